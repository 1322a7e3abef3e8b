"""Section `ind_benchmark.<profile>` of params.yaml: what differs on inD from SDD."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class IndBenchmarkParams:
    """Section `ind_benchmark.<profile>` of params.yaml: what differs on inD from SDD."""

    ynet_resize: float
    """Y-net's map and coordinate scale on inD backgrounds (authors: 0.33; SDD 0.25)."""
    segmentation_downsample: int
    """The U-Net sees inD backgrounds downsampled by this factor (paper: 3; SDD 4)."""
    freeze_encoder_epochs: int
    """Fine-tuning epochs (of `segmentation.<profile>.epochs`) with the U-Net encoder frozen."""

    def __post_init__(self) -> None:
        if not 0 < self.ynet_resize <= 1:
            raise ValueError(f"ynet_resize must be in (0, 1], got {self.ynet_resize}")
        if self.segmentation_downsample < 1 or self.freeze_encoder_epochs < 0:
            raise ValueError("need segmentation_downsample >= 1 and freeze_encoder_epochs >= 0")
