"""Section `ttst` of params.yaml: Y-net's Test-Time Sampling Trick (`ynet.sampling`). No defaults:
params.yaml holds the values (the authors' long-term SDD ones), in one place."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class TtstParams:
    temperature: float
    """Goal and waypoint maps are sigmoid(logits / temperature) before sampling."""
    rel_threshold: float
    """Pixels below rel_threshold * max are never sampled."""

    def __post_init__(self):
        if not self.temperature > 0:
            raise ValueError(f"temperature must be > 0, got {self.temperature}")
        if not 0 <= self.rel_threshold < 1:
            raise ValueError(f"rel_threshold must be in [0, 1), got {self.rel_threshold}")
