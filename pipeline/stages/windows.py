"""Stage `windows`: the paper's long-term windows, cut from the raw tracks and imported from the release.

One table per horizon of `windows.horizons` (`raw_tf<t_f>.parquet`), plus the authors' released
t_f = 30 windows (`release_tf30.parquet`, pickles unpickled only after their checksum matched), all
in the window-table schema (`pipeline.data.windows`, `pipeline.data.window_table`); window counts
per split and per scene. Params: `windows`, `split`.

    python -m pipeline.stages.windows --tracks data/tracks/sdd.parquet \
        --release data/raw/ynet-release --release-manifest manifests/ynet-release.sha256 \
        --out data/windows --stats metrics/windows.json --scene-stats reports/data/windows_per_scene.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import pandas as pd

from pipeline.config.loading import load_section, read_params
from pipeline.config.split import SplitParams
from pipeline.config.windows import WindowParams
from pipeline.data.checksums import ChecksumError, read_manifest
from pipeline.data.windows import ReleaseError, count_windows, raw_windows, release_windows
from pipeline.io import atomic_dir, write_json


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracks", type=Path, required=True)
    parser.add_argument("--release", type=Path, required=True, help="fetched ynet-release root")
    parser.add_argument("--release-manifest", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True, help="folder of window tables")
    parser.add_argument("--stats", type=Path, required=True, help="metrics JSON (totals)")
    parser.add_argument("--scene-stats", type=Path, required=True, help="JSON of window counts per scene")
    args = parser.parse_args(argv)
    all_params = read_params()
    params = load_section(WindowParams, "windows", all_params)
    val_videos = set(load_section(SplitParams, "split", all_params).val_videos)

    tracks = pd.read_parquet(args.tracks)
    try:
        release = release_windows(args.release, read_manifest(args.release_manifest), params,
                                  val_videos)
    except (ReleaseError, ChecksumError) as e:
        sys.exit(f"windows: {e}")
    raw = raw_windows(tracks, params, val_videos)

    with atomic_dir(args.out) as staging:
        release.to_parquet(staging / f"release_tf{params.release_horizon}.parquet", index=False)
        for t_f, (table, _) in raw.items():
            table.to_parquet(staging / f"raw_tf{t_f}.parquet", index=False)

    stats = {"release": {f"tf{params.release_horizon}": count_windows(release, ["split"])},
             "raw": {f"tf{t_f}": {**count_windows(table, ["split"]), "outside_split": n_out}
                     for t_f, (table, n_out) in raw.items()}}
    scene_stats = {"release": {f"tf{params.release_horizon}": count_windows(release, ["split", "scene_id"])},
                   "raw": {f"tf{t_f}": count_windows(table, ["split", "scene_id"])
                           for t_f, (table, _) in raw.items()}}
    write_json(stats, args.stats, sort_keys=True)
    write_json(scene_stats, args.scene_stats, sort_keys=True)
    print("windows:", json.dumps(stats))


if __name__ == "__main__":
    main()
