"""Stage `evaluate_baseline`: score one baseline at one horizon with the shared metric.

Loads the model (`constant_velocity` needs no checkpoint; `sgan` / `pecnet` take the checkpoint
directory trained for this horizon; `rpecnet` takes the t_f = 5 PECNet's directory and a table of
any horizon), draws K samples per window of the chosen split in `rounds` independently seeded
rounds, and writes a metrics JSON: best-of-K ADE / FDE, independent (paper protocol) and joint
(`pipeline.metrics`), as the mean and spread over rounds, plus the horizon, K, the number of
windows, the training time recorded in the checkpoint and the evaluation time.

    python -m pipeline.evaluate_baseline --model rpecnet --horizon 30 \
        --table data/horizon_windows/tf30.parquet --checkpoint-dir checkpoints/pecnet_tf5 \
        --metrics metrics/baselines/rpecnet_tf30.json
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from pipeline import baselines
from pipeline.baselines.common import (fit_result_from, load_checkpoint, load_windows, save_json_atomic,
                                       select_split)
from pipeline.device import CPU, RuntimeParams, describe, select_device
from pipeline.device import generator as seeded_generator
from pipeline.metrics import summarize, window_errors
from pipeline.params import load_section, read_params
from pipeline.window_table import WindowArrays
from pipeline.windows import WindowParams

METRIC_KEYS = ("ade", "fde", "ade_joint", "fde_joint")


@dataclass
class EvaluateBaselineParams:
    k: int
    """Samples per window; the metric takes the best of them (paper: 20)."""
    split: str
    """Split scored: `test` for the benchmark, `val` while developing."""
    rounds: int
    """Independently seeded sampling rounds (seeds seed, seed+1, ...); mean and spread reported."""
    seed: int
    """Seed of the first round."""
    threads: int
    """torch CPU threads."""

    def __post_init__(self):
        if self.k < 1 or self.rounds < 1 or self.threads < 1:
            raise ValueError("k, rounds and threads must be >= 1")
        if self.split not in ("train", "val", "test"):
            raise ValueError(f"split must be train, val or test, got {self.split!r}")


def evaluate(model, arrays: WindowArrays, k: int, rounds: int, seed: int, device: torch.device = CPU) -> dict:
    """Mean and std over rounds of the shared metric's summary, plus each round's summary; round r
    samples from a generator on `device` (the model's) seeded with seed + r."""
    per_round = []
    t0 = time.perf_counter()
    for r in range(rounds):
        pred = model.predict(arrays, k, seeded_generator(device, seed + r))  # (N, K, n_f, 2)
        per_round.append(summarize(window_errors(pred, arrays.future)))
    seconds = time.perf_counter() - t0
    out = {key: float(np.mean([r[key] for r in per_round])) for key in METRIC_KEYS}
    out |= {f"{key}_std": float(np.std([r[key] for r in per_round])) for key in METRIC_KEYS}
    return {**out, "k": k, "n_windows": len(arrays), "rounds": rounds,
            "eval_seconds": seconds, "eval_seconds_per_round": seconds / rounds, "per_round": per_round}


def training_facts(model: str, checkpoint_dir: Path | None) -> dict:
    """What the checkpoint records about its training (nothing for constant velocity)."""
    if checkpoint_dir is None:
        return {"train_seconds": 0.0}
    result = fit_result_from(checkpoint_dir)
    meta = load_checkpoint(Path(checkpoint_dir) / "best.pt")["meta"]
    return {"train_seconds": result.train_seconds, "trained_epochs": result.epochs,
            "best_epoch": result.best_epoch, "best_val_ade": result.best_val_ade,
            "trained_horizon": meta["n_future"]}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, choices=sorted(baselines.BASELINES))
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--checkpoint-dir", type=Path, default=None,
                        help="trained model (rpecnet: the t_f = 5 PECNet); not for constant_velocity")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    args = parser.parse_args(argv)
    all_params = read_params()
    params = load_section(EvaluateBaselineParams, "evaluate_baseline", all_params)
    n_past = load_section(WindowParams, "windows", all_params).n_past
    runtime = load_section(RuntimeParams, "runtime", all_params)
    torch.set_num_threads(params.threads)
    device = select_device(runtime.device)
    print(f"evaluate_baseline {args.model} t_f = {args.horizon}: {describe(device)}", flush=True)

    cls = baselines.get(args.model)
    needs_checkpoint = args.model != "constant_velocity"
    if needs_checkpoint != (args.checkpoint_dir is not None):
        parser.error(f"--checkpoint-dir is {'required' if needs_checkpoint else 'not taken'} for {args.model}")
    model = cls.load(args.checkpoint_dir, device)
    arrays = select_split(load_windows(args.table, n_past, args.horizon), params.split)
    if len(arrays) == 0:
        raise ValueError(f"{args.table}: no {params.split} windows")
    scores = evaluate(model, arrays, params.k, params.rounds, params.seed, device)
    save_json_atomic({"model": args.model, "horizon": args.horizon, "split": params.split,
                      "seed": params.seed, **scores,
                      **training_facts(args.model, args.checkpoint_dir)}, args.metrics)


if __name__ == "__main__":
    main()
