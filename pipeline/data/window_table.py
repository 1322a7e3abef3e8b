"""The one table format every trajectory window is stored in, and its conversion to arrays.

A window table is long-format parquet, one row per (window, step), sorted by window_id, step:

| column     | type    | meaning                                                         |
|------------|---------|-----------------------------------------------------------------|
| window_id  | int64   | unique within the table                                         |
| scene_id   | string  | `<scene>_<video>`, e.g. `gates_2`                               |
| track_id   | int64   | the raw annotation's track id                                   |
| step       | int64   | 0 .. n_p + n_f - 1 (1 FPS steps)                                |
| frame      | int64   | the raw 30 FPS frame number                                     |
| x, y       | float64 | box centre in original image pixels                             |
| split      | string  | train / val / test                                              |
| t_f        | int64   | prediction horizon in seconds (= n_f at 1 FPS)                  |
| source     | string  | raw (cut here from annotations) / release (authors' windows) /  |
|            |         | release_chain (cut from chained release windows)                |
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

COLUMNS = {
    "window_id": "int64",
    "scene_id": "string",
    "track_id": "int64",
    "step": "int64",
    "frame": "int64",
    "x": "float64",
    "y": "float64",
    "split": "string",
    "t_f": "int64",
    "source": "string",
}
SPLITS = ("train", "val", "test")
SOURCES = ("raw", "release", "release_chain")


def conform(table: pd.DataFrame) -> pd.DataFrame:
    """Columns in schema order and dtypes, rows sorted by window and step."""
    missing = sorted(set(COLUMNS) - set(table.columns))
    if missing:
        raise ValueError(f"window table lacks column(s) {missing}")
    table = table[list(COLUMNS)].astype(COLUMNS)
    return table.sort_values(["window_id", "step"], kind="stable").reset_index(drop=True)


@dataclass(frozen=True)
class WindowArrays:
    """The windows of one table as arrays; N windows of n_p observed + n_f future steps."""

    past: np.ndarray  # (N, n_p, 2) float64, original pixels
    future: np.ndarray  # (N, n_f, 2) float64, original pixels
    window_id: np.ndarray  # (N,)
    scene_id: np.ndarray  # (N,) str
    track_id: np.ndarray  # (N,)
    first_frame: np.ndarray  # (N,) frame of step 0: windows of one scene with equal first_frame co-occur
    split: np.ndarray  # (N,) str

    def __len__(self) -> int:
        return len(self.window_id)


def to_arrays(table: pd.DataFrame, n_past: int) -> WindowArrays:
    """Split a window table (all windows the same length) into past and future arrays."""
    table = table.sort_values(["window_id", "step"], kind="stable")
    lengths = table.groupby("window_id", sort=True).size()
    if lengths.nunique() > 1:
        raise ValueError(f"windows of several lengths in one table: {sorted(lengths.unique())}")
    n_windows = len(lengths)
    length = int(lengths.iloc[0]) if n_windows else n_past + 1
    if length <= n_past:
        raise ValueError(f"windows of {length} steps cannot hold {n_past} observed steps")
    xy = table[["x", "y"]].to_numpy(np.float64).reshape(n_windows, length, 2)
    first = table.groupby("window_id", sort=True).first()
    return WindowArrays(
        past=xy[:, :n_past],
        future=xy[:, n_past:],
        window_id=first.index.to_numpy(),
        scene_id=first["scene_id"].to_numpy(str),
        track_id=first["track_id"].to_numpy(),
        first_frame=first["frame"].to_numpy(),
        split=first["split"].to_numpy(str),
    )


def subset(arrays: WindowArrays, index: np.ndarray) -> WindowArrays:
    """The windows `index` of `arrays`."""
    return WindowArrays(**{f.name: getattr(arrays, f.name)[index]
                           for f in dataclasses.fields(WindowArrays)})


def select_split(arrays: WindowArrays, name: str) -> WindowArrays:
    """The windows of split `name` (train / val / test)."""
    return subset(arrays, np.flatnonzero(arrays.split == name))


def load_windows(table_path: Path, n_past: int, horizon: int) -> WindowArrays:
    """The windows of the horizon table at `table_path` as arrays (every split); fails unless
    they are n_past + horizon steps (1 FPS)."""
    table = pd.read_parquet(table_path)
    horizons = sorted(table["t_f"].unique().tolist())
    if horizons != [horizon]:
        raise ValueError(f"{table_path}: windows of horizon(s) {horizons}, expected {horizon}")
    arrays = to_arrays(table, n_past)
    if arrays.future.shape[1] != horizon:
        raise ValueError(f"{table_path}: {arrays.future.shape[1]} future steps for t_f = {horizon} s")
    return arrays
