"""Training throughput of the segmentation U-Net: crops/s and the time of one epoch.

Times the two parts of a training step separately (making augmented crops, and the forward/backward/
Adam step) with the settings of params.yaml, on the real training scenes when stage `labels` has run
(else on random scenes of the same size: the network's speed does not depend on the pixels). The
machine is usually shared, so the load average is printed next to the numbers.

    python -m bench.bench_segmentation [--sdd data/raw/sdd] [--labels data/labels] [--profile paper]
                                       [--steps 10] [--threads 1] [--smoke]

`--smoke`: random scenes, 64 x 64 crops in batches of 2, one timed step (seconds: the code path,
not a measurement).
"""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import numpy as np
import torch

from bench import common
from pipeline.device import cpu_has_bf16
from pipeline.data.labels import read_index
from pipeline.config.loading import load_profile, read_params
from pipeline.config.segmentation import SegmentationParams
from pipeline.runners.segmentation import (epoch_batches, load_training_scenes,
                                           train_step, unet_config)
from ynet.segmentation import UNet

N_TRAIN_VIDEOS = 30  # TrajNet train videos, for the epoch estimate on synthetic scenes


def scenes_for_bench(sdd: Path, labels: Path, params: SegmentationParams, real: bool = True):
    """(scenes, names, where): the real training scenes if available (and `real`), else random
    ones."""
    if real and (labels / "index.json").exists() and sdd.exists():
        index = read_index(labels)
        names = sorted(n for n, v in index["videos"].items() if v["split"] == "train")
        scenes = load_training_scenes(sdd, labels, names, params.downsample, params.pad_multiple)
        return scenes, names, f"{len(names)} real training scenes"
    rng = np.random.default_rng(0)
    scenes = [(rng.integers(0, 255, (512, 384, 3), dtype=np.uint8),
               rng.integers(1, 6, (512, 384), dtype=np.uint8)) for _ in range(4)]
    names = [f"synthetic_{k}" for k in range(N_TRAIN_VIDEOS)]
    why = f"{labels}/index.json not found" if real else "--smoke"
    return scenes, names, f"random 512x384 scenes ({why})"


def main() -> None:
    parser = common.parser(__doc__)
    parser.add_argument("--sdd", type=Path, default=Path("data/raw/sdd"))
    parser.add_argument("--labels", type=Path, default=Path("data/labels"))
    parser.add_argument("--profile", choices=("cpu", "paper"), default=None,
                        help="profile to time (default: the one params.yaml selects)")
    parser.add_argument("--steps", type=int, default=10, help="timed optimiser steps")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (as the stage)")
    args = parser.parse_args()
    raw = read_params()
    if args.profile:
        raw["profile"] = args.profile
    params = load_profile(SegmentationParams, "segmentation", raw)
    if args.smoke:
        params = dataclasses.replace(params, crop=64, batch_size=2)
        args.steps, args.threads = 1, 1
    torch.set_num_threads(args.threads)

    scenes, names, where = scenes_for_bench(args.sdd, args.labels, params, real=not args.smoke)
    batches = epoch_batches(scenes, params, epoch=0)
    start = time.perf_counter()
    data = [next(batches) for _ in range(min(args.steps + 2, len(scenes) * params.crops_per_image
                                             // params.batch_size))]
    data_s = (time.perf_counter() - start) / len(data)
    while len(data) < args.steps + 2:
        data += data

    torch.manual_seed(params.seed)
    model = UNet(unet_config(params))
    if params.bf16:
        model = model.to(memory_format=torch.channels_last)
    optimiser = torch.optim.Adam(model.parameters(), lr=params.lr)
    for images, labels in data[:2]:  # warm-up (allocator, oneDNN kernels)
        train_step(model, optimiser, images, labels, params.bf16)
    start = time.perf_counter()
    for images, labels in data[2:args.steps + 2]:
        train_step(model, optimiser, images, labels, params.bf16)
    step_s = (time.perf_counter() - start) / args.steps

    bs = params.batch_size
    steps_per_epoch = -(-len(names) * params.crops_per_image // bs)
    epoch_s = steps_per_epoch * (data_s + step_s)
    n_params = sum(p.numel() for p in model.parameters())
    print(f"segmentation bench, profile {raw['profile']} on {where}: U-Net base "
          f"{params.base_channels} depth {params.depth} ({n_params / 1e6:.2f} M params), "
          f"bf16 {params.bf16}, batch {bs} x {params.crop}^2, {torch.get_num_threads()} thread(s), "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print("CPU bf16 hardware (AVX-512 BF16 or AMX): "
          f"{'yes' if cpu_has_bf16() else 'no, so the bf16 cases run float32 (pipeline.device.use_bf16)'}")
    print(f"  augmented crops: {bs / data_s:8.1f} crops/s ({1000 * data_s:.0f} ms/batch)")
    print(f"  training step:   {bs / step_s:8.1f} crops/s ({1000 * step_s:.0f} ms/batch)")
    print(f"  overall:         {bs / (data_s + step_s):8.1f} crops/s")
    print(f"  epoch ({len(names)} videos x {params.crops_per_image} crops = {steps_per_epoch} steps): "
          f"{epoch_s:.1f} s; {params.epochs} epochs: {params.epochs * epoch_s / 60:.1f} min")


if __name__ == "__main__":
    main()
