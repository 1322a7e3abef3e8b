"""Section `short_term` of params.yaml: the short-term windows and the ETH/UCY maps."""

from __future__ import annotations

from dataclasses import dataclass, field

from pipeline.splits import FOLD_TEST_SCENES, SDD_RAW_FPS, TRAIN_VIDEOS


@dataclass(frozen=True)
class ShortTermParams:
    """Section `short_term` of params.yaml: the short-term windows and the ETH/UCY maps."""

    n_past: int = 8
    """Observed steps n_p (3.2 s at 2.5 FPS)."""
    n_future: int = 12
    """Predicted steps n_f (4.8 s); n_past + n_future = 20 is what the TrajNet SDD files hold."""
    fps: float = 2.5
    """Frame rate of the windows."""
    sdd_ratio_version: str = "A"
    """Row of `H_SDD.txt` (A or B) whose metres-per-pixel ratio converts TrajNet metres to pixels."""
    sdd_val_videos: list[str] = field(
        default_factory=lambda: ["bookstore_2", "deathCircle_3", "gates_8", "hyang_6", "nexus_7"])
    """Whole TrajNet train videos held out for model selection (never test videos)."""
    ethucy_folds: list[str] = field(default_factory=lambda: list(FOLD_TEST_SCENES))
    """Leave-one-scene-out folds to build (SGAN's folders)."""
    ethucy_min_agents: int = 2
    """A 20-frame run gives windows only if this many pedestrians are in all of it (SGAN: 2)."""
    ethucy_map_downsample: float = 1.5
    """The ETH/UCY maps are stored at 1 / this of the oracle's size (Y-net's ETH/UCY resize)."""

    def __post_init__(self) -> None:
        if self.n_past < 2 or self.n_future < 1:
            raise ValueError("n_past must be at least 2 and n_future at least 1")
        if self.fps <= 0 or (SDD_RAW_FPS / self.fps) % 1:
            raise ValueError(f"fps must divide SDD's {SDD_RAW_FPS} FPS, got {self.fps}")
        if self.sdd_ratio_version not in ("A", "B"):
            raise ValueError(f"sdd_ratio_version must be 'A' or 'B', got {self.sdd_ratio_version!r}")
        not_train = sorted(set(self.sdd_val_videos) - TRAIN_VIDEOS)
        if not_train:
            raise ValueError(f"sdd_val_videos must be TrajNet train videos; not train: {not_train}")
        unknown = sorted(set(self.ethucy_folds) - set(FOLD_TEST_SCENES))
        if unknown or not self.ethucy_folds or len(set(self.ethucy_folds)) < len(self.ethucy_folds):
            raise ValueError(f"ethucy_folds must be distinct folds of {sorted(FOLD_TEST_SCENES)}, "
                             f"got {self.ethucy_folds}")
        if self.ethucy_min_agents < 1:
            raise ValueError("ethucy_min_agents must be at least 1")
        if self.ethucy_map_downsample < 1:
            raise ValueError("ethucy_map_downsample must be at least 1")

    @property
    def window_length(self) -> int:
        return self.n_past + self.n_future

    @property
    def sdd_frame_step(self) -> int:
        """Raw SDD frames between two window steps (12 at 2.5 FPS)."""
        return int(SDD_RAW_FPS / self.fps)

    @property
    def ethucy_resize(self) -> float:
        return 1.0 / self.ethucy_map_downsample
