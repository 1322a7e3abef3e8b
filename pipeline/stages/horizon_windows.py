"""Stage `horizon_windows`: windows for every horizon on all 60 SDD videos.

Raw windows where a video has annotations, else windows cut from the release's t_f = 30 windows
chained back into contiguous pieces (`source` column says which; `pipeline.data.horizon_windows`).
Params: `windows`, `split`.

    python -m pipeline.stages.horizon_windows --tracks data/tracks/sdd.parquet --windows data/windows \
        --out data/horizon_windows --stats metrics/horizon_windows.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from pipeline.config.loading import load_section, read_params
from pipeline.config.split import SplitParams
from pipeline.config.windows import WindowParams
from pipeline.data.horizon_windows import ChainError, chain_pieces, horizon_table
from pipeline.data.windows import count_windows
from pipeline.io import atomic_dir, write_json


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

    stats = {"chain_pieces": int(chain["piece"].nunique())}
    with atomic_dir(args.out) as staging:
        for t_f in params.horizons:
            raw = pd.read_parquet(args.windows / f"raw_tf{t_f}.parquet")
            table = horizon_table(raw, chain, raw_videos, t_f, params, val_videos)
            table.to_parquet(staging / f"tf{t_f}.parquet", index=False)
            stats[f"tf{t_f}"] = count_windows(table, ["split", "source"])
    write_json(stats, args.stats, sort_keys=True)
    print("horizon_windows:", stats)


if __name__ == "__main__":
    main()
