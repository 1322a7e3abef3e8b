"""Section `rpecnet_rollouts` of params.yaml: the R-PECNet roll-out diagnostic."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class RpecnetRolloutsParams:
    """Section `rpecnet_rollouts`: the diagnostic stage `rpecnet_rollouts`, which rolls the
    t_f = 5 PECNet out in several ways (`pipeline.runners.baselines.rpecnet.VARIANTS`) to see
    which of them gives the compounding error of the paper's R-PECNet. Never the headline."""

    variants: list[str] = field(default_factory=lambda: [
        "independent", "shared_latent", "mean_fed_back", "original_frame"])
    """Roll-outs scored on the choice split (names checked against the variants the code has)."""
    horizons: list[int] = field(default_factory=lambda: [30])
    """t_f (seconds) of the horizon tables scored."""
    k: int = 20
    """Samples per window, best of K (independent minima of ADE and FDE, the headline protocol)."""
    seed: int = 0
    """Seed of every variant's sampling generator (each variant and split from a fresh one)."""
    split_for_choice: str = "val"
    """Split the variant is chosen on; never test (the chosen one alone is then scored on test)."""
    target_fde_over_ade: float = 2.872
    """The chosen variant's mean FDE / mean ADE is the nearest to this: the paper's R-PECNet at
    t_f = 30 s, 750.42 / 261.27 px (Table 3)."""
    threads: int = 1
    """torch CPU threads."""

    def __post_init__(self):
        names = self.variants
        if not isinstance(names, list) or not names or len(set(names)) != len(names) \
                or not all(isinstance(n, str) for n in names):
            raise ValueError(f"variants must be a non-empty list of distinct names, got {names!r}")
        horizons = self.horizons
        if not isinstance(horizons, list) or not horizons or len(set(horizons)) != len(horizons) \
                or any(isinstance(h, bool) or not isinstance(h, int) or h < 1 for h in horizons):
            raise ValueError(f"horizons must be a non-empty list of distinct t_f >= 1, got "
                             f"{self.horizons!r}")
        if self.k < 1 or self.threads < 1:
            raise ValueError("k and threads must be >= 1")
        if self.split_for_choice not in ("train", "val"):
            raise ValueError(f"split_for_choice must be train or val (never test), got "
                             f"{self.split_for_choice!r}")
        if not 0 < self.target_fde_over_ade < float("inf"):
            raise ValueError(f"target_fde_over_ade must be a positive ratio, got "
                             f"{self.target_fde_over_ade}")
