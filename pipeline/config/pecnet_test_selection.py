"""Section `pecnet_test_selection` of params.yaml: the long-term compat diagnostic of upstream
PECNet's selection on test."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class PecnetTestSelectionParams:
    """Section `pecnet_test_selection`: a labelled compat diagnostic (stage `pecnet_test_selection`),
    never a headline number. Upstream PECNet scores the test set after every epoch and reports the
    best test ADE and the best test FDE over epochs (selection on test); the stage retrains PECNet as
    `train_baseline@pecnet-<t_f>` does, scores the test windows after every epoch and reports both
    that and the epoch kept on validation."""

    horizons: list[int] = field(default_factory=lambda: [30])
    """t_f (s) retrained; each needs its `data/horizon_windows/tf<t_f>.parquet` and
    `metrics/baselines/train_pecnet_tf<t_f>.json` among the stage's deps."""
    k: int = 20
    """Samples per test window, best of K (the paper's K = 20)."""
    seed: int = 0
    """Seed of the test sampling, the same after every epoch (epochs differ by weights alone)."""

    def __post_init__(self):
        if not self.horizons or any(isinstance(h, bool) or not isinstance(h, int) or h < 2
                                    for h in self.horizons):
            raise ValueError(f"horizons must be a non-empty list of t_f >= 2 s, got {self.horizons}")
        if len(set(self.horizons)) != len(self.horizons):
            raise ValueError(f"horizons repeat: {self.horizons}")
        if self.k < 1:
            raise ValueError(f"k must be >= 1, got {self.k}")
