"""Training samples/s and scoring windows/s of the long-term Y-net, `paper` beside `cpu` profile.

Not a test: prints numbers. Runs the pipeline's own code paths (`train_ynet.train_epoch`,
`evaluate_ynet.predict_scenes`, so device moves, autocast and input building are included) on a
synthetic scene of SDD size (original 2048 x 1664 px, so 512 x 416 at the paper's resize 0.25),
with each profile's settings from params.yaml (`ynet.<profile>`, `eval.<profile>`: resize, kernel,
batch, K_e / K_a, chunking) on `--device` (default: CUDA when present, else the CPU).

    python bench/bench_profiles.py [--device auto|cpu|cuda] [--threads 2] [--steps 3] [--windows 3]

It re-executes itself with glibc malloc told to keep freed memory, as the stages run (dvc.yaml's
GLIBC_TUNABLES; see bench/bench_ynet.py). With the release's window table at hand (`data/windows/release_tf30.parquet`, stage `windows`) it
also projects one `paper` epoch (every train window under all 8 augmentations) and the full run.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.bench_ynet import keep_freed_memory  # noqa: E402
from pipeline.device import SCORING, TRAINING, describe, select_device, synchronize  # noqa: E402
from pipeline.runners.ynet_scoring import predict_scenes, sampling_options
from pipeline.config import CwsParams, EvalParams, TtstParams, load_profile, load_section, read_params
from pipeline.runners.ynet_training import YnetSettings, epoch_plan, train_epoch  # noqa: E402
from pipeline.data.window_table import WindowArrays  # noqa: E402
from pipeline.data.ynet_data import group_by_scene  # noqa: E402
from ynet.model import YNet  # noqa: E402

IMAGE_HW = (2048, 1664)  # original pixels of the synthetic scene
N_PAST, N_FUTURE = 5, 30
RELEASE_TABLE = Path("data/windows/release_tf30.parquet")


def synthetic_windows(n: int, seed: int) -> tuple[WindowArrays, dict, dict]:
    """`n` straight walks over one scene with a random 6-class map (original pixels)."""
    rng = np.random.default_rng(seed)
    height, width = IMAGE_HW
    start = rng.uniform([200, 200], [width - 800, height - 800], size=(n, 1, 2))
    velocity = rng.uniform(-12, 18, size=(n, 1, 2))
    xy = start + np.arange(N_PAST + N_FUTURE)[None, :, None] * velocity
    arrays = WindowArrays(past=xy[:, :N_PAST], future=xy[:, N_PAST:], window_id=np.arange(n),
                          scene_id=np.array(["bench_0"] * n), track_id=np.arange(n),
                          first_frame=np.zeros(n), split=np.array(["train"] * n))
    probs = rng.dirichlet(np.ones(6), size=(height // 4, width // 4)).astype(np.float32)
    return arrays, {"bench_0": probs.transpose(2, 0, 1)}, {"bench_0": IMAGE_HW}


def training_rate(settings: YnetSettings, device: torch.device, steps: int) -> float:
    """Training samples per second over `steps` optimiser steps after one warm-up step."""
    arrays, maps, sizes = synthetic_windows(settings.batch_size * (steps + 1), 0)
    scenes = group_by_scene(arrays, maps, sizes, settings.resize, device)
    torch.manual_seed(settings.seed)
    model = YNet(settings.model_config(N_PAST, N_FUTURE)).to(device)
    optimizer = torch.optim.Adam(model.parameters(), lr=settings.learning_rate)
    plan = epoch_plan(scenes, settings, np.random.default_rng(0))
    train_epoch(model, optimizer, scenes, settings, plan[:1], 0, [], device)  # warm-up
    synchronize(device)
    start = time.perf_counter()
    train_epoch(model, optimizer, scenes, settings, plan[1:steps + 1], 0, [], device)
    synchronize(device)
    return steps * settings.batch_size / (time.perf_counter() - start)


def scoring_rate(settings: YnetSettings, evaluation: EvalParams, device: torch.device,
                 windows: int) -> float:
    """Test windows per second, TTST + CWS at the profile's K_e and K_a, after one warm-up window."""
    arrays, maps, sizes = synthetic_windows(windows + 1, 1)
    scenes = group_by_scene(arrays, maps, sizes, settings.resize, device)
    model = YNet(settings.model_config(N_PAST, N_FUTURE)).to(device).eval()
    options = sampling_options(evaluation.k_e, evaluation.k_a, TtstParams(), CwsParams(), True, True)
    warm = [scenes[0].subset(np.arange(1))]
    predict_scenes(model, warm, settings, options, 0, evaluation, len(arrays), "warm-up")
    rest = [scenes[0].subset(np.arange(1, windows + 1))]
    synchronize(device)
    start = time.perf_counter()
    predict_scenes(model, rest, settings, options, 0, evaluation, len(arrays), "bench")
    synchronize(device)
    return windows / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="auto")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--steps", type=int, default=3, help="timed training steps per profile")
    parser.add_argument("--windows", type=int, default=3, help="timed test windows per profile")
    args = parser.parse_args()
    keep_freed_memory()
    torch.set_num_threads(args.threads)
    torch.set_flush_denormal(True)
    device = select_device(args.device, purpose=SCORING)
    params = read_params()
    print(f"torch {torch.__version__} on {describe(device)}; GLIBC_TUNABLES="
          f"{os.environ.get('GLIBC_TUNABLES', '(unset)')}; load average "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    train_windows = None
    if RELEASE_TABLE.exists():
        table = pd.read_parquet(RELEASE_TABLE, columns=["window_id", "split"])
        train_windows = table[table["split"] == "train"]["window_id"].nunique()

    print(f"\n{'profile':8s} {'resize':>6s} {'map':>9s} {'batch':>5s} {'K_e x K_a':>9s} "
          f"{'train samples/s':>16s} {'score windows/s':>16s}")
    rates = {}
    for profile in ("cpu", "paper"):
        chosen = {**params, "profile": profile}
        settings = load_profile(YnetSettings, "ynet", chosen)
        settings.threads = args.threads
        evaluation = load_profile(EvalParams, "eval", chosen)
        select_device(args.device, purpose=TRAINING)  # each measured as its stages run
        train = training_rate(settings, device, args.steps)
        select_device(args.device, purpose=SCORING)
        score = scoring_rate(settings, evaluation, device, args.windows)
        rates[profile] = (settings, train, score)
        hw = "x".join(str(round(s * settings.resize)) for s in IMAGE_HW)
        print(f"{profile:8s} {settings.resize:6.4g} {hw:>9s} {settings.batch_size:5d} "
              f"{evaluation.k_e:>4d} x {evaluation.k_a:<2d} {train:16.2f} {score:16.3f}")

    settings, train, score = rates["paper"]
    if train_windows:
        samples = train_windows * settings.augmentations
        epoch_s = samples / train
        print(f"\npaper epoch: {train_windows} train windows x {settings.augmentations} augmentations"
              f" = {samples:,} samples -> {epoch_s / 60:.1f} min per epoch (training steps only);"
              f" {settings.epochs} epochs -> {epoch_s * settings.epochs / 3600:.1f} h on this device")
    else:
        print(f"\n(no {RELEASE_TABLE}: run `dvc repro windows` to project a paper epoch)")


if __name__ == "__main__":
    main()
