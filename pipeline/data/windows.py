"""The paper's long-term windows, cut from the raw tracks and imported from the release (stage `windows`).

Recipe (paper, "Long term setting"; upstream fact 6): keep pedestrians with `lost == 0`, split a
track wherever the 30 FPS frame step is not 1, keep every 30th frame of each piece (1 FPS), drop
pieces shorter than a window, cut non-overlapping windows of n_p + n_f steps from each piece's
start. One table per horizon t_f; plus the authors' released t_f = 30 windows (the main benchmark)
in the same schema. Everything is vectorised: the 790k raw annotations take about a second.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from pipeline.data.checksums import load_verified_pickle
from pipeline.data.window_table import conform
from pipeline.splits import split_of

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.windows import WindowParams

RELEASE_FILES = {"train": "data/SDD/train_longterm.pkl", "test": "data/SDD/test_longterm.pkl"}
RELEASE_COLUMNS = ["trackId", "frame", "x", "y", "sceneId", "metaId"]


class ReleaseError(ValueError):
    """The authors' release windows are not what they should be."""


def cut_pieces(tracks: pd.DataFrame, label: str, stride: int) -> pd.DataFrame:
    """Contiguous pieces of each kept track, downsampled.

    Returns rows (scene_id, track_id, frame, x, y, piece, sub, piece_len): `piece` numbers the
    contiguous runs (frame step 1 at raw_fps), `sub` is the downsampled step within the piece and
    `piece_len` the number of downsampled steps of the piece.
    """
    kept = tracks.loc[(tracks["label"] == label) & (tracks["lost"] == 0),
                      ["scene_id", "track_id", "frame", "x", "y"]]
    kept = kept.sort_values(["scene_id", "track_id", "frame"], kind="stable").reset_index(drop=True)
    same_track = (kept["scene_id"].eq(kept["scene_id"].shift())
                  & kept["track_id"].eq(kept["track_id"].shift()))
    contiguous = same_track & kept["frame"].diff().eq(1)
    kept["piece"] = np.cumsum(~contiguous.to_numpy())
    position = kept.groupby("piece", sort=False).cumcount().to_numpy()
    pieces = kept.loc[position % stride == 0].copy()
    pieces["sub"] = pieces.groupby("piece", sort=False).cumcount()
    pieces["piece_len"] = pieces.groupby("piece", sort=False)["sub"].transform("size")
    return pieces.reset_index(drop=True)


def cut_windows(pieces: pd.DataFrame, length: int) -> pd.DataFrame:
    """Non-overlapping windows of `length` steps from each piece's start; a shorter tail is dropped.

    Returns rows (scene_id, track_id, frame, x, y, window_key, step), window_key unique per window.
    """
    index_in_piece = pieces["sub"].to_numpy() // length
    full = index_in_piece < pieces["piece_len"].to_numpy() // length
    windows = pieces.loc[full, ["scene_id", "track_id", "frame", "x", "y"]].copy()
    windows["window_key"] = pieces.loc[full, "piece"].to_numpy() * 1_000_000 + index_in_piece[full]
    windows["step"] = pieces.loc[full, "sub"].to_numpy() % length
    return windows


def finish_table(windows: pd.DataFrame, t_f: int, source: str,
                 val_videos: set[str]) -> tuple[pd.DataFrame, int]:
    """Assign splits and stable window ids (ordered by scene, track, first frame).

    Returns the window table and the number of windows dropped as outside the TrajNet split.
    """
    split_by_scene = {s: split_of(s, val_videos) for s in windows["scene_id"].unique()}
    windows = windows.assign(split=windows["scene_id"].map(split_by_scene))
    outside = windows["split"].isna()
    n_outside = windows.loc[outside, "window_key"].nunique()
    windows = windows.loc[~outside]
    firsts = (windows.loc[windows["step"] == 0, ["window_key", "scene_id", "track_id", "frame"]]
              .sort_values(["scene_id", "track_id", "frame"], kind="stable"))
    ids = pd.Series(np.arange(len(firsts), dtype=np.int64), index=firsts["window_key"].to_numpy())
    windows = windows.assign(window_id=windows["window_key"].map(ids), t_f=t_f, source=source)
    return conform(windows), int(n_outside)


def raw_windows(tracks: pd.DataFrame, params: WindowParams,
                val_videos: set[str]) -> dict[int, tuple[pd.DataFrame, int]]:
    """t_f -> (window table, windows outside the split) for every horizon."""
    pieces = cut_pieces(tracks, params.label, params.stride)
    return {
        t_f: finish_table(cut_windows(pieces, params.window_length(t_f)), t_f, "raw", val_videos)
        for t_f in params.horizons
    }


def reject_rows(table: pd.DataFrame, bad: np.ndarray, name: str, what: str) -> None:
    """A ReleaseError naming the windows (metaId) and the first row where `bad` holds: one NaN
    position or negative frame would pass every shape check and poison a whole window's scores."""
    if bad.any():
        raise ReleaseError(f"{name}: {int(bad.sum())} row(s) with {what}, in metaId(s) "
                           f"{sorted(table.loc[bad, 'metaId'].unique().tolist())[:5]}, e.g. row "
                           f"{table.index[bad][0]}")


def validate_release(table: pd.DataFrame, name: str, length: int, stride: int) -> None:
    """The authors' pickle as the recipe reads it: its columns, numeric values that are finite
    positions and frames >= 0, whole windows of `length` steps `stride` frames apart, one track and
    scene each."""
    if list(table.columns) != RELEASE_COLUMNS:
        raise ReleaseError(f"{name}: columns {list(table.columns)}, expected {RELEASE_COLUMNS}")
    numeric = [c for c in ("trackId", "frame", "x", "y", "metaId")
               if not pd.api.types.is_numeric_dtype(table[c])]
    if numeric:
        raise ReleaseError(f"{name}: column(s) {numeric} not numeric")
    reject_rows(table, ~np.isfinite(table[["x", "y"]].to_numpy(np.float64)).all(axis=1), name,
                "a non-finite x or y")
    reject_rows(table, ~table["frame"].ge(0).to_numpy(), name, "a negative (or missing) frame")
    sizes = table.groupby("metaId").size()
    wrong = sizes[sizes != length]
    if len(wrong):
        raise ReleaseError(f"{name}: {len(wrong)} window(s) not {length} steps, e.g. metaId "
                           f"{wrong.index[0]} has {wrong.iloc[0]}")
    steps = table.groupby("metaId")["frame"].diff().dropna()
    if not steps.eq(stride).all():
        raise ReleaseError(f"{name}: frames within a window do not all step by {stride}")
    if table.groupby("metaId")[["trackId", "sceneId"]].nunique().gt(1).any(axis=None):
        raise ReleaseError(f"{name}: a window spans several tracks or scenes")


def release_windows(release_root: Path, manifest: dict[str, str], params: WindowParams,
                    val_videos: set[str]) -> pd.DataFrame:
    """The authors' t_f = 30 windows (train and test pickles) in the window-table schema."""
    length = params.window_length(params.release_horizon)
    parts = []
    for release_split, rel in RELEASE_FILES.items():
        table = load_verified_pickle(release_root, rel, manifest)
        validate_release(table, str(release_root / rel), length, params.stride)
        splits = table["sceneId"].map(lambda s: split_of(s, val_videos))
        expected = {"test"} if release_split == "test" else {"train", "val"}
        if not set(splits.unique()) <= expected:
            raise ReleaseError(f"{release_root / rel}: scenes outside its split: "
                               f"{sorted(table.loc[~splits.isin(expected), 'sceneId'].unique())}")
        parts.append(pd.DataFrame({
            "scene_id": table["sceneId"].to_numpy(),
            "track_id": table["trackId"].to_numpy(),
            "frame": table["frame"].to_numpy(),
            "x": table["x"].to_numpy(),
            "y": table["y"].to_numpy(),
            "window_key": table["metaId"].to_numpy() + (10**9 if release_split == "test" else 0),
            "step": table.groupby("metaId").cumcount().to_numpy(),
        }))
    windows, n_outside = finish_table(pd.concat(parts, ignore_index=True),
                                      params.release_horizon, "release", val_videos)
    assert n_outside == 0
    return windows


def count_windows(table: pd.DataFrame, by: list[str]) -> dict:
    """Nested {key: {key: count}} of windows grouped by `by` (first step rows only)."""
    firsts = table.loc[table["step"] == 0]
    counts = firsts.groupby(by, observed=True).size()
    nested: dict = {}
    for key, value in counts.items():
        key = key if isinstance(key, tuple) else (key,)
        node = nested
        for part in key[:-1]:
            node = node.setdefault(str(part), {})
        node[str(key[-1])] = int(value)
    return nested
