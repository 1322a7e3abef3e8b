"""How many aten ops Y-net scoring's CUDA path dispatches per window, and where it waits for the
host, counted on the CPU (issue 62; docs/experiments/2026-11-28-gpu-scoring-cpu-path.md).

Scores `--windows` synthetic windows of one scene (`bench.bench_profiles.ScoringBench`, seeded)
with the `paper` profile's scoring (K_e 20, K_a 1, TTST + CWS, batch 4, chunk 8) through
`ynet_scoring.predict_scenes`, with the choices CUDA makes (`kmeans_check_every`, and
`ttst_windows` where the code has it) made on the CPU, under `tests/sync_audit.py`'s counter (every
dispatched operator, views included). Runs against whatever code `PYTHONPATH` points at:

    PYTHONPATH=<checkout> python -m docs.experiments.gpu_scoring_ops [--windows 32] [--channels tiny|paper]
"""
from __future__ import annotations

import argparse
import dataclasses
import time
from collections import Counter

import torch

from bench.bench_profiles import ScoringBench, main_options, profile_settings
from bench.common import tiny_ynet
from pipeline.config.loading import read_params
from pipeline.device import CPU
from pipeline.runners import ynet_scoring
from tests.sync_audit import SyncAudit

CUDA = torch.device("cuda")


def count(windows: int, channels: str) -> tuple[SyncAudit, float]:
    torch.set_num_threads(1)
    params = read_params()
    settings, evaluation = profile_settings(params, "paper", 1)
    if channels == "tiny":
        settings = tiny_ynet(settings)
    evaluation = dataclasses.replace(evaluation, k_e=20, k_a=1)
    torch.manual_seed(0)
    bench = ScoringBench(settings, evaluation, CPU, windows, main_options(evaluation, params),
                         (512, 416))
    check_every = ynet_scoring.kmeans_check_every
    ynet_scoring.kmeans_check_every = lambda device: check_every(CUDA)
    if hasattr(ynet_scoring, "ttst_windows"):  # the code after issue 62
        group = ynet_scoring.ttst_windows
        ynet_scoring.ttst_windows = lambda device, batch: group(CUDA, batch)
    began = time.perf_counter()
    with SyncAudit() as audit:
        bench.run(windows)
    return audit, time.perf_counter() - began


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=32)
    parser.add_argument("--channels", choices=("tiny", "paper"), default="tiny",
                        help="the model's widths (no count depends on them)")
    args = parser.parse_args()
    audit, seconds = count(args.windows, args.channels)
    total = sum(audit.ops.values())
    batches = -(-args.windows // 4)
    waits = Counter(what for what, _ in audit.events)
    print(f"{args.windows} windows ({batches} batches of 4), {args.channels} channels, "
          f"{seconds:.1f} s on the CPU")
    print(f"aten ops: {total} in all, {total / args.windows:.1f} per window")
    print(f"host waits: {dict(waits)}; per batch {sum(waits.values()) / batches:.2f} "
          f"(counting `.cpu().numpy()` once: {(sum(waits.values()) - waits['numpy']) / batches:.2f})")
    print("top 10 ops (count, per window):")
    for op, n in audit.ops.most_common(10):
        print(f"  {n:6d} {n / args.windows:7.1f}  {op}")
    slow = Counter(getattr(audit, "slow", []))
    print(f"ops slow on CUDA in deterministic mode: {dict(slow) if slow else 'none'}"
          if hasattr(audit, "slow") else "")


if __name__ == "__main__":
    main()
