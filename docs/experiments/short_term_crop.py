"""What seeing a window around each agent costs and saves short-term Y-net, against whole scenes.

Not a test: prints numbers. Takes a trained `short_term_ynet@<dataset>` checkpoint (trained on
crops in the cpu profile) and a fixed seeded sample of that benchmark's *validation* windows (never
the test set), scores them at K_e on each crop side (0 = the whole scene; a convolutional model
runs on any size) and prints best-of-K ADE / FDE (original pixels), seconds per window and the
share of windows whose future leaves the crop.
Written up in docs/profiles.md (row "short-term Y-net: what the model sees").

    python -m docs.experiments.short_term_crop --dataset sdd --crops 64 96 0 --windows-sample 300
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from bench import short_term_validation
from pipeline.benchmarks.registry import short_term
from pipeline.runners.short_term import ynet_options
from pipeline.runners.ynet_scoring import predict_scenes
from pipeline.harness.metrics import window_errors


def outside_share(past: np.ndarray, future: np.ndarray, resize: float, crop: int,
                  lead_steps: float) -> float:
    """Share of windows with a future position outside the crop (as `window_inputs` centres it)."""
    last = past[:, -1]
    centre = np.round((last + lead_steps * (last - past[:, -2])) * resize)  # (N, 2) map pixels
    reach = np.abs(future * resize - centre[:, None]).max(axis=(1, 2))
    return float((reach > crop // 2 - 1).mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    short_term_validation.add_arguments(parser)
    parser.add_argument("--crops", type=int, nargs="+", default=[64, 96, 0])
    parser.add_argument("--k", type=int, default=20)
    args = parser.parse_args()
    trained = short_term_validation.load_from_arguments(args, "short_term_crop")
    model, loaded, settings, val, scenes = (trained.model, trained.settings, trained.stage,
                                            trained.val, trained.scenes)
    options = ynet_options(settings, short_term(args.dataset), args.k)  # as the stage samples
    eval_params = settings.eval_params()  # batch, chunk and bf16 as the stage scores
    print(f"{args.dataset}: {len(val)} val windows, K_e = {args.k}, resize {loaded.resize:.4f}, "
          f"trained on crop {loaded.crop}, lead {loaded.crop_lead_steps} steps, load average "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    for crop in args.crops:
        start = time.perf_counter()
        paths, goals = predict_scenes(model, scenes, loaded, options, settings.seed, eval_params,
                                      len(val), f"crop {crop}", crop, loaded.crop_lead_steps)
        seconds = (time.perf_counter() - start) / len(val)
        errors = window_errors(paths, val.future, goals)
        leaves = ("whole scene" if crop == 0 else f"futures leaving it "
                  f"{outside_share(val.past, val.future, loaded.resize, crop, loaded.crop_lead_steps):.1%}")
        print(f"  crop {crop:3d}: ADE {errors.ade.mean():7.2f} px  FDE {errors.fde.mean():7.2f} px  "
              f"{seconds:.3f} s per window  ({leaves})")


if __name__ == "__main__":
    main()
