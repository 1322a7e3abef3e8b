"""What every benchmark is (`Benchmark`, the base of one module per benchmark, listed in
`pipeline.benchmarks.registry`) and what scoring stored predictions needs from one: a window table
with its truth (`WindowTruth`), the scenes' class masks (`SceneMasks`) and metres per unit
(`ScoredTable`, which `pipeline.harness.stored_scores` scores). Nothing here scores or runs a model.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.data.window_table import conform
from pipeline.io import IntermediateError
from ynet.classes import CLASS_NAMES


@dataclass(frozen=True)
class Benchmark:
    """One benchmark: its name in the registry, how people call it, the unit its errors are in
    and the table columns its truth comes from. A benchmark module subclasses it with its own
    loading (window tables, scales, masks) and the settings it overrides. Where the paper and the
    studies name it, it says so here, so that the report asks it instead of testing names."""

    name: str  # registry key
    title: str  # for people: the report, logs, errors
    unit: str  # px (original image pixels) | m
    truth_columns: tuple[str, str] = ("x", "y")  # the window-table columns its errors compare with
    split: str | None = "test"  # the windows its predictions files hold (None: every window)
    label: str = ""  # its short name in the report's tables (SDD, Hotel, inD)
    paper_table: str = ""  # its table in paper_values.yaml (sdd_short, eth_ucy, sdd_long); "": none
    paper_key: str = ""  # its key in that table: Tables 3-4's column `dataset`, Table 2's scene
    in_paper: str = ""  # where the paper reports it, for people ("Table 2, ETH fold")
    study_key: str = ""  # its name in the studies' records (studies/budget/<key>_<model>_x<f>.json)


# ---------------------------------------------------------------------------------------------
# Scene classes

FORBIDDEN_CLASSES = ("structure", "tree")  # where a pedestrian cannot stand (ynet CLASS_NAMES)


def class_values(names: Sequence[str] = FORBIDDEN_CLASSES) -> tuple[int, ...]:
    """The mask values of class `names` (indices in `ynet.classes.CLASS_NAMES`)."""
    unknown = [name for name in names if name not in CLASS_NAMES]
    if unknown:
        raise ValueError(f"unknown class(es) {unknown}; classes are {list(CLASS_NAMES)}")
    return tuple(CLASS_NAMES.index(name) for name in names)


# ---------------------------------------------------------------------------------------------
# Window truth


@dataclass(frozen=True)
class WindowTruth:
    """The future of every window of a window table, windows in ascending window_id order."""

    path: Path  # the window table read
    window_ids: np.ndarray  # (N,) int64, ascending
    future: np.ndarray  # (N, T, 2) float64, in the benchmark's unit (the truth columns)
    frames: np.ndarray  # (N, T) int64, raw frame of each future step
    first_frame: np.ndarray  # (N,) int64, raw frame of the first observed step
    scenes: np.ndarray  # (N,) str, the table's scene_id ('<scene>_<video>' for SDD)
    tracks: np.ndarray  # (N,) int64, the raw track ids (one agent per scene and track)
    t_f: int  # the table's t_f (seconds; the short-term tables hold n_f, the future steps)

    def take(self, window_ids: np.ndarray, source: Path) -> WindowTruth:
        """The windows `window_ids` (N',), in that order; an IntermediateError naming `source` (the
        predictions file asking) for ids the table does not hold."""
        at = np.searchsorted(self.window_ids, window_ids)  # (N',)
        found = at < len(self.window_ids)
        found[found] = self.window_ids[at[found]] == window_ids[found]
        if not found.all():
            missing = window_ids[~found]
            raise IntermediateError(f"{source}: {len(missing)} of {len(window_ids)} window id(s) "
                                    f"are not in {self.path}, e.g. {missing[:5].tolist()}")
        return WindowTruth(self.path, self.window_ids[at], self.future[at], self.frames[at],
                           self.first_frame[at], self.scenes[at], self.tracks[at], self.t_f)


def read_window_truth(path: Path, n_past: int, columns: Sequence[str] = ("x", "y"),
                      split: str | None = None) -> WindowTruth:
    """The future steps (those after the first `n_past`) of every window of the window table at
    `path` (`pipeline.data.window_table`), positions from `columns` (e.g. ETH/UCY's metres `x_m`,
    `y_m`), only the windows of `split` where given (ids of other splits are then "not in" the
    table); an IntermediateError naming the table if it lacks a column, its windows differ in
    length, hold no future step or several horizons, or none is of `split`."""
    path = Path(path)
    try:
        raw = pd.read_parquet(path)
        missing = [c for c in columns if c not in raw.columns]
        if missing:
            raise ValueError(f"no truth column(s) {missing}")
        x, y = columns
        table = conform(raw.assign(x=raw[x], y=raw[y]))
    except (OSError, ValueError) as e:
        raise IntermediateError(f"{path}: not a window table: {e}") from e
    if split is not None:
        table = table.loc[table["split"] == split].reset_index(drop=True)
    sizes = table.groupby("window_id", sort=True).size()  # (N,)
    if len(sizes) == 0:
        raise IntermediateError(f"{path}: no windows" + (f" of split {split!r}" if split else ""))
    if sizes.nunique() > 1 or int(sizes.iloc[0]) <= n_past:
        raise IntermediateError(f"{path}: windows must all hold {n_past} observed steps and at "
                                f"least one future step, lengths {sorted(sizes.unique().tolist())}")
    horizons = table["t_f"].unique()
    if len(horizons) != 1:
        raise IntermediateError(f"{path}: one t_f per window table, found "
                                f"{sorted(horizons.tolist())}")
    n, length = len(sizes), int(sizes.iloc[0])
    xy = table[["x", "y"]].to_numpy(np.float64).reshape(n, length, 2)  # (N, L, 2)
    frames = table["frame"].to_numpy(np.int64).reshape(n, length)  # (N, L)
    first = table.iloc[::length]  # rows are sorted by window, step: each window's first step
    return WindowTruth(path, sizes.index.to_numpy(np.int64), xy[:, n_past:], frames[:, n_past:],
                       frames[:, 0], first["scene_id"].to_numpy(str),
                       first["track_id"].to_numpy(np.int64), int(horizons[0]))


# ---------------------------------------------------------------------------------------------
# Masks and scored tables


@dataclass
class SceneMasks:
    """A benchmark's class masks, one per scene that has one, and how a position in the benchmark's
    unit lands on them: through `to_pixels` (unit -> original image pixels of the scene; none for
    a benchmark in pixels), then at `scale` mask pixels per original pixel
    (`pipeline.harness.scoring.mask_pixels`; `pipeline.harness.stored_scores.forbidden_shares`
    scores positions on them). A mask is read on first use."""

    source: str  # where the masks come from, for the record
    forbidden: tuple[int, ...]  # class values a pedestrian cannot stand on
    forbidden_names: tuple[str, ...]  # their names, for the record
    names: frozenset[str]  # the scenes that have a mask
    read: Callable[[str], np.ndarray]  # scene -> (H, W) class values
    scale: float = 1.0
    to_pixels: Callable[[np.ndarray, str], np.ndarray] | None = None
    masks: dict[str, np.ndarray] = field(default_factory=dict)  # read so far

    def mask(self, name: str) -> np.ndarray:
        if name not in self.masks:
            self.masks[name] = self.read(name)
        return self.masks[name]

    def coverage(self, scenes: np.ndarray) -> dict[str, Any]:
        """Which of the windows (their `scenes` (N,)) had a mask, for the record."""
        held = sorted(set(np.unique(scenes).tolist()))
        with_mask = [s for s in held if s in self.names]
        return {"source": self.source, "forbidden_classes": list(self.forbidden_names),
                "scenes_with_mask": with_mask,
                "scenes_without_mask": [s for s in held if s not in self.names],
                "windows_with_mask": int(np.isin(scenes, with_mask).sum()),
                "n_windows": int(len(scenes))}


@dataclass
class ScoredTable:
    """How the predictions files of one window table of a benchmark are scored (its `Benchmark`
    makes it): what their metadata must say (`name`, `unit`, `truth_columns`, `split`), where the
    truth is (`table`, `n_past`), metres per unit per scene (`metres_per_unit`; None: the unit is metres) and the scenes' masks (`masks`,
    or why there are none: `masks_absent`). The table is read on first use (`truth`): a benchmark
    whose files all say why nothing was predicted (inD not provided) never reads it."""

    name: str  # the metadata `benchmark` its files give
    table: Path
    unit: str  # px | m
    n_past: int
    truth_columns: tuple[str, str] = ("x", "y")
    split: str | None = None  # the windows its files may predict (None: every window)
    metres_per_unit: Mapping[str, float] | None = None
    scales_source: str = "the unit is metres"  # for the record
    masks: SceneMasks | None = None
    masks_absent: str | None = None
    same_start_collisions: bool = False  # collisions only between windows starting together
    read_truth: WindowTruth | None = None  # cached

    def truth(self) -> WindowTruth:
        if self.read_truth is None:
            self.read_truth = read_window_truth(self.table, self.n_past, self.truth_columns,
                                                self.split)
        return self.read_truth

    def to_metres(self, scenes: np.ndarray, source: Path) -> np.ndarray:
        """(N,) metres per unit of each window's scene; an IntermediateError naming `source` (the
        predictions file) for a scene without a scale."""
        if self.metres_per_unit is None:
            return np.ones(len(scenes))
        missing = sorted(set(scenes.tolist()) - set(self.metres_per_unit))
        if missing:
            raise IntermediateError(f"{source}: no metres per {self.unit} for scene(s) "
                                    f"{missing[:5]} ({self.scales_source})")
        return np.array([self.metres_per_unit[s] for s in scenes.tolist()], dtype=np.float64)

    def describe(self) -> dict[str, Any]:
        """What the record says about the benchmark (and, once read, its windows)."""
        out = {"benchmark": self.name, "window_table": Path(self.table).as_posix(),
               "unit": self.unit, "truth_columns": list(self.truth_columns), "split": self.split,
               "metres_per_unit": self.scales_source,
               "collision_partners": ("windows of another track starting at the same frame"
                                      if self.same_start_collisions else
                                      "windows of another track sharing a raw frame")}
        if self.read_truth is not None:
            truth = self.read_truth
            out.update(n_windows=len(truth.window_ids), n_future=int(truth.future.shape[1]),
                       t_f=truth.t_f)
            out["scene_masks"] = (self.masks.coverage(truth.scenes) if self.masks is not None
                                  else {"absent": self.masks_absent})
        return out

