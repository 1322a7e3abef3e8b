"""Section `cws` of params.yaml: Y-net's Conditioned Waypoint Sampling prior (`ynet.sampling`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class CwsParams:
    sigma_factor: float = 6.0
    """Prior sigma = (distance + 5) / sigma_factor."""
    ratio: float = 2.0
    """Prior sigma across the direction of travel is divided by this."""
    rot: bool = True
    """Rotate the prior to the direction of travel."""

    def __post_init__(self):
        for name in ("sigma_factor", "ratio"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
