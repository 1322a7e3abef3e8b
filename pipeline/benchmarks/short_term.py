"""What the short-term benchmarks (paper Tables 1 and 2) share: windows of n_p = 8 observed and
n_f = 12 future steps at 2.5 FPS in one folder (stage `short_term_windows`), one table a benchmark,
each a `ShortTermBenchmark` named by the stages' `--dataset`: TrajNet SDD
(`pipeline.benchmarks.trajnet_sdd`) and each ETH/UCY leave-one-scene-out fold
(`pipeline.benchmarks.ethucy`).

A short-term benchmark says where its table is, the unit its errors are in, the params keys of
its own settings (`settings_key`: `k_<key>`, `ynet_<key>`, `rel_threshold.<key>`,
`epochs.<model>.<key>`, `ynet_training.<key>`, `short_term_baselines.<profile>.<model>.<key>`),
its summary for the report (`summary_file`, `table_k`), the fetched raw sources its scenes come
from (`raw_sources`), what scoring its stored predictions reads (`scored_table` of
`ScoringSources`), and loads its windows (`load`: original pixels, the test truth in its unit;
`load_in_unit`: every split in its unit, for the baselines; by default as they are, for a
benchmark in pixels). The tables' text files are read here (`read_rows`) and numbered here
(`number_windows`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, TYPE_CHECKING

import numpy as np
import pandas as pd

from pipeline.benchmarks.base import Benchmark, SceneMasks, ScoredTable
from pipeline.data.window_table import WindowArrays, conform, select_split, to_arrays
from pipeline.io import IntermediateError
from pipeline.model_list import YNET

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.short_term_models import ShortTermModelsParams, YnetScale
    from pipeline.config.ynet import YnetSettings

METRE_COLUMNS = ("x_m", "y_m")
SPLITS = ("train", "val", "test")


class ShortTermInputError(ValueError):
    """A raw file of the short-term benchmarks that cannot be used as it is."""


@dataclass(frozen=True)
class ShortTermSplits:
    """One benchmark's windows (original pixels, or its unit: `load_in_unit`) and the test ground
    truth in the unit it is scored in."""

    train: WindowArrays
    val: WindowArrays
    test: WindowArrays
    truth: np.ndarray  # (N_test, n_f, 2) in `unit`
    unit: str  # px | m
    to_unit: Callable[[np.ndarray], np.ndarray]  # (N_test, ..., 2) the windows' coordinates -> unit


def splits_of(table: pd.DataFrame, title: str, n_past: int, n_future: int
              ) -> tuple[WindowArrays, WindowArrays, WindowArrays]:
    """Train, val and test windows of a short-term window table; a ValueError (naming `title`)
    unless every split has windows of n_past + n_future steps."""
    arrays = to_arrays(table, n_past)
    if arrays.future.shape[1] != n_future:
        raise ValueError(f"{title}: windows of {n_past} + {arrays.future.shape[1]} steps, "
                         f"expected {n_past} + {n_future}")
    train, val, test = (select_split(arrays, s) for s in SPLITS)
    if min(len(train), len(val), len(test)) == 0:
        raise ValueError(f"{title}: every split needs windows (train {len(train)}, "
                         f"val {len(val)}, test {len(test)})")
    return train, val, test


@dataclass
class ScoringSources:
    """What scoring a short-term benchmark's stored predictions may read besides its table: the
    `short_term_windows` folder, SDD's hand-label masks and scales (TrajNet SDD), and the masks
    read so far (the ETH/UCY folds share one folder of road maps: it is read once)."""

    windows: Path
    n_past: int
    sdd_masks: SceneMasks | None = None
    scales: Mapping[str, float] = field(default_factory=dict)
    scales_path: Path | None = None
    read_masks: dict[Path, SceneMasks] = field(default_factory=dict)

    def masks(self, folder: Path, read: Callable[[Path], SceneMasks]) -> SceneMasks:
        """The masks of `folder`, `read` on first use."""
        if folder not in self.read_masks:
            self.read_masks[folder] = read(folder)
        return self.read_masks[folder]


@dataclass(frozen=True)
class ShortTermBenchmark(Benchmark):
    """A short-term benchmark: its `--dataset` name, its table in the `short_term_windows` folder
    and the params key of its settings (`settings_key`)."""

    dataset: str = ""
    table_file: str = ""
    settings_key: str = ""
    same_start_collisions: bool = False  # scoring: collisions only between windows starting together
    summary_file: str = ""  # its file in stage `short_term_tables`' folder (the report reads it)
    table_k: int | None = None  # the one K its summary holds; None: every K scored, by K
    sizes_source: str | None = None  # raw source (`--<source>`) of its scene sizes; None: windows
    images_source: str | None = None  # raw source (`--<source>`) of its scene images

    def raw_sources(self, images: bool) -> tuple[str, ...]:
        """The fetched raw sources Y-net's stages must be given on it (each as `--<source>`): its
        scene sizes' and, with `images` (scoring draws its qualitative windows), its images'."""
        wanted = (self.sizes_source, self.images_source if images else None)
        return tuple(dict.fromkeys(source for source in wanted if source is not None))

    def table(self, windows: Path) -> Path:
        """Its window table in the `short_term_windows` folder `windows`."""
        return Path(windows) / self.table_file

    def prediction_benchmark(self) -> str:
        """The benchmark a predictions file of this table names: `short_term_<table stem>`."""
        return f"short_term_{Path(self.table_file).stem}"

    def prediction_metadata(self, windows: Path, model: str, ks: list[int] | None = None,
                            **extra) -> dict[str, Any]:
        """What a stored short-term predictions file records besides its seeds: the model, the
        benchmark of the window table scored (window ids belong to their table), the unit and the
        table's columns the predictions compare with, the split and, where scored, K (the first
        of `ks`, the K stored) and every K scored."""
        table = self.table(windows)
        metadata = {"model": model, "benchmark": self.prediction_benchmark(), "unit": self.unit,
                    "truth_columns": list(self.truth_columns), "split": self.split,
                    "window_table": str(table)}
        if ks is not None:
            metadata.update(k=ks[0], ks_scored=list(ks))
        return {**metadata, **extra}

    # -- settings ------------------------------------------------------------------------------

    def ks(self, params: ShortTermModelsParams) -> list[int]:
        """The K values it is scored at (`k_<key>`; the first is the one stored)."""
        return getattr(params, f"k_{self.settings_key}")

    def rel_threshold(self, params: ShortTermModelsParams) -> float:
        """Y-net's TTST threshold on it (`rel_threshold.<key>`)."""
        return params.rel_threshold[self.settings_key]

    def epochs(self, params: ShortTermModelsParams, model: str) -> int:
        """A model's training epochs on it (`epochs.<model>.<key>`)."""
        return params.epochs[model][self.settings_key]

    def ynet_scale(self, params: ShortTermModelsParams) -> YnetScale:
        """Y-net's map scale, kernel and sigma on it (`ynet_<key>`)."""
        return getattr(params, f"ynet_{self.settings_key}")

    def ynet_settings(self, base: YnetSettings, params: ShortTermModelsParams, n_future: int,
                      semantic_classes: int) -> YnetSettings:
        """`ynet.<profile>` (`base`) with the short-term goal-only waypoint, this benchmark's scale
        and epochs, and its training departures (`ynet_training.<key>`). Built as `type(base)`: the
        caller, which read `base`, holds the section's class."""
        return type(base)(**{
            **asdict(base), **asdict(self.ynet_scale(params)),
            **params.ynet_training.of(self.settings_key).overrides(),
            "waypoints": [n_future - 1], "epochs": self.epochs(params, YNET),
            "semantic_classes": semantic_classes, "steps_per_epoch": params.ynet_steps_per_epoch})

    # -- windows -------------------------------------------------------------------------------

    def read_table(self, windows: Path) -> pd.DataFrame:
        return pd.read_parquet(self.table(windows))

    def load(self, windows: Path, n_past: int, n_future: int) -> ShortTermSplits:
        """Its windows from the `short_term_windows` folder, in original pixels, the test truth in
        its unit (as they are: a benchmark in pixels)."""
        return self.splits_in_unit(self.read_table(windows), n_past, n_future)

    def load_in_unit(self, windows: Path, n_past: int, n_future: int) -> ShortTermSplits:
        """Its windows with every split in its unit (what the baselines train and predict in); a
        table it cannot use is named (`IntermediateError`)."""
        path = self.table(windows)
        try:
            return self.splits_in_unit(pd.read_parquet(path), n_past, n_future)
        except ValueError as error:
            raise IntermediateError(f"{path}: {error}") from None

    def splits_in_unit(self, table: pd.DataFrame, n_past: int, n_future: int) -> ShortTermSplits:
        """Every split of `table` in its unit: the table's x, y (a benchmark in pixels)."""
        train, val, test = splits_of(table, self.dataset, n_past, n_future)
        return ShortTermSplits(train, val, test, test.future, self.unit, lambda points: points)

    def scene_sizes(self, windows: Path, sdd: Path | None, scene_ids: set[str]
                    ) -> dict[str, tuple[int, int]]:
        """The original (height, width) of the scenes its windows lie in."""
        raise NotImplementedError

    def scene_images(self, windows: Path, sdd: Path | None, cameras: Path | None
                     ) -> Callable[[str], np.ndarray]:
        """scene_id -> its original-size BGR image, on the grid of the windows' original pixels."""
        raise NotImplementedError

    def scored_table(self, sources: ScoringSources) -> ScoredTable:
        """Its test windows as scoring their stored predictions sees them."""
        raise NotImplementedError


def read_rows(path: Path, what: str) -> np.ndarray:
    """(R, 4) float64 rows of a whitespace-separated text file of `what` (four numbers a line).

    A line that is not four finite numbers, or a first or second column (frame, agent id) that is
    not a whole number, is a ShortTermInputError naming the file and line.
    """
    lines = Path(path).read_text().splitlines()
    rows = []
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        fields = line.split()
        try:
            values = [float(v) for v in fields]
        except ValueError:
            values = []
        if len(values) != 4 or not np.isfinite(values).all() or values[0] % 1 or values[1] % 1:
            raise ShortTermInputError(f"{path}:{number}: expected '{what}' (4 numbers, whole frame "
                                      f"and id), got {line!r}")
        rows.append(values)
    if not rows:
        raise ShortTermInputError(f"{path}: no rows")
    return np.asarray(rows, dtype=np.float64)


def number_windows(windows: pd.DataFrame, n_future: int, source: str) -> pd.DataFrame:
    """Window ids in (scene, track, first frame) order; schema columns (`conform`), then x_m, y_m.

    `windows`: one row per (window, step) with the schema's columns except window_id, t_f and
    source, plus `window_key` (unique per window) and the metre columns.
    """
    firsts = (windows.loc[windows["step"] == 0, ["window_key", "scene_id", "track_id", "frame"]]
              .sort_values(["scene_id", "track_id", "frame", "window_key"], kind="stable"))
    ids = pd.Series(np.arange(len(firsts), dtype=np.int64), index=firsts["window_key"].to_numpy())
    windows = windows.assign(window_id=windows["window_key"].map(ids), t_f=n_future, source=source)
    windows = windows.sort_values(["window_id", "step"], kind="stable").reset_index(drop=True)
    table = conform(windows)  # same (window_id, step) order: that pair is unique
    return table.assign(**{c: windows[c].to_numpy(np.float64) for c in METRE_COLUMNS})

