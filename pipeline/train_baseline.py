"""Stage `train_baseline`: train one baseline (S-GAN or PECNet) for one horizon.

Reads a window table (`pipeline.window_table` schema), trains on its `train` split, keeps the epoch
with the lowest min-over-K ADE on its `val` split (never `test`), and writes the checkpoint
directory (`best.pt`, `last.pt`; an interrupted run resumes from `last.pt`) and a JSON of training
facts. Settings: section `train_baseline` (seed, threads) and the model's own section (`sgan`,
`pecnet`), which holds one config per profile: `cpu` (sized so that every baseline at every
horizon trains in about 30 minutes on 2 cores) and `paper` (upstream's settings, e.g. PECNet 650
epochs); the top-level `profile` key picks one for every stage (`dvc exp run -S profile=paper`).
Section `runtime`: the device trained on, and `max_minutes`. SIGTERM / SIGINT or the time budget
save a mid-epoch checkpoint and exit with 143 / 130 / 75 (`pipeline.preemption`); the next run
continues from it to the same weights as an uninterrupted one.

    python -m pipeline.train_baseline --model pecnet --horizon 30 \
        --table data/horizon_windows/tf30.parquet --checkpoint-dir checkpoints/pecnet_tf30 \
        --metrics metrics/baselines/train_pecnet_tf30.json
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import torch

from pipeline import baselines
from pipeline.baselines.common import load_windows, save_json_atomic, select_split
from pipeline.device import CPU, RuntimeParams, describe, select_device
from pipeline.params import load_profile, load_section, read_params
from pipeline.preemption import NEVER, Preemption, exit_when_stopped
from pipeline.window_table import WindowArrays
from pipeline.windows import WindowParams


@dataclass
class TrainBaselineParams:
    seed: int
    """Seed of all randomness in training (initialisation, batches, noise)."""
    threads: int
    """torch CPU threads."""

    def __post_init__(self):
        if self.threads < 1:
            raise ValueError("threads must be >= 1")


def model_config(model: str, params: dict):
    """The settings of `model` (sections `sgan` / `pecnet`) for the active `profile`."""
    if model not in baselines.TRAINABLE:
        raise ValueError(f"{model!r} is not trained; trainable: {baselines.TRAINABLE}")
    return load_profile(baselines.get(model).config_class, model, params)


def train(model: str, arrays: WindowArrays, config, checkpoint_dir: Path, seed: int,
          device: torch.device = CPU, preemption: Preemption = NEVER) -> dict:
    """Fit `model` on the train split (selecting on val) on `device`; returns the training facts
    (the per-epoch history stays in the checkpoint's last.pt). Raises `StopRequested` (after a
    mid-epoch checkpoint) when `preemption` says so."""
    train_set, val_set = select_split(arrays, "train"), select_split(arrays, "val")
    fitted = baselines.get(model).fit(train_set, val_set, config, checkpoint_dir, seed,
                                      device=device, preemption=preemption)
    result = fitted.fit_result
    return {
        "n_train": len(train_set), "n_val": len(val_set), "epochs": result.epochs,
        "best_epoch": result.best_epoch, "best_val_ade": result.best_val_ade,
        "train_seconds": result.train_seconds,
        "seconds_per_epoch": result.train_seconds / max(result.epochs, 1),
    }


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
    save_json_atomic({
        "model": args.model, "horizon": args.horizon, "profile": all_params["profile"], "seed": params.seed,
        "threads": params.threads, "device": describe(device), "wall_seconds": time.perf_counter() - t0,
        **facts,
    }, args.metrics)


if __name__ == "__main__":
    main()
