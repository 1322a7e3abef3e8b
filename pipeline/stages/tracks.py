"""Stage `tracks`: each SDD video's `annotations.txt` parsed into one table, and where each came from.

The files are the fetched mirror's and, with `data.sdd.path`, your own SDD copy's: a file the
manifest pins must match it, any other is parsed and fingerprinted (`pipeline.data.sdd_sources`).
One row per annotation (none dropped unless `compat.drop_first_row` asks for the authors' quirk),
positions as box centres in original pixels (`pipeline.data.tracks`). A malformed line or a file
that differs from its pin stops the stage, which then writes nothing. `--sources`: each video's
origin, SHA-256 and rows, the copy's reference images, totals. The copy lies outside the
repository: after changing its files run `dvc repro -f tracks`. Params: `compat.drop_first_row`,
`data.sdd`.

    python -m pipeline.stages.tracks --sdd data/raw/sdd --manifest manifests/sdd.sha256 \
        --out data/tracks/sdd.parquet --sources metrics/sdd_sources.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pipeline.config.compat import CompatParams
from pipeline.config.data import DataParams
from pipeline.config.loading import load_section, read_params
from pipeline.data.checksums import ChecksumError, read_manifest
from pipeline.data.sdd_sources import (SourceError, annotation_files, choose_videos, copy_images,
                                       copy_root, sources_record)
from pipeline.data.tracks import AnnotationError, tracks_from_files
from pipeline.io import write_json, write_parquet


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root (data/raw/sdd)")
    parser.add_argument("--manifest", type=Path, required=True, help="its manifest (manifests/sdd.sha256)")
    parser.add_argument("--out", type=Path, required=True, help="tracks parquet")
    parser.add_argument("--sources", type=Path, required=True, help="JSON: where each video came from")
    args = parser.parse_args(argv)
    params = read_params()
    compat = load_section(CompatParams, "compat", params)
    sdd = load_section(DataParams, "data", params).sdd
    try:
        manifest = read_manifest(args.manifest)
        videos = choose_videos(args.sdd, manifest, copy_root(sdd))
        images = copy_images(copy_root(sdd), manifest)
        tracks = tracks_from_files(annotation_files(videos), compat.drop_first_row)
    except (AnnotationError, ChecksumError, SourceError) as e:
        sys.exit(f"tracks: {e}")
    rows = tracks.groupby("scene_id", observed=True).size()
    record = sources_record(sdd, videos, images, {str(k): int(n) for k, n in rows.items()})
    write_parquet(tracks, args.out)
    write_json(record, args.sources, sort_keys=True)
    print(f"tracks: {len(tracks):,} annotations from {tracks['scene_id'].nunique()} videos -> {args.out}")
    print("tracks: videos per origin", json.dumps(record["totals"]["per_origin"]))


if __name__ == "__main__":
    main()
