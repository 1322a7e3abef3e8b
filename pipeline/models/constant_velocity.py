"""Constant velocity, written to the contract of `pipeline.models`: the worked example of README
"Your model here". Its registry line in params.yaml:

    models:
      constant_velocity: {class: ConstantVelocity, label: Constant velocity, colour: "#7f7f7f", settings: {}}

The last observed velocity extrapolated, x_{t+s} = x_t + s (x_t - x_{t-1}) (`extrapolate`). The
pipeline's one constant velocity: the long-term horizons run it as a registered model (stages
`fit_model` / `predict_model`), inD scores it as its reference through the same contract, and the
chain-bias measurement uses `extrapolate`. Deterministic and with nothing to learn: `fit` keeps
nothing, and the one path is returned k times (its best of k is that path).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.models import WindowSet

NAME = Path(__file__).stem  # the contract names a model by its file: registry key, stages, files


def extrapolate(past: np.ndarray, n_future: int) -> np.ndarray:
    """(N, n_p, 2) observed positions -> (N, n_future, 2): x_{t+s} = x_t + s (x_t - x_{t-1})."""
    velocity = past[:, -1] - past[:, -2]  # (N, 2) per step
    steps = np.arange(1, n_future + 1, dtype=np.float64)  # (n_f,)
    return past[:, -1, None] + steps[None, :, None] * velocity[:, None]  # (N, n_f, 2)


class ConstantVelocity:
    def __init__(self, settings: Mapping[str, Any]) -> None:
        if settings:
            raise ValueError(f"constant velocity takes no settings, got {sorted(settings)}")

    def fit(self, train: WindowSet, val: WindowSet, workdir: Path, seed: int) -> None:
        """Nothing to learn: the workdir stays empty."""

    def predict(self, test: WindowSet, k: int, workdir: Path, seed: int) -> np.ndarray:
        path = extrapolate(test.past, test.n_future)  # (N, n_f, 2)
        return np.repeat(path[:, None], k, axis=1)  # (N, k, n_f, 2)
