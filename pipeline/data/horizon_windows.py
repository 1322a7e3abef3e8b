"""Windows for every horizon on all 60 SDD videos, from raw tracks or chained release windows
(stage `horizon_windows`).

Raw 30 FPS annotations exist for 23 videos only. For the others, the authors' released 35-step
windows were cut without overlap from contiguous 1 FPS pieces, so consecutive windows of a track
(next first frame = previous last frame + 30) chain back into those pieces, and any horizon can be
cut from them. Each window records its source: `raw` where the video has raw annotations,
`release_chain` otherwise. Chains lose each piece's tail (< 35 steps) and pieces shorter than 35
steps entirely, so short horizons from chains lean toward long tracks (the `chain_bias` stage
measures by how much).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from pipeline.data.window_table import conform
from pipeline.data.windows import cut_windows, finish_table

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.windows import WindowParams


class ChainError(ValueError):
    """Release windows that cannot be chained: wrong length, a break inside, a duplicate frame."""


def chain_pieces(windows: pd.DataFrame, length: int, stride: int) -> pd.DataFrame:
    """Chain windows of equal length into contiguous pieces.

    `windows` is a window table. Returns rows like `windows.cut_pieces`: (scene_id, track_id,
    frame, x, y, piece, sub, piece_len), where consecutive windows of one track whose frames
    continue at `stride` share a piece.
    """
    sizes = windows.groupby("window_id").size()
    if (sizes != length).any():
        bad = sizes[sizes != length]
        raise ChainError(f"{len(bad)} window(s) not {length} steps, e.g. window {bad.index[0]} "
                         f"has {bad.iloc[0]}")
    ordered = windows.sort_values(["window_id", "step"], kind="stable")
    inner_steps = ordered.groupby("window_id")["frame"].diff().dropna()
    if not inner_steps.eq(stride).all():
        window = ordered.loc[inner_steps.index[~inner_steps.eq(stride)][0], "window_id"]
        raise ChainError(f"window {window}: chain break inside the window "
                         f"(frames do not step by {stride})")
    duplicated = windows.duplicated(["scene_id", "track_id", "frame"], keep=False)
    if duplicated.any():
        row = windows.loc[duplicated].iloc[0]
        raise ChainError(f"{row.scene_id} track {row.track_id}: frame {row.frame} appears in "
                         "more than one window")
    rows = (windows[["scene_id", "track_id", "frame", "x", "y"]]
            .sort_values(["scene_id", "track_id", "frame"], kind="stable").reset_index(drop=True))
    same_track = (rows["scene_id"].eq(rows["scene_id"].shift())
                  & rows["track_id"].eq(rows["track_id"].shift()))
    continues = same_track & rows["frame"].diff().eq(stride)
    rows["piece"] = np.cumsum(~continues.to_numpy())
    rows["sub"] = rows.groupby("piece", sort=False).cumcount()
    rows["piece_len"] = rows.groupby("piece", sort=False)["sub"].transform("size")
    return rows


def combine(raw: pd.DataFrame, chained: pd.DataFrame) -> pd.DataFrame:
    """One window table of raw and chained windows, ids renumbered (raw first)."""
    offset = int(raw["window_id"].max()) + 1 if len(raw) else 0
    return conform(pd.concat([raw, chained.assign(window_id=chained["window_id"] + offset)],
                             ignore_index=True))


def horizon_table(raw: pd.DataFrame, chain: pd.DataFrame, raw_videos: set[str], t_f: int,
                  params: WindowParams, val_videos: set[str]) -> pd.DataFrame:
    """Raw windows of horizon t_f plus chained-release windows on the videos without raw data."""
    without_raw = chain.loc[~chain["scene_id"].isin(raw_videos)]
    chained, n_outside = finish_table(cut_windows(without_raw, params.window_length(t_f)), t_f,
                                      "release_chain", val_videos)
    assert n_outside == 0, "release windows are all inside the TrajNet split"
    return combine(raw, chained)
