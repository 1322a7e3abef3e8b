"""Do the CPU's Y-net numbers stay byte for byte what they were? (issue 62: scoring and training
changed for CUDA; the `cpu` profile must not move.)

Runs, with whatever code `PYTHONPATH` points at, the `cpu` profile's Y-net (params.yaml settings,
a seeded untrained model) on two synthetic scenes (`bench.bench_profiles.synthetic_windows`):

- scoring: every sampling of the long-term evaluation sequence (main rounds, ablation, K_e x K_a
  grid: `ynet_scoring.sequence_settings`) over all windows, whole scenes and crops, through
  `ynet_scoring.predict_samplings` on the CPU (default k-means mode, the profile's bf16);
- training: a few `ynet_training.train_epoch` steps (the profile's bf16 and schedule).

and writes every array (paths, goals, weights of each sampling; losses and weights after
training) to one npz. `--compare OLD NEW` says, array by array, whether the bytes are equal.

    PYTHONPATH=<old checkout> python -m docs.experiments.gpu_scoring_cpu_identity --out old.npz
    PYTHONPATH=<new checkout> python -m docs.experiments.gpu_scoring_cpu_identity --out new.npz
    python -m docs.experiments.gpu_scoring_cpu_identity --compare old.npz new.npz
"""
from __future__ import annotations

import argparse
import dataclasses
import sys

import numpy as np
import torch

from bench.bench_profiles import N_FUTURE, N_PAST, profile_settings, synthetic_windows
from pipeline.config.cws import CwsParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.ttst import TtstParams
from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import group_by_scene
from pipeline.runners.ynet_scoring import predict_samplings, sequence_settings, setting_samplings
from pipeline.runners.ynet_training import epoch_plan, optimizer_groups, train_epoch
from ynet.model import YNet

IMAGE_HW = (2048, 1664)  # SDD-sized scenes: 128 x 104 at the cpu profile's resize


def two_scenes(windows: int) -> tuple[WindowArrays, dict, dict]:
    """`windows` synthetic windows on each of two scenes (other maps, other walks)."""
    parts = [synthetic_windows(windows, seed, IMAGE_HW) for seed in (1, 2)]
    names = ["bench_0", "bench_1"]
    arrays = WindowArrays(**{
        field.name: np.concatenate([getattr(part[0], field.name) for part in parts])
        for field in dataclasses.fields(WindowArrays)})
    arrays = dataclasses.replace(arrays, window_id=np.arange(2 * windows),
                                 scene_id=np.repeat(names, windows))
    maps = {name: part[1]["bench_0"] for name, part in zip(names, parts)}
    sizes = {name: IMAGE_HW for name in names}
    return arrays, maps, sizes


def run(windows: int, steps: int) -> dict[str, np.ndarray]:
    torch.set_num_threads(1)
    torch.set_flush_denormal(True)
    params = read_params()
    settings, evaluation = profile_settings(params, "cpu", 1)
    arrays, maps, sizes = two_scenes(windows)
    scenes = group_by_scene(arrays, maps, sizes, settings.resize)
    out = {}
    samplings = setting_samplings(sequence_settings(evaluation, load_section(TtstParams, "ttst", params),
                                                    load_section(CwsParams, "cws", params)),
                                  evaluation.seed)
    torch.manual_seed(settings.seed)
    model = YNet(settings.model_config(N_PAST, N_FUTURE)).eval()
    for crop in (0, 64):
        sampled, _ = predict_samplings(model, scenes, settings, samplings, evaluation, len(arrays),
                                       "identity", crop, 1.0 if crop else 0.0)
        for i, drawn in enumerate(sampled):
            out[f"crop{crop}_sampling{i}_paths"] = drawn.paths
            out[f"crop{crop}_sampling{i}_goals"] = drawn.goals
            if drawn.weights is not None:
                out[f"crop{crop}_sampling{i}_weights"] = drawn.weights
    torch.manual_seed(settings.seed)
    model = YNet(settings.model_config(N_PAST, N_FUTURE))
    optimizer = torch.optim.Adam(optimizer_groups(model, settings), lr=settings.learning_rate)
    plan = epoch_plan(scenes, settings, np.random.default_rng(settings.seed))[:steps]
    losses: list[float] = []
    train_epoch(model, optimizer, scenes, settings, plan, 1, losses)
    out["train_losses"] = np.array(losses)
    for name, value in model.state_dict().items():
        out[f"weights_{name}"] = value.numpy()
    for i, state in optimizer.state_dict()["state"].items():
        for key in ("exp_avg", "exp_avg_sq"):
            out[f"adam_{i}_{key}"] = state[key].numpy()
    return out


def compare(old_path: str, new_path: str) -> bool:
    old, new = np.load(old_path), np.load(new_path)
    names = sorted(set(old.files) | set(new.files))
    differ = [name for name in names if name not in old.files or name not in new.files
              or old[name].dtype != new[name].dtype or old[name].shape != new[name].shape
              or old[name].tobytes() != new[name].tobytes()]
    total = sum(old[name].nbytes for name in old.files)
    print(f"{len(names)} arrays ({total:,} bytes): {len(names) - len(differ)} byte-identical, "
          f"{len(differ)} differ" + (f": {differ[:10]}" if differ else ""))
    return not differ


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="npz to write")
    parser.add_argument("--compare", nargs=2, metavar=("OLD", "NEW"))
    parser.add_argument("--windows", type=int, default=6, help="windows per scene")
    parser.add_argument("--steps", type=int, default=3, help="training steps")
    args = parser.parse_args()
    if args.compare:
        sys.exit(0 if compare(*args.compare) else 1)
    if not args.out:
        parser.error("give --out or --compare")
    arrays = run(args.windows, args.steps)
    np.savez(args.out, **arrays)
    print(f"wrote {len(arrays)} arrays to {args.out}")


if __name__ == "__main__":
    main()
