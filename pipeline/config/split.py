"""Section `split` of params.yaml: the validation videos carved from TrajNet's train videos."""

from __future__ import annotations

from dataclasses import dataclass, field

from pipeline.splits import TRAIN_VIDEOS


@dataclass
class SplitParams:
    val_videos: list[str] = field(default_factory=list)
    """Train videos held out for validation (model selection); whole videos, never test ones."""

    def __post_init__(self):
        not_train = sorted(set(self.val_videos) - TRAIN_VIDEOS)
        if not_train:
            raise ValueError(f"val_videos must be TrajNet train videos; not train: {not_train}")
