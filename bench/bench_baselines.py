"""Time the baselines at t_f = 30 on realistic sizes, to plan the CPU budget.

Synthetic SDD-like tracks (about 20 px per 1 FPS step, slowly turning, some agents co-occurring):
1,000 train / 150 val / 382 test windows of 5 + 30 steps, the sizes of the authors' release. For
each model: seconds per training epoch (validation included) and seconds to draw K = 20 samples
for the test windows; with the profile's epochs, the projected training time at this size.

    python -m bench.bench_baselines [--profile cpu] [--epochs 2] [--threads 1] [--params params.yaml]
                                    [--smoke]

`--smoke`: 16 / 4 / 6 windows and one epoch (seconds: the code path, not a measurement).

Settings: the models' sections of `params.yaml` (`sgan`, `pecnet`) for the chosen profile, or the
config dataclasses' defaults (the paper settings) where a section is missing.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from bench import common
from pipeline.runners import baselines
from pipeline.config.loading import load_profile, read_params
from pipeline.data.window_table import WindowArrays
from pipeline.models import window_set
from pipeline.models.constant_velocity import ConstantVelocity

N_PAST, N_FUTURE = 5, 30
SIZES = {"train": 1000, "val": 150, "test": 382}  # the authors' release
SMOKE_SIZES = {"train": 16, "val": 4, "test": 6}


def synthetic_windows(n: int, split: str, seed: int) -> WindowArrays:
    """n windows of slowly turning walks at about 20 px/step; ~1.2 agents per co-occurrence group."""
    rng = np.random.default_rng(seed)
    steps = N_PAST + N_FUTURE
    heading = rng.uniform(0, 2 * np.pi, n)[:, None] + np.cumsum(rng.normal(0, 0.15, (n, steps)), axis=1)
    speed = rng.uniform(10, 30, (n, 1)) * (1 + 0.1 * rng.normal(size=(n, steps)))
    step = speed[..., None] * np.stack([np.cos(heading), np.sin(heading)], axis=-1)  # (n, T, 2)
    xy = rng.uniform(0, 1500, (n, 1, 2)) + np.cumsum(step, axis=1) - step[:, :1]
    first_frame = rng.integers(0, int(n / 1.2), n) * 30 * steps
    return WindowArrays(past=xy[:, :N_PAST], future=xy[:, N_PAST:], window_id=np.arange(n),
                        scene_id=np.array(["scene_0"] * n), track_id=np.arange(n),
                        first_frame=first_frame, split=np.array([split] * n))


def configs(params_path: Path, profile: str) -> dict:
    """Each trained model's settings for `profile`: from params.yaml when it has the model's
    section, else the config dataclass's defaults (the paper settings)."""
    params = read_params(params_path) if params_path.exists() else {}
    out = {}
    for name in baselines.TRAINABLE:
        cls = baselines.get(name).config_class
        if name in params:
            out[name] = load_profile(cls, name, {**params, "profile": profile})
        else:
            print(f"({params_path} has no {name} section: using {cls.__name__}'s defaults)")
            out[name] = cls()
    return out


def main(argv: list[str] | None = None) -> None:
    parser = common.parser(__doc__)
    parser.add_argument("--profile", default="cpu", choices=("cpu", "paper"))
    parser.add_argument("--epochs", type=int, default=2, help="epochs timed per model")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    args = parser.parse_args(argv)
    if args.smoke:
        args.threads = 1
    torch.set_num_threads(args.threads)
    epochs = 1 if args.smoke else args.epochs
    sizes = SMOKE_SIZES if args.smoke else SIZES
    train, val, test = (synthetic_windows(n, s, i) for i, (s, n) in enumerate(sizes.items()))
    print(f"t_f = {N_FUTURE}: {len(train)} train / {len(val)} val / {len(test)} test windows, "
          f"{args.threads} thread(s), profile {args.profile}")
    print(f"{'model':<18}{'s/epoch':>9}{'epochs':>8}{'train s':>9}{'eval s (K=20)':>15}")
    for name, config in configs(args.params, args.profile).items():
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            model = baselines.get(name).fit(train, val, dataclasses.replace(config, epochs=epochs),
                                            Path(tmp), seed=0)
            per_epoch = (time.perf_counter() - t0) / epochs
            t0 = time.perf_counter()
            model.predict(test, 20, torch.Generator().manual_seed(0))
            evaluation = time.perf_counter() - t0
            if name == "pecnet":  # R-PECNet: the same PECNet's 5-step version rolled out 6 times
                short = dataclasses.replace(train, future=train.future[:, :5])
                short_val = dataclasses.replace(val, future=val.future[:, :5])
                pecnet5 = baselines.get("pecnet").fit(short, short_val, dataclasses.replace(config, epochs=1),
                                                      Path(tmp) / "tf5", seed=0)
                t1 = time.perf_counter()
                baselines.get("rpecnet")(pecnet5).predict(test, 20, torch.Generator().manual_seed(0))
                rollout = time.perf_counter() - t1
        print(f"{name:<18}{per_epoch:>9.2f}{config.epochs:>8}{per_epoch * config.epochs:>9.0f}{evaluation:>15.2f}")
    print(f"{'rpecnet':<18}{'':>9}{'':>8}{'':>9}{rollout:>15.2f}")
    t0 = time.perf_counter()
    test_set = window_set(test, str(test.split[0]), with_future=False)
    ConstantVelocity({}).predict(test_set, 20, Path("."), 0)  # nothing fitted: reads no workdir
    print(f"{'constant_velocity':<18}{'':>9}{'':>8}{'':>9}{time.perf_counter() - t0:>15.2f}")


if __name__ == "__main__":
    main()
