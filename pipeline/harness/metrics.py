"""The one metric every model (baselines and Y-net) is scored with: best-of-K ADE and FDE in pixels,
and the one summary over seeded rounds (`seeded_rounds`) every metrics file uses.

Inputs are in original image pixels (the window table's coordinates), as numpy arrays or torch
tensors; everything is computed in float64 numpy.

- ADE of a sample: mean over the n_f future steps of the L2 distance to the ground truth.
- FDE of a sample: L2 distance of its final point to the ground-truth final point. A model with a
  separate goal prediction (Y-net samples a goal, then a path to it) passes `goals`; FDE then uses
  the goal and ADE the path.
- Independent minima (the paper's protocol, as upstream computes it): min over K of ADE and,
  separately, min over K of FDE; the two may come from different samples.
- Joint minima: the sample with the lowest ADE is chosen, and its ADE and FDE are reported
  (`ade_joint` therefore equals `ade`; `fde_joint` >= `fde`). Ties go to the lowest sample index.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

METRIC_KEYS = ("ade", "fde", "ade_joint", "fde_joint")
"""The four summaries every benchmark reports: best-of-K ADE / FDE, independent and joint."""


def as_numpy(values: Any) -> np.ndarray:
    """A float64 numpy copy of a numpy array or torch tensor (on any device)."""
    if hasattr(values, "detach"):  # torch.Tensor, without importing torch here
        values = values.detach().cpu().numpy()
    return np.asarray(values, dtype=np.float64)


def step_errors(pred: Any, truth: Any) -> np.ndarray:
    """L2 distance per window, sample and step: pred (N, K, n_f, 2), truth (N, n_f, 2) -> (N, K, n_f)."""
    pred, truth = as_numpy(pred), as_numpy(truth)
    if pred.ndim != 4 or pred.shape[-1] != 2:
        raise ValueError(f"predictions must be (N, K, n_f, 2), got {pred.shape}")
    if truth.shape != (pred.shape[0], pred.shape[2], 2):
        raise ValueError(f"ground truth {truth.shape} does not match predictions {pred.shape}")
    return np.linalg.norm(pred - truth[:, None], axis=-1)


def goal_errors(goals: Any, truth: Any) -> np.ndarray:
    """L2 distance of goals (N, K, 2) to the final ground-truth point of truth (N, n_f, 2) -> (N, K)."""
    goals, truth = as_numpy(goals), as_numpy(truth)
    if goals.ndim != 3 or goals.shape[0] != truth.shape[0] or goals.shape[-1] != 2:
        raise ValueError(f"goals must be (N, K, 2) with N = {truth.shape[0]}, got {goals.shape}")
    return np.linalg.norm(goals - truth[:, None, -1], axis=-1)


@dataclass(frozen=True)
class WindowErrors:
    """Best-of-K errors per window, in pixels."""

    ade: np.ndarray  # (N,) min over K of ADE
    fde: np.ndarray  # (N,) min over K of FDE, independently of ADE (paper protocol)
    fde_joint: np.ndarray  # (N,) FDE of the sample with the lowest ADE
    best_ade_sample: np.ndarray  # (N,) int, index of the sample with the lowest ADE
    best_fde_sample: np.ndarray  # (N,) int, index of the sample with the lowest FDE
    k: int  # number of samples the minima were taken over

    def __len__(self) -> int:
        return len(self.ade)

    def summary(self) -> dict[str, float | int]:
        """Means over windows: the numbers a metrics JSON reports."""
        return summarize(self)


def window_errors(pred: Any, truth: Any, goals: Any | None = None) -> WindowErrors:
    """Best-of-K ADE and FDE per window.

    pred: (N, K, n_f, 2) predicted paths; truth: (N, n_f, 2); goals: optional (N, K, 2) goal
    predictions, used for FDE instead of each path's last point.
    """
    per_step = step_errors(pred, truth)  # (N, K, n_f)
    ade_k = per_step.mean(axis=-1)  # (N, K)
    fde_k = per_step[..., -1] if goals is None else goal_errors(goals, truth)  # (N, K)
    if fde_k.shape != ade_k.shape:
        raise ValueError(f"goals give {fde_k.shape[1]} samples, paths {ade_k.shape[1]}")
    best_ade = ade_k.argmin(axis=1)  # (N,) first index on ties
    best_fde = fde_k.argmin(axis=1)  # (N,)
    rows = np.arange(len(ade_k))
    return WindowErrors(
        ade=ade_k[rows, best_ade],
        fde=fde_k[rows, best_fde],
        fde_joint=fde_k[rows, best_ade],
        best_ade_sample=best_ade,
        best_fde_sample=best_fde,
        k=ade_k.shape[1],
    )


def summarize(errors: WindowErrors) -> dict[str, float | int]:
    """Mean over windows of the independent and joint minima (NaN for an empty set)."""
    n = len(errors)

    def mean(values: np.ndarray) -> float:
        return float(values.mean()) if n else float("nan")

    return {
        "ade": mean(errors.ade),
        "fde": mean(errors.fde),
        "ade_joint": mean(errors.ade),
        "fde_joint": mean(errors.fde_joint),
        "k": int(errors.k),
        "n_windows": int(n),
    }


def ade_fde(pred: Any, truth: Any, goals: Any | None = None) -> dict[str, float | int]:
    """Shortcut: `summarize(window_errors(pred, truth, goals))`."""
    return summarize(window_errors(pred, truth, goals))


# ---------------------------------------------------------------------------------------------
# Seeded rounds: the one way a benchmark turns repeated sampling into a number and its spread


def round_scores(errors: WindowErrors) -> dict[str, float]:
    """One round's means over windows of the four `METRIC_KEYS`."""
    summary = summarize(errors)
    return {key: summary[key] for key in METRIC_KEYS}


def summarize_rounds(per_round: list[dict[str, float]]) -> dict[str, dict[str, float]]:
    """{metric: {mean, std, min, max}} over rounds (population std: 0 for one round)."""
    if not per_round:
        raise ValueError("no rounds to summarize")
    result = {}
    for key in METRIC_KEYS:
        values = np.array([r[key] for r in per_round], dtype=np.float64)
        result[key] = {"mean": float(values.mean()), "std": float(values.std()),
                       "min": float(values.min()), "max": float(values.max())}
    return result


def rounds_record(per_round: list[dict[str, float]]) -> dict:
    """The metrics layout every benchmark writes for one setting scored over seeded rounds:
    {"ade": {"mean", "std", "min", "max"}, "fde", "ade_joint", "fde_joint", "rounds", "per_round"}."""
    return {**summarize_rounds(per_round), "rounds": len(per_round), "per_round": list(per_round)}


def seeded_rounds(score_round: Callable[[int], WindowErrors], rounds: int, seed: int) -> dict:
    """Score `rounds` seeded rounds, round r with seed `seed + r`; `score_round(seed)` samples the
    model once over the test set and returns its `WindowErrors`. Returns `rounds_record`."""
    if rounds < 1:
        raise ValueError(f"rounds must be >= 1, got {rounds}")
    return rounds_record([round_scores(score_round(seed + r)) for r in range(rounds)])
