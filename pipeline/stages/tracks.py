"""Stage `tracks`: every SDD `annotations.txt` present, parsed into one parquet table.

One row per annotation (none dropped unless `compat.drop_first_row` asks for the authors' quirk),
positions as box centres in original pixels (`pipeline.data.tracks`). A malformed line stops the
stage with the file and line number. Params: `compat.drop_first_row`.

    python -m pipeline.stages.tracks --sdd data/raw/sdd --out data/tracks/sdd.parquet
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pipeline.config import CompatParams, load_section, read_params
from pipeline.data.tracks import AnnotationError, build_tracks
from pipeline.io import write_parquet


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root (data/raw/sdd)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    compat = load_section(CompatParams, "compat", read_params())
    try:
        tracks = build_tracks(args.sdd, compat.drop_first_row)
    except AnnotationError as e:
        sys.exit(f"tracks: {e}")
    write_parquet(tracks, args.out)
    print(f"tracks: {len(tracks):,} annotations from {tracks['scene_id'].nunique()} videos -> {args.out}")


if __name__ == "__main__":
    main()
