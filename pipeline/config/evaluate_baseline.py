"""Section `evaluate_baseline` of params.yaml: how the long-term baselines are scored."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class EvaluateBaselineParams:
    k: int
    """Samples per window; the metric takes the best of them (paper: 20)."""
    split: str
    """Split scored: `test` for the benchmark, `val` while developing."""
    rounds: int
    """Independently seeded sampling rounds (seeds seed, seed+1, ...); mean and spread reported."""
    seed: int
    """Seed of the first round."""
    threads: int
    """torch CPU threads."""
    epoch_selection: str = "raw"
    """Which kept epoch of a trained baseline is scored: `raw` (lowest validation ADE) or a smoothed
    rule of `pipeline.harness.epoch_selection` (chosen by the stage `epoch_selection`'s study;
    checked there, where the rules are defined)."""

    def __post_init__(self):
        if self.k < 1 or self.rounds < 1 or self.threads < 1:
            raise ValueError("k, rounds and threads must be >= 1")
        if self.split not in ("train", "val", "test"):
            raise ValueError(f"split must be train, val or test, got {self.split!r}")
