"""How much CPU an idle local Dask cluster takes from the stages beside it: Dask's defaults against
`tools/parallel_repro.py`'s QUIET_LOCAL_CLUSTER, for the cluster `make repro` starts without GPUs
(one worker, in the driver's process). CPU seconds of this process while the cluster idles.

    python -m docs.experiments.dask_runner_idle [--seconds 30]
"""

import argparse
import resource
import time


def idle_cpu_seconds(config: dict, seconds: float) -> float:
    import dask
    from distributed import Client, LocalCluster

    with dask.config.set(config):
        cluster = LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                               dashboard_address=":0")
    client = Client(cluster, set_as_default=False)
    try:
        before = resource.getrusage(resource.RUSAGE_SELF)
        time.sleep(seconds)
        after = resource.getrusage(resource.RUSAGE_SELF)
    finally:
        client.close()
        cluster.close()
    return (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0)
    args = parser.parse_args()
    from tools.parallel_repro import QUIET_LOCAL_CLUSTER

    for name, config in (("dask defaults", {}), ("QUIET_LOCAL_CLUSTER", QUIET_LOCAL_CLUSTER)):
        used = idle_cpu_seconds(config, args.seconds)
        print(f"{name}: {used:.2f} CPU s in {args.seconds:g} s idle "
              f"({100 * used / args.seconds:.1f} % of a core)", flush=True)


if __name__ == "__main__":
    main()
