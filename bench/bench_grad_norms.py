"""How hard does each training step push the short-term Y-net? Its global gradient norms.

Not a test: prints numbers. Runs the first `--steps` optimiser steps of the
`train_short_term_ynet@<dataset>` stage's own training (the profile's settings, seed and batch plan;
`--set key=value` overrides a `YnetSettings` field, e.g. `seed=1`), *unclipped*, and prints, per
block of steps, the median, 90th and 99th percentile and the largest global L2 norm of the
gradients each step applies (read by the optimiser before its step). With batches of 2 a few
steps can push the weights hundreds of times harder than the rest: that tail is what
`grad_clip_norm` cuts, and its 90th percentile is about where the `cpu` profile put the bound.

    python bench/bench_grad_norms.py --dataset sdd --steps 900 --set seed=1
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch

from pipeline.config import ShortTermModelsParams, ShortTermParams, load_profile, load_section, read_params
from pipeline.data.ynet_data import group_by_scene
from pipeline.runners.short_term import load_dataset, ynet_inputs, ynet_settings
from pipeline.runners.ynet_training import (YnetSettings, epoch_plan, optimizer_groups,
                                            seed_everything, train_epoch)
from ynet.model import YNet


def norm_percentiles(norms: np.ndarray, block: int) -> list[dict[str, float]]:
    """(steps,) norms -> per block of `block` steps: its first step, median, p90, p99, max."""
    return [{"first_step": start, "median": float(np.median(part)),
             "p90": float(np.percentile(part, 90)), "p99": float(np.percentile(part, 99)),
             "max": float(part.max())}
            for start in range(0, len(norms), block) for part in [norms[start:start + block]]]


class NormRecordingAdam(torch.optim.Adam):
    """Adam that appends the global L2 norm of the gradients to `norms` before every step;
    the step itself is Adam's, so the run is the stage's, bit for bit."""

    def __init__(self, groups: list[dict], norms: list[float], **options):
        super().__init__(groups, **options)
        self.norms = norms

    def step(self, closure=None):
        grads = [p.grad for group in self.param_groups for p in group["params"] if p.grad is not None]
        self.norms.append(float(torch.nn.utils.get_total_norm(grads)))
        return super().step(closure)


def overrides(pairs: list[str]) -> dict:
    """["seed=1", "learning_rate=0.001"] -> {"seed": 1, "learning_rate": 0.001} (JSON values)."""
    out = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or key not in {f.name for f in dataclasses.fields(YnetSettings)}:
            raise SystemExit(f"--set {pair!r}: expected <YnetSettings field>=<JSON value>")
        out[key] = json.loads(value)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="sdd")
    parser.add_argument("--windows", type=Path, default=Path("data/short_term"))
    parser.add_argument("--sdd", type=Path, default=Path("data/raw/sdd"))
    parser.add_argument("--steps", type=int, default=900)
    parser.add_argument("--block", type=int, default=300)
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    params = read_params()
    stage = load_profile(ShortTermModelsParams, "short_term_models", params)
    lengths = load_section(ShortTermParams, "short_term", params)
    bench, ethucy_scenes = load_dataset(args.windows, args.dataset, lengths.n_past, lengths.n_future)
    maps_path = Path("data/semantic_maps") if ethucy_scenes is None else args.windows / "ethucy_semantic"
    maps, sizes, classes = ynet_inputs(maps_path, args.sdd, set(bench.train.scene_id), ethucy_scenes)
    settings = ynet_settings(load_profile(YnetSettings, "ynet", params), stage, args.dataset,
                             lengths.n_future, classes)
    settings = dataclasses.replace(settings, **{**overrides(args.set), "grad_clip_norm": 0.0})

    # as `ynet_training.train` starts a run: seeded init, optimiser, plan generator
    torch.set_num_threads(settings.threads)
    torch.set_flush_denormal(True)
    seed_everything(settings.seed)
    model = YNet(settings.model_config(lengths.n_past, lengths.n_future))
    norms: list[float] = []
    optimizer = NormRecordingAdam(optimizer_groups(model, settings), norms, lr=settings.learning_rate)
    rng = np.random.default_rng(settings.seed)
    scenes = group_by_scene(bench.train, maps, sizes, settings.resize)
    began, epoch = time.perf_counter(), 0
    while len(norms) < args.steps:
        epoch += 1
        plan = epoch_plan(scenes, settings, rng)[:args.steps - len(norms)]
        train_epoch(model, optimizer, scenes, settings, plan, epoch, [])
    print(f"{args.dataset}: {len(norms)} steps in {time.perf_counter() - began:.0f} s, lr "
          f"{settings.learning_rate:g} (trajectory x{settings.trajectory_lr_scale:g}), batch "
          f"{settings.batch_size}, seed {settings.seed}, unclipped")
    print("  global L2 norm of each step's gradients, per block of steps:")
    for row in norm_percentiles(np.asarray(norms), args.block):
        print(f"  steps {row['first_step']:5d}+  median {row['median']:8.1f}  p90 {row['p90']:8.1f}  "
              f"p99 {row['p99']:9.1f}  max {row['max']:10.1f}")


if __name__ == "__main__":
    main()
