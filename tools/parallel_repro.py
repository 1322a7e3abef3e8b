"""`dvc repro` whose stage commands run as tasks on a Dask `distributed` cluster.

DVC stays the judge, in this one process (the driver) and one stage at a time: DVC's own stage
objects check staleness, remove the outputs, restore from the run cache, save the deps, and after
the command hash, commit and write dvc.lock (`prepare` and `commit` below). Only the commands run
on the cluster: each stage's commands become one task, submitted once every stage it depends on
has finished, as with `dvc repro`; outputs and `dvc.lock` are therefore a serial run's. The
driver's CPU comes out of the stages' on a small machine, so it is kept light: the local cluster's
own monitors run seldom (`QUIET_LOCAL_CLUSTER`) and dvc.lock, which DVC rewrites after each stage,
is not parsed again right after the driver wrote it (`lock_parsed_once`).

Resources (Dask worker resources decide where and beside what a task runs):
- `threads`: a worker offers its thread budget. A single-threaded stage asks for 1; any other asks
  for a worker's whole budget, so it runs alone there. Single-threaded: its dvc.yaml
  `meta: {threads: 1}` (a data step, which no param gives a thread count), or without one, every
  `threads` key (or `eval_threads` and the like) among its declared params is 1.
- `GPU`: a stage asks for one when its declared `runtime.device` param (what its own code hands to
  `pipeline.device.select_device`) is `cuda`/`cuda:N`, or `auto` while the cluster offers GPUs.
  The param, not a dvc.yaml flag: the scheduler and the stage then read the same setting, and
  `auto` keeps meaning "CUDA when available". The worker gives the command its own
  CUDA_VISIBLE_DEVICES (one GPU per worker, as with dask-cuda or a one-GPU SLURM job); a stage
  that asked for none gets CUDA_VISIBLE_DEVICES="".
- `memory_gb`: asked for when dvc.yaml says `meta: {memory_gb: N}`; the local cluster's workers
  offer the machine's memory shared out among them.

The default cluster is a LocalCluster sized to this machine (`local_worker_specs`): without GPUs
one worker with `--jobs` threads (default: the CPU count), so on 2 cores two single-threaded stages
run at once and the others alone, as before Dask; with N GPUs (`nvidia-smi -L`, or
CUDA_VISIBLE_DEVICES when set; torch is not imported here) N worker processes, one GPU each, the
cores shared out. `--address tls://host:port` uses a running scheduler instead (dask-jobqueue,
dask-kubernetes: docs/cluster.md).

The network (Dask's comms are unauthenticated without TLS, and a worker runs whatever it is sent):
the local cluster, its scheduler, its workers (the in-process one and the GPU Nanny processes) and
their dashboards listen on 127.0.0.1 only; `--dashboard HOST:PORT` opens the scheduler's dashboard
elsewhere, with a warning (it shows every stage's command and log). `--address` to a scheduler on
another machine must be `tls://`, with certificates from Dask's config (`distributed.comm.tls.*`,
or its DASK_DISTRIBUTED__COMM__TLS__* environment variables); plain `tcp://` is refused before
anything runs (`check_address`) unless `--insecure` says the network is trusted, which the run then
prints.

Before anything is written the run checks that it can work (`SetupError`, each check within
CONNECT_TIMEOUT_S): the scheduler answers and has a worker, every worker sees the project at the
same path with the same code (git HEAD and a hash of the tracked .py files,
`stage_worker.project_fingerprint`; a worker that does not answer, as on a hung mount, is named),
and every stage's resources are offered by some worker.

Output: a worker appends its commands' output to `.dvc/tmp/stage-logs/<stage>.log` on the shared
filesystem and the driver tails it: each line labelled `[stage]`, progress bars thinned. A file
costs the scheduler nothing, works on any shared mount and keeps what a dead worker printed.

Faults: a task whose worker dies is run again on another one (the scheduler's `allowed-failures`,
1 on the local cluster; an external scheduler's own setting decides there) and a task that raises
is retried once (`retries=1`): a command its machine ended (killed by a signal the driver did not
send, or its worker shutting down: `stage_worker.interrupted`) raises, whichever of the worker and
the command went first; a killed worker's command gets SIGTERM rather than running on beside its
retry (`stage_worker.DIE_WITH_WORKER`). A finished task is released at once, so that its worker
dying later cannot run a locked stage again. DVC's part is not repeated, so a retry does not
remove outputs; a training's checkpoint folder is a `persist: true` output, which `remove_outs`
never deletes anyway, so the retried training resumes from its `last.pt` (saved every epoch, and
mid-epoch on SIGTERM). A failed stage starts nothing more; the run ends with 1 once the running stages end, and
dvc.lock holds exactly the stages that finished. SIGINT / SIGTERM to the driver goes, once, to
every running command's process group on every worker (`stage_worker.stop_commands`); the run
ends with 128 + the signal's number.

    python -m tools.parallel_repro [--jobs N] [--dashboard HOST:PORT]
                                   [--address tls://host:port [--insecure]] [-f] [-s] [targets...]
"""

from __future__ import annotations

import argparse
import codecs
import contextlib
import importlib.util
import io
import ipaddress
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from pathlib import Path

from tools import stage_worker

ALONE, SHARED = "alone", "shared"  # how a stage's command may run: by itself or beside others
PROGRESS_EVERY_S = 30.0  # how often a concurrent stage's progress bar (lines ended by \r) is echoed
CONNECT_TIMEOUT_S = 30  # to reach the scheduler; as long again for a first worker, and for
# every worker to say which project it sees
LOG_DIR = ".dvc/tmp/stage-logs"  # DVC's tmp: neither git nor DVC track it
LOOPBACK = "127.0.0.1"  # where the local cluster listens: this machine only
LOOPBACK_ANY_PORT = f"{LOOPBACK}:0"  # a free port (a fixed one may be taken), loopback only
ENCRYPTED_SCHEMES = {"tls", "wss"}  # Dask comms that authenticate both ends with certificates
TLS_SETTINGS = ("Dask's config (distributed.comm.tls.ca-file, .client.cert, .client.key) or the "
                "environment (DASK_DISTRIBUTED__COMM__TLS__CA_FILE, ..._CLIENT__CERT, "
                "..._CLIENT__KEY)")


class SetupError(RuntimeError):
    """The cluster cannot run this pipeline; raised before anything is written."""


def thread_counts(params: Mapping[str, object]) -> list[object]:
    """The value of every `threads` (or `..._threads`) key among a stage's declared params,
    sections included: {"train_baseline": {"seed": 0, "threads": 1}, "eval.cpu": {"threads": 2},
    "short_term_models.cpu.eval_threads": 2} -> [1, 2, 2]."""
    counts = []
    for key, value in params.items():
        if isinstance(value, Mapping):
            counts += thread_counts(value)
        elif str(key).split(".")[-1].endswith("threads"):
            counts.append(value)
    return counts


def sharing(params: Mapping[str, object]) -> str:
    """SHARED if every `threads` key the stage declares is 1 (and it declares one), else ALONE."""
    counts = thread_counts(params)
    return SHARED if counts and all(count == 1 for count in counts) else ALONE


def ready(order: list[str], upstream: Mapping[str, set[str]], finished: set[str],
          started: set[str]) -> list[str]:
    """The stages of `order` not started yet whose upstream stages have all finished, in order."""
    return [name for name in order
            if name not in started and upstream.get(name, set()) <= finished]


def echo_output(name: str, stream, prefix: bool) -> None:
    """Copy a child's output to ours; beside other stages each line carries `[stage]` and a
    progress bar's redraws (lines ended by \\r) are shown every PROGRESS_EVERY_S seconds only."""
    last_progress, pending = 0.0, ""
    decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")  # a character may span reads
    while chunk := stream.read1(65536):
        text = pending + decoder.decode(chunk)
        if not prefix:
            sys.stdout.write(text)
            sys.stdout.flush()
            pending = ""
            continue
        pieces = text.replace("\r\n", "\n").split("\n")
        pending = pieces.pop()
        for line in pieces:
            sys.stdout.write(f"[{name}] {line.split(chr(13))[-1]}\n")
        if "\r" in pending:  # a progress redraw: keep its latest state
            *_, pending = pending.split("\r")
            if time.monotonic() - last_progress > PROGRESS_EVERY_S and pending.strip():
                sys.stdout.write(f"[{name}] {pending}\n")
                last_progress = time.monotonic()
        sys.stdout.flush()
    if pending.strip():
        sys.stdout.write(f"[{name}] {pending}\n" if prefix else pending)
        sys.stdout.flush()


def stage_resources(kind: str, device: object, memory_gb: object, whole_threads: int,
                    cluster_has_gpus: bool) -> dict[str, float]:
    """The Dask resources a stage's task asks for: 1 thread (SHARED) or a worker's whole budget
    (ALONE); a GPU for a `runtime.device` of cuda / cuda:N, or of auto on a cluster with GPUs;
    `memory_gb` if declared."""
    wanted: dict[str, float] = {"threads": 1 if kind == SHARED else whole_threads}
    device = str(device) if device is not None else "cpu"
    if device.startswith("cuda") or (device == "auto" and cluster_has_gpus):
        wanted["GPU"] = 1
    if memory_gb is not None:
        wanted["memory_gb"] = float(memory_gb)
    return wanted


def unplaceable(wanted: Mapping[str, Mapping[str, float]],
                offered: Mapping[str, Mapping[str, float]]) -> list[str]:
    """The stages (of `wanted`: stage -> resources) no single worker (of `offered`: address ->
    resources) can take."""
    return [name for name, resources in wanted.items()
            if not any(all(offer.get(key, 0) >= amount for key, amount in resources.items())
                       for offer in offered.values())]


def fingerprint_differences(driver: Mapping[str, object], worker: Mapping[str, object],
                            root: str) -> list[str]:
    """What a worker's view of the project differs in from the driver's (empty: the same)."""
    if not worker.get("project"):
        return [f"no DVC project at {root}"]
    return [f"{key} {worker.get(key)} (driver: {driver.get(key)})"
            for key in ("git_head", "python_sha256") if worker.get(key) != driver.get(key)]


def visible_gpus(cuda_visible_devices: str | None, nvidia_smi_listing: str) -> list[str]:
    """The GPU ids this machine offers: CUDA_VISIBLE_DEVICES when set ("" or "-1": none), else
    the `GPU n:` lines of `nvidia-smi -L`."""
    if cuda_visible_devices is not None:
        ids = [item.strip() for item in cuda_visible_devices.split(",") if item.strip()]
        return [] if ids[:1] == ["-1"] else ids
    return re.findall(r"^GPU (\d+):", nvidia_smi_listing, flags=re.MULTILINE)


def local_worker_specs(cores: int, gpus: list[str], memory_gb: float) -> list[dict]:
    """Worker options (Nanny's) for a LocalCluster sized to this machine: one worker with every
    core when there is no GPU; else one per GPU, that GPU its CUDA_VISIBLE_DEVICES, the cores and
    memory shared out."""
    count = max(len(gpus), 1)
    threads = max(cores // count, 1)
    specs = []
    for gpu in gpus or [None]:
        resources = {"threads": threads, "memory_gb": round(memory_gb / count, 1)}
        spec = {"nthreads": threads, "resources": resources}
        if gpu is not None:
            resources["GPU"] = 1
            spec["env"] = {"CUDA_VISIBLE_DEVICES": gpu}
        specs.append(spec)
    return specs


def machine_gpus() -> list[str]:
    """`visible_gpus` of this machine."""
    listing = ""
    if "CUDA_VISIBLE_DEVICES" not in os.environ and shutil.which("nvidia-smi"):
        listing = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True).stdout
    return visible_gpus(os.environ.get("CUDA_VISIBLE_DEVICES"), listing)


# Dask's own periodic work, sampled seldom on the local cluster: the workers' statistical profiler
# (every 10 ms by default), event-loop health ticks (20 ms), the system monitor (0.5 s, the
# dashboard's machine plots) and the memory monitor (0.1 s). Nothing here uses them (a task only
# waits on a child process), and at their defaults an idle local cluster takes some 5 % of a core
# from the stages beside it, at these 0.5 % (docs/experiments/dask_runner_idle.py).
QUIET_LOCAL_CLUSTER = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "5s",
}


def start_local_cluster(cores: int, gpus: list[str] | None = None,
                        dashboard: str = LOOPBACK_ANY_PORT):
    """The default cluster: `local_worker_specs` of this machine (its `machine_gpus` unless
    `gpus` says). Without GPUs its one worker runs in this process (its tasks only wait on child
    processes); GPU workers are processes, each with its CUDA_VISIBLE_DEVICES. Everything listens
    on loopback only, but the scheduler's dashboard where `dashboard` (HOST:PORT) says; its plots
    need bokeh."""
    import dask
    import psutil
    from distributed import LocalCluster, Nanny, Scheduler, SpecCluster

    gpus = machine_gpus() if gpus is None else gpus
    specs = local_worker_specs(cores, gpus, psutil.virtual_memory().total / 2**30)
    with dask.config.set({"distributed.scheduler.allowed-failures": 1, **QUIET_LOCAL_CLUSTER}):
        if not gpus:  # scheduler and worker talk in-process (inproc://): only their HTTP listens
            return LocalCluster(n_workers=1, threads_per_worker=specs[0]["nthreads"],
                                resources=specs[0]["resources"], processes=False,
                                dashboard_address=dashboard,
                                worker_dashboard_address=LOOPBACK_ANY_PORT)
        scheduler = {"cls": Scheduler,
                     "options": {"host": LOOPBACK, "dashboard_address": dashboard}}
        # config: a worker its Nanny restarts (after the OOM killer) stays quiet too; the Nanny's
        # own copy of Dask's config shares the nested dicts this `with` puts back on exit
        workers = {f"gpu{gpu}": {"cls": Nanny, "options": {
            **spec, "host": LOOPBACK, "dashboard_address": LOOPBACK_ANY_PORT,
            "config": QUIET_LOCAL_CLUSTER}} for gpu, spec in zip(gpus, specs)}
        return SpecCluster(workers=workers, scheduler=scheduler, name="ynet-repro")


def scheme_and_host(address: str) -> tuple[str, str]:
    """A Dask address's protocol and host, as Dask reads it (a bare host:port is tcp):
    "tls://[::1]:8786" -> ("tls", "::1"); inproc -> ("inproc", "")."""
    from distributed.comm.addressing import parse_address, parse_host_port

    scheme, location = parse_address(address, strict=False)
    if scheme == "inproc":
        return scheme, ""
    try:
        return scheme, parse_host_port(location, default_port=0)[0]
    except ValueError as error:
        raise SetupError(f"--address {address!r} is not a Dask scheduler address "
                         f"(tls://host:port): {error}") from None


def is_loopback(host: str) -> bool:
    """127.0.0.0/8, ::1 or `localhost`: reachable from this machine only. Any other name counts
    as the network; it is not looked up (no traffic before the address is accepted)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def plain_network(address: str) -> bool:
    """Whether `address` reaches another machine without TLS (tcp://, ws://, ucx://, host:port):
    unauthenticated and unencrypted, so whoever reaches it can run code on the workers."""
    scheme, host = scheme_and_host(address)
    return scheme not in ENCRYPTED_SCHEMES | {"inproc"} and not is_loopback(host)


def address_refusal(address: str, insecure: bool) -> str | None:
    """Why `--address` is refused (None: it is not): plain TCP to another machine without
    `--insecure`."""
    if insecure or not plain_network(address):
        return None
    from distributed.comm.addressing import parse_address

    location = parse_address(address, strict=False)[1]
    return (f"refusing the Dask scheduler at {address}: plain TCP to another machine is "
            f"unauthenticated and unencrypted, so anyone who can reach that scheduler or its "
            f"workers can run code on them. Start it with TLS and use tls://{location}, its "
            f"certificates named in {TLS_SETTINGS}, as docs/cluster.md shows; or, on a network "
            f"you trust, add --insecure (make repro DASK_INSECURE=1)")


def insecure_notice(address: str, insecure: bool) -> str | None:
    """What the run prints when `--insecure` lets plain TCP to another machine through."""
    if not (insecure and plain_network(address)):
        return None
    return (f"parallel_repro: --insecure: the Dask scheduler at {address} is reached over plain "
            f"TCP, unauthenticated and unencrypted: anyone on that network can run code on its "
            f"workers. Only on a network you trust (docs/cluster.md)")


def missing_tls_settings(ca_file: str | None, client_cert: str | None) -> str | None:
    """What a tls:// address lacks to connect (None: nothing): the CA that signed the cluster's
    certificates and the driver's own certificate (its key may be in the same file)."""
    wanted = {"a CA file": ca_file, "a client certificate": client_cert}
    missing = [name for name, value in wanted.items() if not value]
    if not missing:
        return None
    return f"{' and '.join(missing)}: set {TLS_SETTINGS}"


def check_address(address: str, insecure: bool = False):
    """The Security to reach `address` with (Dask's config; None but for tls:// and wss://), or a
    SetupError, before anything runs: plain TCP to another machine without `insecure`, or TLS
    without certificates."""
    scheme, _ = scheme_and_host(address)
    refusal = address_refusal(address, insecure)
    if refusal:
        raise SetupError(refusal)
    if scheme not in ENCRYPTED_SCHEMES:
        return None
    from distributed import Security

    security = Security()  # distributed.comm.tls.*, from Dask's config files and environment
    missing = missing_tls_settings(security.tls_ca_file, security.tls_client_cert)
    if missing:
        raise SetupError(f"the Dask scheduler at {address} needs TLS certificates: {missing}")
    return security


def dashboard_notice(dashboard: str) -> str | None:
    """What the run prints when the local dashboard listens beyond loopback ("" or 0.0.0.0: on
    every interface)."""
    host = dashboard.rsplit(":", 1)[0].strip("[]") if ":" in dashboard else dashboard
    if is_loopback(host):
        return None
    return (f"parallel_repro: the Dask dashboard listens on {dashboard}, open to the network: "
            f"without any login, whoever reaches it sees every stage's command and log and the "
            f"workers' logs (docs/cluster.md)")


def dashboard_link(host: str, port: int) -> str:
    """The dashboard's address to open in a browser: the host it listens on, or this machine's
    name when that is every interface."""
    import socket

    if host in ("", "0.0.0.0", "::"):
        host = socket.gethostname()
    return f"http://[{host}]:{port}/status" if ":" in host else f"http://{host}:{port}/status"


def local_dashboard_link(cluster) -> str | None:
    """`dashboard_link` of a local cluster's scheduler (in this process), None if it has none.
    Dask's own link names the machine's address even when the dashboard is on loopback."""
    server = getattr(getattr(cluster, "scheduler", None), "http_server", None)
    return dashboard_link(server.address, server.port) if server is not None else None


def connect(address: str, timeout: float, security=None):
    """A client of the scheduler at `address` (with `security` for tls://) with at least one
    worker, or SetupError naming it."""
    from distributed import Client

    try:
        client = Client(address, timeout=timeout, set_as_default=False, security=security)
    except (OSError, TimeoutError) as error:
        raise SetupError(f"cannot reach the Dask scheduler at {address} within {timeout:.0f} s "
                         f"({type(error).__name__}: {error})") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        client.close()
        raise SetupError(f"the Dask scheduler at {address} has no worker "
                         f"(none joined within {timeout:.0f} s)") from None
    return client


def fingerprints(client, root: str, timeout: float) -> dict[str, object]:
    """Each worker's `stage_worker.project_fingerprint` of `root`, or what it raised, or a
    TimeoutError if it has not answered within `timeout` (a hung shared mount never does): one
    question per worker, so the silent ones can be named."""
    addresses = sorted(client.scheduler_info()["workers"])
    answers: dict[str, object] = {}

    def ask(address: str) -> None:
        try:
            answers.update(client.run(stage_worker.project_fingerprint, root, workers=[address],
                                      on_error="return"))
        except Exception as error:  # the connection went (the client closed after a time-out)
            answers[address] = error

    askers = [threading.Thread(target=ask, args=(address,), daemon=True) for address in addresses]
    deadline = time.monotonic() + timeout
    for asker in askers:
        asker.start()
    for asker in askers:
        asker.join(max(deadline - time.monotonic(), 0))
    silent = TimeoutError(f"no answer within {timeout:.0f} s (is the shared filesystem hung?)")
    return {address: answers.get(address, silent) for address in addresses}


def check_workers(client, root: str, timeout: float = CONNECT_TIMEOUT_S
                  ) -> dict[str, dict[str, float]]:
    """Every worker's resources, once every worker sees the project as the driver does; else
    SetupError naming each worker and what differs, within `timeout`."""
    driver = stage_worker.project_fingerprint(root)
    seen = fingerprints(client, root, timeout)
    problems = []
    for address, fingerprint in seen.items():
        if isinstance(fingerprint, BaseException):
            problems.append(f"worker {address}: {type(fingerprint).__name__}: {fingerprint}")
            continue
        for difference in fingerprint_differences(driver, fingerprint, root):
            problems.append(f"worker {address} ({fingerprint.get('host')}): {difference}")
    if problems:
        raise SetupError("workers must see this project on a shared filesystem, at the same path, "
                         "with the same code (docs/cluster.md):\n  " + "\n  ".join(problems))
    workers = client.scheduler_info()["workers"]
    return {address: dict(workers[address].get("resources") or {})
            for address in seen if address in workers}  # one that joined since is not checked


def cluster_line(client, offered: Mapping[str, Mapping[str, float]],
                 link: str | None = None) -> str:
    """What the run prints first: the scheduler, its workers' resources and where its dashboard
    is (`link`, else Dask's; its plots need bokeh: the `[cluster]` extra)."""
    info = client.scheduler_info()
    port = (info.get("services") or {}).get("dashboard")
    dashboard = (link or client.dashboard_link) if port else "none"
    if port and importlib.util.find_spec("bokeh") is None:
        dashboard += " (its plots need bokeh: pip install -c requirements.lock -e '.[cluster]')"
    workers = ", ".join(str(dict(resources)) for resources in offered.values())
    return (f"Dask scheduler {info.get('address')}: {len(offered)} worker(s) {workers}; "
            f"dashboard: {dashboard}")


@contextlib.contextmanager
def lock_parsed_once():
    """DVC records each finished stage by reading the whole dvc.lock round-trip (ruamel, comments
    kept), changing the stage's entry and dumping the whole file again: for our ~225-stage lock
    some 2-3.5 s of parsing and 1.5 s of dumping, in the driver, while the stages beside it want
    the cores. Here one process writes the lock, so the text it reads next is the text it just
    dumped: within this context the data just dumped to a file is handed back for exactly that
    file and text instead of parsing it again (once: a failed update in between, or any other
    file written, leaves nothing to hand back). The dump itself is DVC's, unchanged, so the same
    bytes are written."""
    from dvc.utils.serialize import _yaml

    parse, dump = _yaml.parse_yaml_for_update, _yaml._dump
    last = None  # (file, text dumped there, the data dumped), until the next parse

    def dump_remembered(data, stream):
        nonlocal last
        buffer = io.StringIO()
        result = dump(data, buffer)
        text = buffer.getvalue()
        stream.write(text)
        name = getattr(stream, "name", None)
        last = ((os.path.abspath(name), text, data) if isinstance(name, (str, os.PathLike))
                else None)  # a file, not a buffer
        return result

    def parse_unless_just_dumped(text, path):
        nonlocal last
        kept, last = last, None
        if kept is not None and kept[:2] == (os.path.abspath(path), text):
            return kept[2]
        return parse(text, path)

    _yaml.parse_yaml_for_update, _yaml._dump = parse_unless_just_dumped, dump_remembered
    try:
        yield
    finally:
        _yaml.parse_yaml_for_update, _yaml._dump = parse, dump


class LogTail:
    """A stage's log file read as it grows (`read1`, as `echo_output` reads a pipe): returns b""
    only once `done` is set and everything written has been read."""

    def __init__(self, path: Path, done: threading.Event):
        self.path, self.done, self.file = path, done, None

    def read1(self, size: int) -> bytes:
        while True:
            finished = self.done.is_set()  # before reading: what came before it is then read
            if self.file is None and self.path.exists():
                self.file = self.path.open("rb")
            chunk = self.file.read(size) if self.file is not None else b""
            if chunk or finished:
                return chunk
            time.sleep(0.2)


def run_stages(targets: list[str], force: bool = False, jobs: int = 2, single_item: bool = False,
               on_stage_done: Callable[[str, float], None] | None = None,
               root: str = ".", address: str | None = None,
               connect_timeout: float = CONNECT_TIMEOUT_S, insecure: bool = False,
               dashboard: str | None = None) -> tuple[int, dict[str, float]]:
    """Reproduce `targets` (all stages if none) and what they depend on (with `single_item`, the
    targets alone, as `dvc repro --single-item`) on the cluster at `address` (`check_address`;
    `insecure` lets plain TCP to another machine through), or on a LocalCluster with `jobs`
    threads and its dashboard at `dashboard` (default: loopback); (exit code, wall seconds of each
    stage that ran: DVC's part plus the command's). `on_stage_done(name, seconds)` follows each
    lock update. Raises SetupError before anything is written if the cluster cannot run these
    stages, and before anything runs if `address` is refused."""
    import cloudpickle
    from distributed import Client
    from dvc.repo import Repo, lock_repo
    from dvc.repo.reproduce import collect_stages, plan_repro

    security = None
    if address is not None:
        if dashboard is not None:
            raise SetupError(f"--dashboard is for the local cluster; the scheduler at {address} "
                             f"serves its own")
        security = check_address(address, insecure)
    for notice in (insecure_notice(address, insecure) if address else None,
                   dashboard_notice(dashboard) if dashboard else None):
        if notice:
            print(notice, file=sys.stderr, flush=True)
    repo = Repo(root)
    with lock_repo(repo):
        graph = repo.index.graph
        chosen = collect_stages(repo, targets) if targets else None
        planned = chosen if single_item and chosen else plan_repro(graph, chosen)
        stages = {stage.addressing: stage for stage in planned if stage.cmd and not stage.frozen}
        # dvc's graph has an edge from a stage to each stage that produces one of its deps
        upstream = {name: {dep.addressing for dep in graph.successors(stage)} & set(stages)
                    for name, stage in stages.items()}
        params = {name: params_of(stage) for name, stage in stages.items()}  # read once each
        declared = {name: (sharing(declared_threads(stage, params[name])),
                           declared_device(params[name]), meta_of(stage).get("memory_gb"))
                    for name, stage in stages.items()}

    # workers need not import tools/: client.run's functions and the plugin go by value (the
    # stage's task too, through ByValue, as a task graph is pickled another way)
    cloudpickle.register_pickle_by_value(stage_worker)
    cluster = (start_local_cluster(jobs, dashboard=dashboard or LOOPBACK_ANY_PORT)
               if address is None else None)
    try:
        client = (Client(cluster, set_as_default=False) if cluster is not None
                  else connect(address, connect_timeout, security))
    except BaseException:
        if cluster is not None:
            cluster.close()
        raise
    try:
        offered = check_workers(client, repo.root_dir, connect_timeout)
        link = local_dashboard_link(cluster) if cluster is not None else None
        print(cluster_line(client, offered, link), flush=True)
        whole = min(int(offer.get("threads", 1)) for offer in offered.values())
        has_gpus = any(offer.get("GPU", 0) >= 1 for offer in offered.values())
        wanted = {name: stage_resources(kind, device, memory, whole, has_gpus)
                  for name, (kind, device, memory) in declared.items()}
        missing = unplaceable(wanted, offered)
        if missing:
            raise SetupError("no worker offers what these stages need: " + "; ".join(
                f"stage '{name}' needs {wanted[name]}" for name in missing)
                + f" (workers offer: {sorted(offered.values(), key=str)})")
        client.register_plugin(stage_worker.StageCommands(), name=stage_worker.PLUGIN_NAME)
        prefix = sum(int(offer.get("threads", 1)) for offer in offered.values()) > 1
        runner = StageRunner(client, repo, stages, wanted, force, prefix, on_stage_done)
        # as_current: distributed.wait looks for the client there
        with client.as_current(), lock_parsed_once():
            return runner.run(list(stages), upstream)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


class ByValue:
    """`func`, pickled by value (cloudpickle) even inside a task graph: Dask pickles a graph with
    plain pickle, which names a function's module, and the scheduler (which unpickles graphs) and
    the workers of an existing cluster cannot import tools/."""

    def __init__(self, func: Callable):
        self.func = func

    def __call__(self, *args, **kwargs):
        return self.func(*args, **kwargs)

    def __reduce__(self):
        import cloudpickle

        cloudpickle.register_pickle_by_value(sys.modules[self.func.__module__])
        return cloudpickle.loads, (cloudpickle.dumps(self.func),)


class StageRunner:
    """One run: DVC's part of each stage here (`prepare`, `commit`), its commands on the cluster
    (`submit`), and the loop that starts what is ready and collects what finished."""

    def __init__(self, client, repo, stages, wanted, force, prefix, on_stage_done):
        self.client, self.repo, self.stages, self.wanted = client, repo, stages, wanted
        self.force, self.prefix, self.on_stage_done = force, prefix, on_stage_done
        self.log_dir = Path(repo.root_dir) / LOG_DIR
        self.finished: set[str] = set()
        self.seconds: dict[str, float] = {}
        self.running: dict = {}  # future -> (stage name, DVC seconds so far, tail's event, thread)
        self.stop_signal: int | None = None

    def prepare(self, name: str) -> float | None:
        """DVC's part before the command: None if the stage is done here (unchanged, or restored
        from the run cache), else DVC's seconds so far (the outputs removed, the deps saved)."""
        from dvc.repo import lock_repo
        from dvc.stage.cache import RunCacheNotFoundError

        stage = self.stages[name]
        with lock_repo(self.repo):
            if not self.force and not stage.changed():
                print(f"Stage '{name}' didn't change, skipping", flush=True)
                self.finished.add(name)
                return None
            print(f"Running stage '{name}':", flush=True)
            since = time.monotonic()
            # persist outputs (training checkpoints) are kept: force=False only unprotects them
            stage.remove_outs(ignore_remove=False, force=False)
            if not self.force:
                try:
                    stage.repo.stage_cache.restore(stage)
                except RunCacheNotFoundError:
                    stage.save_deps()
                else:
                    self.commit(name, time.monotonic() - since)
                    return None
        return time.monotonic() - since

    def commit(self, name: str, seconds: float) -> None:
        """DVC's part after the command: hash, commit, and the stage's dvc.lock entry."""
        from dvc.repo import lock_repo

        stage = self.stages[name]
        since = time.monotonic()
        with lock_repo(self.repo):
            stage.save()
            stage.commit()
            stage.dump(update_pipeline=False)
        self.seconds[name] = seconds + time.monotonic() - since
        self.finished.add(name)
        print(f"Updating lock file 'dvc.lock' ({name}: {self.seconds[name]:.0f} s)", flush=True)
        if self.on_stage_done is not None:
            self.on_stage_done(name, self.seconds[name])

    def submit(self, name: str, dvc_seconds: float) -> None:
        """The stage's commands as one task, with its resources; its log tailed to our stdout."""
        from dvc.stage.run import _enforce_cmd_list, _make_cmd, get_executable, prepare_kwargs

        stage = self.stages[name]
        kwargs = prepare_kwargs(stage)
        env = {key: value for key, value in kwargs["env"].items() if key.startswith("DVC_")}
        commands = [(line, _make_cmd(get_executable(), line))
                    for line in _enforce_cmd_list(stage.cmd)]
        self.log_dir.mkdir(parents=True, exist_ok=True)
        log = self.log_dir / (re.sub(r"[^\w@.-]", "_", name) + ".log")
        log.write_bytes(b"")
        future = self.client.submit(
            ByValue(stage_worker.run_commands), commands, kwargs["cwd"], env, str(log),
            "GPU" in self.wanted[name], key=f"stage-{name}-{uuid.uuid4().hex[:8]}",
            resources=self.wanted[name], retries=1, pure=False)
        done = threading.Event()
        echo = threading.Thread(target=echo_output, args=(name, LogTail(log, done), self.prefix),
                                daemon=True)
        echo.start()
        self.running[future] = (name, dvc_seconds, done, echo)

    def start_ready(self, order: list[str], upstream: Mapping[str, set[str]],
                    started: set[str]) -> None:
        """Start every stage whose upstream stages have finished (one finished here at once, by
        the run cache or unchanged, may make more ready)."""
        while fresh := ready(order, upstream, self.finished, started):
            for name in fresh:
                started.add(name)
                dvc_seconds = self.prepare(name)
                if dvc_seconds is not None:
                    self.submit(name, dvc_seconds)

    def collect(self, future) -> bool:
        """A finished task: lock its stage if every command succeeded; whether it did."""
        name, dvc_seconds, done, echo = self.running.pop(future)
        done.set()
        echo.join()
        if future.status != "finished":
            print(f"ERROR: failed to reproduce '{name}': {future.exception()!r}", flush=True)
            return False
        result = future.result()
        future.release()  # the scheduler forgets it: a worker lost later does not rerun the stage
        if result["code"] != 0:
            print(f"ERROR: failed to reproduce '{name}': exited with {result['code']}",
                  flush=True)
            return False
        if not result["complete"]:
            return False  # stopped between two of its commands: unfinished, so not locked
        self.commit(name, dvc_seconds + result["seconds"])
        return True

    def run(self, order: list[str], upstream: Mapping[str, set[str]]) -> tuple[int, dict]:
        from distributed import wait

        def on_signal(signum, _frame):
            # only noted: the loop passes it on once, from the main thread, not inside a handler
            if self.stop_signal is None:
                self.stop_signal = signum

        previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
        started: set[str] = set()
        failed, passed_on = False, False
        try:
            self.start_ready(order, upstream, started)
            while self.running:
                if self.stop_signal is not None and not passed_on:
                    passed_on = True
                    self.client.run(stage_worker.stop_commands, self.stop_signal,
                                    on_error="ignore")
                try:
                    wait(list(self.running), timeout=0.5, return_when="FIRST_COMPLETED")
                except TimeoutError:
                    continue
                for future in [f for f in self.running if f.done()]:
                    failed |= not self.collect(future)
                if not failed and self.stop_signal is None:
                    self.start_ready(order, upstream, started)
        finally:
            for future, (_, _, done, echo) in self.running.items():
                future.cancel()
                done.set()
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        if self.stop_signal is not None:
            return 128 + self.stop_signal, self.seconds
        return (1 if failed else 0), self.seconds


def meta_of(stage) -> Mapping[str, object]:
    """A stage's dvc.yaml `meta` (DVC ignores it; here it may say `threads` and `memory_gb`)."""
    return stage.meta if isinstance(stage.meta, Mapping) else {}


def declared_threads(stage, params: Mapping[str, object]) -> Mapping[str, object]:
    """What `sharing` reads of a stage: its dvc.yaml `meta: {threads: N}` if it has one (what a
    data step says of itself; a data step may declare another stage's `threads` param to pass it
    on, as ynet_slot_scoring does), else its declared params (`params_of`)."""
    meta = meta_of(stage)
    return {"meta.threads": meta["threads"]} if "threads" in meta else params


def declared_device(params: Mapping[str, object]) -> object:
    """The `runtime.device` among a stage's declared params (`params_of`; None if it declares
    none: it runs no torch)."""
    runtime = params.get("runtime")
    if isinstance(runtime, Mapping):
        return runtime.get("device")
    return params.get("runtime.device")


def params_of(stage) -> dict[str, object]:
    """The values of the params keys `stage` declares (all its params files)."""
    from dvc.dependency.param import ParamsDependency

    values = {}
    for dep in stage.deps:
        if isinstance(dep, ParamsDependency):
            values.update(dep.read_params())
    return values


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("targets", nargs="*", help="stages to reproduce (default: all)")
    parser.add_argument("-f", "--force", action="store_true", help="run even unchanged stages")
    parser.add_argument("-s", "--single-item", action="store_true",
                        help="the targets alone, not what they depend on")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="the local cluster's threads (default: the CPU count)")
    parser.add_argument("--address", help="a running Dask scheduler, tls://host:port with "
                        "certificates from Dask's config (tcp:// on loopback only; default: a "
                        "LocalCluster sized to this machine, on loopback)")
    parser.add_argument("--insecure", action="store_true",
                        help="allow a plain tcp:// --address on another machine: on a network "
                        "you trust only (whoever reaches the cluster can run code on it)")
    parser.add_argument("--dashboard", help="where the local cluster's dashboard listens, "
                        "HOST:PORT (default: 127.0.0.1 and a free port; another host opens it "
                        "to the network: it shows every stage's command and log)")
    args = parser.parse_args(argv)
    try:
        code, seconds = run_stages(args.targets, force=args.force, jobs=args.jobs,
                                   single_item=args.single_item, address=args.address,
                                   insecure=args.insecure, dashboard=args.dashboard)
    except SetupError as error:
        print(f"parallel_repro: {error}", file=sys.stderr)
        return 2
    print(f"parallel_repro: {len(seconds)} stages, exit {code}")
    return code


if __name__ == "__main__":
    sys.exit(main())
