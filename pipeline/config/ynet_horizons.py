"""Section `ynet_horizons.<profile>` of params.yaml: the horizons Y-net is trained at, and how."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class HorizonParams:
    """Section `ynet_horizons.<profile>` of params.yaml."""

    epochs: dict[int, int] = field(default_factory=dict)
    """Horizon (s) -> training epochs, for the horizons this profile trains Y-net at (the other
    settings are `ynet.<profile>`'s); any other horizon gets a 'not run' record."""
    rounds: int = 3
    """Evaluation rounds (TTST + CWS, K_e from `eval.<profile>`, K_a = 1)."""
    why_subset: str = ""
    """Shown in the report for a horizon this profile does not train."""
    init_from_main: bool = False
    """Start each horizon from the main (30-s) Y-net's weights, its two output heads stretched to
    the horizon (`ynet.model.weights_for_horizon`), instead of a seeded random init (the authors')."""

    def __post_init__(self):
        if self.rounds < 1 or any(int(e) < 1 for e in self.epochs.values()):
            raise ValueError("epochs and rounds must be >= 1")

    @property
    def horizons(self) -> list[int]:
        return sorted(int(h) for h in self.epochs)
