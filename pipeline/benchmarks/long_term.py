"""What the long-term benchmarks (paper Tables 3 and 4: SDD, `pipeline.benchmarks.sdd_long_term`,
and inD, `pipeline.benchmarks.ind`) share: where their models' records lie in metrics/, so that
the report asks the benchmark instead of testing its name, and the windows and backgrounds a
benchmark's folder gives the long-term runners (`LongTermData`, `pipeline.runners.long_term_benchmark`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pipeline.benchmarks.base import Benchmark
from pipeline.data.window_table import WindowArrays


@dataclass(frozen=True)
class Background:
    """A scene's background image, which its semantic map is predicted from."""

    image: Path  # (H, W, 3) BGR
    labels: Path | None  # its hand-labelled mask (H, W), values the U-Net's classes; None: none


@dataclass(frozen=True)
class LongTermData:
    """A long-term benchmark's folder as its runners train and score on it: the windows of its
    horizon and of R-PECNet's base horizon, and the scenes' backgrounds with the labelled ones the
    U-Net is fine-tuned and scored on."""

    index: Path  # the file listing the scenes (errors about them name it)
    n_past: int
    horizon: int  # t_f (s) of `long`
    table: Path  # the window table of `long`: the predictions' window ids are its
    long: WindowArrays  # t_f = `horizon`, every split
    base: WindowArrays  # t_f = R-PECNet's base horizon: its PECNet trains on them
    splits: dict[str, WindowArrays]  # train / val / test of `long`
    sizes: dict[str, tuple[int, int]]  # scene -> (H, W) of its background
    backgrounds: dict[str, Background]  # scene -> its background
    finetune_scenes: list[str]  # labelled train backgrounds the U-Net is fine-tuned on
    scored_scenes: list[str]  # labelled test backgrounds its maps are scored on
    unlabelled_note: str  # why, with no labelled train background, the U-Net runs unchanged


@dataclass(frozen=True)
class LongTermBenchmark(Benchmark):
    """A long-term benchmark: the record of its Y-net scoring and where its baselines' and its
    stored predictions' scores are."""

    metrics_file: str = ""  # in metrics/: Y-net's main setting, ablation and K_a grid

    def baseline_metrics(self, model: str, t_f: int) -> tuple[str, tuple[str, ...]]:
        """(file in metrics/, keys to the record) of a baseline's scores at horizon `t_f`."""
        raise NotImplementedError

    def stored_scores(self, model: str, table: str) -> tuple[str, tuple[str, ...]]:
        """(file in metrics/, keys to the record) of a model's stored-predictions scores (stage
        `score_predictions`); `table`: the window table scored, where the benchmark has several."""
        raise NotImplementedError

    def not_provided(self, folder: Path) -> str | None:
        """Why the benchmark's `folder` holds no windows (None: it does), the folder checked first."""
        raise NotImplementedError

    def load(self, folder: Path) -> LongTermData:
        """The windows and backgrounds of a provided `folder`."""
        raise NotImplementedError
