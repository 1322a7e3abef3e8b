"""Section `labels` of params.yaml: how the report overlays of the hand labels look."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LabelsParams:
    """How the report overlays of the hand labels look (the label maps themselves are lossless)."""

    overlay_scale: float = 0.25
    """Overlays are written at this fraction of the original image size."""
    overlay_alpha: float = 0.45
    """Weight of the class colour over the image in the overlays."""

    def __post_init__(self) -> None:
        if not 0 < self.overlay_scale <= 1:
            raise ValueError(f"overlay_scale must be in (0, 1], got {self.overlay_scale}")
        if not 0 <= self.overlay_alpha <= 1:
            raise ValueError(f"overlay_alpha must be in [0, 1], got {self.overlay_alpha}")
