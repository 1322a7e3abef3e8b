"""Section `report` of params.yaml: the report's colour thresholds."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class ReportParams:
    close: float
    """|ours - paper| / paper at or below this is shown green ("reproduced")."""
    far: float
    """Above this it is red; amber between `close` and `far`."""

    def __post_init__(self):
        if not 0 <= self.close < self.far:
            raise ValueError(f"need 0 <= close < far, got close={self.close}, far={self.far}")
