"""Training rates of the `paper` segmentation U-Net, S-GAN and PECNet, for the projection
(`bench/projection.py`) beside the Y-net rates of `bench/bench_profiles.py`.

Not a test. Each runs the stage's own training loop (`pipeline.runners.segmentation.train`, the
baselines' `fit`), so crop making, device moves, validation and checkpoints count as they do in
the stage: one epoch first (warm-up: the same shapes), then the loop resumes from that epoch's
checkpoint and the next `epochs` are timed. Inputs are synthetic (random scenes, the walks of
`bench/bench_baselines.py`): these networks' speed does not depend on the values.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from bench.bench_baselines import N_FUTURE, N_PAST, synthetic_windows
from bench.projection import PECNET, SEGMENTATION, SGAN, paper
from pipeline.config.loading import load_section
from pipeline.config.segmentation import SegmentationParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.device import synchronize
from pipeline.runners import baselines
from pipeline.runners import segmentation

SCENE_HW = (512, 384)  # a downsampled SDD scene (bench/bench_segmentation.py's synthetic size)


def synthetic_scenes(n: int, seed: int = 0) -> list[tuple[np.ndarray, np.ndarray]]:
    """`n` (image, labels) scenes made of four random ones, repeated (crops only read them)."""
    rng = np.random.default_rng(seed)
    distinct = [(rng.integers(0, 255, (*SCENE_HW, 3), dtype=np.uint8),
                 rng.integers(1, 6, SCENE_HW, dtype=np.uint8)) for _ in range(4)]
    return [distinct[i % 4] for i in range(n)]


def segmentation_rate(params: SegmentationParams, device: torch.device, steps: int,
                      epochs: int = 2) -> dict:
    """Training crops/s of the U-Net of `params`: epochs of `steps` full batches each."""
    scenes = synthetic_scenes(-(-steps * params.batch_size // params.crops_per_image))
    crops_per_epoch = len(scenes) * params.crops_per_image
    with tempfile.TemporaryDirectory() as folder:
        checkpoint = Path(folder) / "last.pt"
        segmentation.train(scenes, params, checkpoint, "bench", stop_after=1, progress=False,
                           device=device)  # warm-up, and the checkpoint the timed call resumes
        synchronize(device)
        start = time.perf_counter()
        segmentation.train(scenes, params, checkpoint, "bench", stop_after=epochs, progress=False,
                           device=device)
        synchronize(device)
        seconds = time.perf_counter() - start
    return {"rate": epochs * crops_per_epoch / seconds, "unit": "crops/s", "seconds": seconds,
            "epochs": epochs, "crops_per_epoch": crops_per_epoch,
            "what": f"U-Net base {params.base_channels} depth {params.depth}, batch "
                    f"{params.batch_size} x {params.crop}^2 crops of random "
                    f"{SCENE_HW[0]}x{SCENE_HW[1]} scenes"}


def baseline_rate(name: str, config, device: torch.device, n_train: int, n_val: int,
                  epochs: int = 2) -> dict:
    """Train windows x epochs per second of baseline `name` (validation included, as in its stage)."""
    train = synthetic_windows(n_train, "train", 0)
    val = synthetic_windows(n_val, "val", 1)
    fit = baselines.get(name).fit
    with (tempfile.TemporaryDirectory() as folder, contextlib.redirect_stdout(io.StringIO()),
          contextlib.redirect_stderr(io.StringIO())):  # the fits' epoch lines and progress bars
        fit(train, val, dataclasses.replace(config, epochs=1), Path(folder), seed=0, device=device)
        synchronize(device)
        start = time.perf_counter()
        fit(train, val, dataclasses.replace(config, epochs=1 + epochs), Path(folder), seed=0,
            device=device)  # resumes after the warm-up epoch
        synchronize(device)
        seconds = time.perf_counter() - start
    return {"rate": epochs * n_train / seconds, "unit": "train windows x epochs/s",
            "seconds": seconds, "epochs": epochs,
            "what": f"{n_train} train + {n_val} val synthetic windows of {N_PAST} + {N_FUTURE} steps, "
                    f"batch {config.batch_size}"}


def smoke_params(params: dict) -> dict:
    """`params` with the `paper` U-Net 4 channels wide at the top (paper: 32) on 64 x 64 crops in
    batches of 2: a smoke run's (the paper U-Net takes seconds a step on a CPU, and its
    checkpoints are 100 MB)."""
    segmentation = {**params["segmentation"]["paper"], "base_channels": 4, "crop": 64,
                    "batch_size": 2}
    return {**params, "segmentation": {**params["segmentation"], "paper": segmentation}}


@contextlib.contextmanager
def torch_threads(n: int):
    """torch on `n` CPU threads inside, as before outside."""
    before = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def stage_rates(params: dict, device: torch.device, smoke: bool = False,
                segmentation_steps: int = 8) -> dict[str, dict]:
    """The paper segmentation (`segmentation_steps` steps an epoch), S-GAN and PECNet rates on
    `device`, each on its stage's CPU threads (`segmentation.paper.threads`,
    `train_baseline.threads`: on a busy 2-core machine two threads make these small ops many times
    slower); `smoke`: one step or epoch each, 64 windows."""
    unet = paper(SegmentationParams, "segmentation", params)
    with torch_threads(unet.threads):
        out = {SEGMENTATION: segmentation_rate(unet, device, steps=1 if smoke else segmentation_steps,
                                               epochs=1 if smoke else 2)}
    n_train, n_val = (64, 16) if smoke else (1000, 150)
    with torch_threads(load_section(TrainBaselineParams, "train_baseline", params).threads):
        for name, key in (("sgan", SGAN), ("pecnet", PECNET)):
            config = paper(baselines.get(name).config_class, name, params)
            out[key] = baseline_rate(name, config, device, n_train, n_val, epochs=1 if smoke else 2)
    return out
