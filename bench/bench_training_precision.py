"""Training samples per second of Y-net on this CPU: float32 against bfloat16 autocast, and for the
short-term crops batch 2 against batch 16, in one run.

Not a test: prints numbers. Runs the pipeline's own training step (`ynet_training.train_epoch`) on
synthetic windows (no data needed), with each profile's settings from params.yaml:

- long-term `ynet.cpu` (whole scenes at its resize, batch 2): float32 vs `bf16`, the change behind
  `ynet.cpu.bf16`;
- short-term SDD (`short_term_models.cpu`: 64 x 64 agent crops at resize 0.125): batch 2 float32
  (what the profile trains) vs batch 16 in bfloat16 (one scene a batch; the README's trial mixed
  scenes, a switch since removed);
- short-term ETH/UCY (64 x 64 crops at its resize): batch 2 float32 (the profile) vs bfloat16.

With `--threads 1`, against the default 2, it shows what one core does alone: whether two
trainings side by side on one thread each would beat one after the other on two.

    python -m bench.bench_training_precision [--steps 12] [--threads 2] [--smoke]

`--smoke`: Y-nets of a few channels on 1024 x 1024 scenes, one timed step per case (seconds: the
code path, not a measurement).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import torch

from bench import common
from bench.bench_profiles import IMAGE_HW
from bench.bench_ynet import keep_freed_memory
from pipeline.benchmarks.ethucy import FOLDS
from pipeline.benchmarks.trajnet_sdd import TRAJNET_SDD
from pipeline.device import cpu_has_bf16
from pipeline.config.loading import load_profile, read_params
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.ynet import YnetSettings
from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import group_by_scene
from pipeline.runners.ynet_training import epoch_plan, train_epoch
from ynet.model import YNet


SMOKE_IMAGE_HW = (1024, 1024)


def synthetic_windows(n: int, n_past: int, n_future: int, classes: int, seed: int = 0,
                      image_hw: tuple[int, int] = IMAGE_HW):
    """`n` straight walks split over two scenes of `image_hw` with random `classes`-class maps
    (original pixels)."""
    rng = np.random.default_rng(seed)
    height, width = image_hw
    start = rng.uniform([200, 200], [width - 800, height - 800], size=(n, 1, 2))
    xy = start + np.arange(n_past + n_future)[None, :, None] * rng.uniform(-12, 18, size=(n, 1, 2))
    scene_id = np.where(np.arange(n) < n // 2, "bench_0", "bench_1")
    arrays = WindowArrays(past=xy[:, :n_past], future=xy[:, n_past:], window_id=np.arange(n),
                          scene_id=scene_id, track_id=np.arange(n), first_frame=np.zeros(n),
                          split=np.array(["train"] * n))
    maps = {name: rng.dirichlet(np.ones(classes), size=(height // 4, width // 4)).astype(np.float32)
            .transpose(2, 0, 1) for name in ("bench_0", "bench_1")}
    return arrays, maps, {name: image_hw for name in maps}


def samples_per_second(settings: YnetSettings, steps: int, n_past: int, n_future: int,
                       image_hw: tuple[int, int] = IMAGE_HW) -> float:
    """Training samples per second over `steps` optimiser steps after one warm-up step."""
    settings = dataclasses.replace(settings, steps_per_epoch=0)
    arrays, maps, sizes = synthetic_windows(settings.batch_size * (steps + 1), n_past, n_future,
                                            settings.semantic_classes, image_hw=image_hw)
    scenes = group_by_scene(arrays, maps, sizes, settings.resize)
    torch.manual_seed(settings.seed)
    model = YNet(settings.model_config(n_past, n_future))
    optimizer = torch.optim.Adam(model.parameters(), lr=settings.learning_rate)
    plan = epoch_plan(scenes, settings, np.random.default_rng(0))
    train_epoch(model, optimizer, scenes, settings, plan[:1], 1, [])  # warm-up: allocator, kernels
    start = time.perf_counter()
    train_epoch(model, optimizer, scenes, settings, plan[1:steps + 1], 1, [])
    taken = sum(sum(len(rows) for *_, rows in batch) for batch in plan[1:steps + 1])
    return taken / (time.perf_counter() - start)


def main() -> None:
    parser = common.parser(__doc__)
    parser.add_argument("--steps", type=int, default=12)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    image_hw = SMOKE_IMAGE_HW if args.smoke else IMAGE_HW
    if args.smoke:
        args.steps, args.threads = 1, 1
    keep_freed_memory()
    torch.set_num_threads(args.threads)
    torch.set_flush_denormal(True)
    params = read_params()
    cpu = {**params, "profile": "cpu"}
    long_term = load_profile(YnetSettings, "ynet", cpu)
    if args.smoke:
        long_term = dataclasses.replace(long_term, **common.TINY_CHANNELS)
    short_params = load_profile(ShortTermModelsParams, "short_term_models", cpu)
    short_term = TRAJNET_SDD.ynet_settings(long_term, short_params, 12, 6)
    ethucy = FOLDS["eth"].ynet_settings(long_term, short_params, 12, 3)  # its maps: 3 classes
    cases = {  # name: (settings, n_past, n_future)
        "long-term, batch 2, float32": (dataclasses.replace(long_term, bf16=False), 5, 30),
        "long-term, batch 2, bf16 (ynet.cpu)": (dataclasses.replace(long_term, bf16=True), 5, 30),
        "short-term SDD crops, batch 2, float32 (cpu)": (short_term, 8, 12),
        "short-term SDD crops, batch 16, bf16": (dataclasses.replace(
            short_term, batch_size=16, bf16=True), 8, 12),
        "short-term ETH/UCY crops, batch 2, float32 (cpu)": (ethucy, 8, 12),
        "short-term ETH/UCY crops, batch 2, bf16": (dataclasses.replace(ethucy, bf16=True), 8, 12),
    }
    print(f"torch {torch.__version__}, {args.threads} threads, {args.steps} steps per case")
    print("CPU bf16 hardware (AVX-512 BF16 or AMX): "
          f"{'yes' if cpu_has_bf16() else 'no, so the bf16 cases run float32 (pipeline.device.use_bf16)'}")
    for name, (settings, n_past, n_future) in cases.items():
        rate = samples_per_second(settings, args.steps, n_past, n_future, image_hw)
        print(f"  {name:46s} {rate:6.1f} samples/s")


if __name__ == "__main__":
    main()
