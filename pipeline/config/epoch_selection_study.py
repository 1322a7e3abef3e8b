"""Section `epoch_selection_study` of params.yaml: the split-half study of the epoch selection
rules."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EpochSelectionStudyParams:
    """Section `epoch_selection_study`: the split-half study of the stage `epoch_selection`, which
    compares the epoch selection rules on validation windows alone
    (`pipeline.studies.epoch_selection`)."""

    n_splits: int = 200
    """Random halvings of each run's validation windows (each half chooses once)."""
    seed: int = 0
    """Seed of the halvings."""

    def __post_init__(self):
        if self.n_splits < 1:
            raise ValueError("n_splits must be >= 1")
