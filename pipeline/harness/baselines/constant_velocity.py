"""Constant velocity: the last observed velocity extrapolated over the horizon.

The extrapolation is the registered model's (`pipeline.models.constant_velocity.extrapolate`).
Deterministic, nothing to train: the one path is repeated for every one of the K samples, so it is
scored with the same best-of-K metric as the stochastic models (its min over K is that path).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from pipeline.data.window_table import WindowArrays
from pipeline.models.constant_velocity import extrapolate
from pipeline.preemption import Preemption


@dataclass
class ConstantVelocityConfig:
    """No settings: the section exists so every model has one."""


class ConstantVelocity:
    """The constant-velocity model behind the common baseline interface."""

    name = "constant_velocity"
    config_class = ConstantVelocityConfig
    trainable = False

    @classmethod
    def fit(cls, train: WindowArrays, val: WindowArrays, config: ConstantVelocityConfig,
            checkpoint_dir: Path | None = None, seed: int = 0, device: torch.device | None = None,
            preemption: Preemption | None = None) -> ConstantVelocity:
        return cls()

    @classmethod
    def load(cls, checkpoint_dir: Path | None = None, device: torch.device | None = None,
             selection: str = "raw") -> ConstantVelocity:
        """`device` and `selection` are taken for a uniform interface: nothing is trained, and the
        extrapolation is numpy, on the CPU."""
        return cls()

    def predict(self, arrays: WindowArrays, k: int, generator: torch.Generator | None = None,
                n_future: int | None = None) -> np.ndarray:
        """(N, k, n_f, 2) in pixels; n_f is the windows' future length unless `n_future` is given."""
        n_future = arrays.future.shape[1] if n_future is None else n_future
        path = extrapolate(np.asarray(arrays.past, np.float64), n_future)  # (N, n_f, 2)
        return np.repeat(path[:, None], k, axis=1)  # (N, k, n_f, 2)
