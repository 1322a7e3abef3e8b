"""Section `train_baseline` of params.yaml: the trained baselines' seed and threads."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class TrainBaselineParams:
    seed: int
    """Seed of all randomness in training (initialisation, batches, noise)."""
    threads: int
    """torch CPU threads."""

    def __post_init__(self):
        if self.threads < 1:
            raise ValueError("threads must be >= 1")
