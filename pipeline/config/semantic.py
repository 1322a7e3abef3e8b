"""Section `semantic` of params.yaml: which scene maps Y-net gets, and at what resolution."""

from __future__ import annotations

from dataclasses import dataclass


SEMANTIC_SOURCES = ("predicted", "labels")


@dataclass(frozen=True)
class SemanticParams:
    """Section `semantic` of params.yaml: which scene maps Y-net gets, and at what resolution."""

    source: str = "predicted"
    """'predicted' (the U-Net's softmax) or 'labels' (one-hot hand labels: the oracle ablation)."""
    resize: float = 0.25
    """Maps are stored at this fraction of the original image size (Y-net's SDD resize, 0.25)."""

    def __post_init__(self) -> None:
        if self.source not in SEMANTIC_SOURCES:
            raise ValueError(f"source must be one of {SEMANTIC_SOURCES}, got {self.source!r}")
        if not 0 < self.resize <= 1:
            raise ValueError(f"resize must be in (0, 1], got {self.resize}")
