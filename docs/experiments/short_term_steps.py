"""Where a trained short-term Y-net loses accuracy: the goal it picks, or the path to that goal.

Not a test: prints numbers. On a fixed seeded sample of the benchmark's *validation* windows
(never the test set) it prints the error per future step (original pixels) of one deterministic
path (softargmax heatmaps, K = 1) decoded
- towards the goal decoder's own softargmax goal (what validation ADE / FDE measure),
- towards the true goal (the trajectory decoder alone),
and of constant velocity, plus the mean peak of the trajectory decoder's per-step softmax: a flat
heatmap's softargmax drifts to the centre of the map (or crop) whatever the step.
Written up in docs/profiles.md (where the `cpu` short-term Y-net loses accuracy).

    python -m docs.experiments.short_term_steps --dataset sdd --windows-sample 300
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from bench import short_term_validation
from pipeline.runners.ynet_scoring import PAD_CLASS
from pipeline.data.ynet_data import window_inputs
from ynet.heatmaps import distance_maps
from ynet.sampling import softargmax


def constant_velocity(past: torch.Tensor, n_future: int) -> torch.Tensor:
    """(B, n_p, 2) -> (B, n_f, 2): the last observed step repeated."""
    step = past[:, -1] - past[:, -2]
    return past[:, -1:] + step[:, None] * torch.arange(1, n_future + 1)[None, :, None]


@torch.inference_mode()
def step_errors(trained: short_term_validation.TrainedOnValidation,
                batch_size: int = 16) -> dict[str, np.ndarray]:
    """Errors (N, n_f) in original pixels per decoding, and the softmax peaks (N, n_f)."""
    model, settings = trained.model, trained.settings
    goal_step = list(model.config.waypoints)
    out = {"own goal": [], "true goal": [], "constant velocity": [], "softmax peak": []}
    for scene in trained.scenes:
        for start in range(0, len(scene), batch_size):
            past, future = scene.past[start:start + batch_size], scene.future[start:start + batch_size]
            inputs, origin = window_inputs(scene.semantic, past, settings.max_distance, settings.crop,
                                           PAD_CLASS, settings.crop_lead_steps)
            origin = origin[:, None]  # (B, 1, 2): map pixels -> model-input pixels
            height, width = inputs.shape[-2:]
            features = model.encode(inputs)
            own = softargmax(model.predict_goals(features)[:, goal_step])  # (B, n_w, 2) crop pixels
            for name, waypoints in (("own goal", own), ("true goal", future[:, goal_step] - origin)):
                logits = model.predict_trajectory(
                    features, distance_maps(waypoints, height, width, settings.max_distance))
                path = softargmax(logits) + origin  # (B, n_f, 2)
                out[name].append(((path - future).norm(dim=-1) / settings.resize).numpy())
                if name == "true goal":
                    out["softmax peak"].append(torch.softmax(logits.flatten(2), -1).amax(-1).numpy())
            guess = constant_velocity(past, future.shape[1])
            out["constant velocity"].append(((guess - future).norm(dim=-1) / settings.resize).numpy())
    return {name: np.concatenate(values) for name, values in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    short_term_validation.add_arguments(parser)
    args = parser.parse_args()
    trained = short_term_validation.load_from_arguments(args, "short_term_steps")
    results = step_errors(trained)
    print(f"{args.dataset}: {len(trained.val)} val windows, K = 1, original pixels; "
          "error per future step")
    for name, values in results.items():
        if name == "softmax peak":
            print(f"  {'softmax peak':18s}              " + " ".join(f"{v:5.3f}" for v in values.mean(0)))
        else:
            print(f"  {name:18s} ADE {values.mean():6.2f} FDE {values[:, -1].mean():6.2f}  "
                  + " ".join(f"{v:5.1f}" for v in values.mean(0)))


if __name__ == "__main__":
    main()
