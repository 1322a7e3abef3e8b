"""How hard does each training step push the short-term Y-net? Its global gradient norms.

Not a test: prints numbers. Runs the first `--epochs` epochs of the `train_short_term_ynet@<dataset>`
stage's own training (`pipeline.runners.short_term.train_ynet` with the profile's settings, seed,
batch plan and validation, in a temporary folder; `-S key=value` overrides a `YnetSettings` field,
e.g. `-S seed=1`), *unclipped*, and prints per epoch the median, 90th and 99th percentile and the
largest global L2 norm of the gradients each optimiser step applies (read by a step pre-hook). With
batches of 2 a few steps can push the weights hundreds of times harder than the rest: that tail is
what `grad_clip_norm` cuts, and its 90th percentile is about where the `cpu` profile put the bound.
Written up in docs/profiles.md (gradient clipping).

    python -m docs.experiments.short_term_grad_norms --dataset sdd --epochs 3 -S seed=1
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from torch.optim.optimizer import register_optimizer_step_pre_hook

from pipeline.benchmarks.ethucy import EthUcyFold
from pipeline.benchmarks.registry import short_term
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.ynet import YnetSettings
from pipeline.runners.short_term import train_ynet, ynet_maps
from tools.rerun_plan import parse_override  # `-S key=value` as dvc exp run


def norm_percentiles(norms: np.ndarray, block: int) -> list[dict[str, float]]:
    """(steps,) norms -> per block of `block` steps: its first step, median, p90, p99, max."""
    return [{"first_step": start, "median": float(np.median(part)),
             "p90": float(np.percentile(part, 90)), "p99": float(np.percentile(part, 99)),
             "max": float(part.max())}
            for start in range(0, len(norms), block) for part in [norms[start:start + block]]]


def settings_overrides(texts: list[str]) -> dict:
    """["seed=1", "learning_rate=0.001"] -> {"seed": 1, "learning_rate": 0.001}; YnetSettings
    fields only."""
    fields = {field.name for field in dataclasses.fields(YnetSettings)}
    out = dict(parse_override(text) for text in texts)
    unknown = sorted(set(out) - fields)
    if unknown:
        raise SystemExit(f"-S {', '.join(unknown)}: not a YnetSettings field")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="sdd")
    parser.add_argument("--windows", type=Path, default=Path("data/short_term"))
    parser.add_argument("--sdd", type=Path, default=Path("data/raw/sdd"))
    parser.add_argument("--epochs", type=int, default=3)
    parser.add_argument("-S", "--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    params = read_params()
    stage = load_profile(ShortTermModelsParams, "short_term_models", params)
    lengths = load_section(ShortTermParams, "short_term", params)
    benchmark = short_term(args.dataset)
    bench = benchmark.load(args.windows, lengths.n_past, lengths.n_future)
    maps_path = (benchmark.maps(args.windows) if isinstance(benchmark, EthUcyFold)
                 else Path("data/semantic_maps"))
    scene_ids = set(bench.train.scene_id) | set(bench.val.scene_id)
    maps, classes = ynet_maps(maps_path)
    sizes = benchmark.scene_sizes(args.windows, args.sdd, scene_ids)
    settings = benchmark.ynet_settings(load_profile(YnetSettings, "ynet", params), stage,
                                       lengths.n_future, classes)
    settings = dataclasses.replace(settings, **{**settings_overrides(args.set),
                                                "epochs": args.epochs, "grad_clip_norm": 0.0})

    norms: list[float] = []

    def record(optimizer, *_):
        grads = [p.grad for group in optimizer.param_groups for p in group["params"]
                 if p.grad is not None]
        norms.append(float(torch.nn.utils.get_total_norm(grads)))

    hook = register_optimizer_step_pre_hook(record)
    began = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as folder:
            train_ynet(bench, maps, sizes, settings, lengths.n_past, Path(folder),
                       stage.val_windows, stage.seed)
    finally:
        hook.remove()
    print(f"{args.dataset}: {len(norms)} steps in {time.perf_counter() - began:.0f} s (validation "
          f"included), lr {settings.learning_rate:g} (trajectory x{settings.trajectory_lr_scale:g}), "
          f"batch {settings.batch_size}, seed {settings.seed}, unclipped")
    print("  global L2 norm of each step's gradients, per epoch:")
    for row in norm_percentiles(np.asarray(norms), len(norms) // args.epochs):
        print(f"  steps {row['first_step']:5d}+  median {row['median']:8.1f}  p90 {row['p90']:8.1f}  "
              f"p99 {row['p99']:9.1f}  max {row['max']:10.1f}")


if __name__ == "__main__":
    main()
