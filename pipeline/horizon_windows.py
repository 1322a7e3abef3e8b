"""Stage `horizon_windows`: windows for every horizon on all 60 SDD videos.

Raw 30 FPS annotations exist for 23 videos only. For the others, the authors' released 35-step
windows were cut without overlap from contiguous 1 FPS pieces, so consecutive windows of a track
(next first frame = previous last frame + 30) chain back into those pieces, and any horizon can be
cut from them. Each window records its source: `raw` where the video has raw annotations,
`release_chain` otherwise. Chains lose each piece's tail (< 35 steps) and pieces shorter than 35
steps entirely, so short horizons from chains lean toward long tracks (the `chain_bias` stage
measures by how much).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.params import load_section, read_params
from pipeline.splits import SplitParams
from pipeline.window_table import conform
from pipeline.windows import (WindowParams, count_windows, cut_windows, finish_table,
                              write_json_atomic)


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


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracks", type=Path, required=True)
    parser.add_argument("--windows", type=Path, required=True, help="folder of the windows stage")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--stats", type=Path, required=True)
    args = parser.parse_args(argv)
    all_params = read_params()
    params = load_section(WindowParams, "windows", all_params)
    val_videos = set(load_section(SplitParams, "split", all_params).val_videos)

    raw_videos = set(pd.read_parquet(args.tracks, columns=["scene_id"])["scene_id"].unique())
    release = pd.read_parquet(args.windows / f"release_tf{params.release_horizon}.parquet")
    try:
        chain = chain_pieces(release, params.window_length(params.release_horizon), params.stride)
    except ChainError as e:
        sys.exit(f"horizon_windows: {args.windows}/release_tf{params.release_horizon}.parquet: {e}")

    staging = args.out.with_name(f".{args.out.name}.tmp")
    staging.mkdir(parents=True, exist_ok=True)
    stats = {"chain_pieces": int(chain["piece"].nunique())}
    for t_f in params.horizons:
        raw = pd.read_parquet(args.windows / f"raw_tf{t_f}.parquet")
        table = horizon_table(raw, chain, raw_videos, t_f, params, val_videos)
        table.to_parquet(staging / f"tf{t_f}.parquet", index=False)
        stats[f"tf{t_f}"] = count_windows(table, ["split", "source"])
    if args.out.exists():
        shutil.rmtree(args.out)
    os.replace(staging, args.out)
    write_json_atomic(stats, args.stats)
    print("horizon_windows:", stats)


if __name__ == "__main__":
    main()
