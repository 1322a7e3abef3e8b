"""Stage `train_baseline@<model>-<t_f>`: train one baseline (S-GAN or PECNet) for one horizon.

Trains on the window table's `train` split, keeps the epoch with the lowest min-over-K ADE on its
`val` split (never `test`; `pipeline.harness.baseline_runs`), and writes the checkpoint folder
(`best.pt`, `last.pt`; an interrupted run resumes from `last.pt`) and a JSON of training facts.
SIGTERM / SIGINT or `runtime.max_minutes` save a mid-epoch checkpoint and exit 143 / 130 / 75.
Params: `train_baseline` (seed, threads), `<model>.<profile>`, `profile`, `windows.n_past`,
`runtime.device`, `runtime.max_minutes`.

    python -m pipeline.stages.train_baseline --model pecnet --horizon 30 \
        --table data/horizon_windows/tf30.parquet --checkpoint-dir checkpoints/pecnet_tf30 \
        --metrics metrics/baselines/train_pecnet_tf30.json
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch

from pipeline.config import (RuntimeParams, TrainBaselineParams, WindowParams, load_section,
                             read_params)
from pipeline.device import describe, select_device
from pipeline.harness import baselines
from pipeline.harness.baseline_runs import model_config, train
from pipeline.harness.baselines.common import load_windows
from pipeline.io import write_json
from pipeline.preemption import Preemption, exit_when_stopped


@exit_when_stopped
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, choices=baselines.TRAINABLE)
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True, help="JSON of training facts")
    args = parser.parse_args(argv)
    all_params = read_params()
    params = load_section(TrainBaselineParams, "train_baseline", all_params)
    config = model_config(args.model, all_params)
    n_past = load_section(WindowParams, "windows", all_params).n_past
    runtime = load_section(RuntimeParams, "runtime", all_params)
    torch.set_num_threads(params.threads)
    device = select_device(runtime.device)
    print(f"train_baseline {args.model} t_f = {args.horizon}: {describe(device)}", flush=True)

    arrays = load_windows(args.table, n_past, args.horizon)
    t0 = time.perf_counter()
    with Preemption(runtime.max_minutes) as preemption:
        facts = train(args.model, arrays, config, args.checkpoint_dir, params.seed, device, preemption)
    write_json({
        "model": args.model, "horizon": args.horizon, "profile": all_params["profile"], "seed": params.seed,
        "threads": params.threads, "device": describe(device), "wall_seconds": time.perf_counter() - t0,
        **facts,
    }, args.metrics)


if __name__ == "__main__":
    main()
