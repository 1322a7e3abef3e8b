"""Stage `audit`: our raw-cut t_f = 30 windows against the authors' released windows, per video.

For every video with raw annotations: windows ours / release / exact matches. Each mismatch is
re-checked against windows cut with the other `compat.drop_first_row` setting (the authors'
`read_csv(header=0)` quirk, the only known cause; `pipeline.data.audit`), from the very files stage
`tracks` parsed (the mirror's and your SDD copy's, `pipeline.data.sdd_sources`); an unexplained
mismatch fails the stage, which then writes nothing. Params: `compat.drop_first_row`, `data.sdd`,
`windows`, `split`.

    python -m pipeline.stages.audit --sdd data/raw/sdd --manifest manifests/sdd.sha256 \
        --windows data/windows --out metrics/data_audit.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from pipeline.config.compat import CompatParams
from pipeline.config.data import DataParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.split import SplitParams
from pipeline.config.windows import WindowParams
from pipeline.data.audit import audit
from pipeline.data.checksums import ChecksumError, read_manifest
from pipeline.data.sdd_sources import SourceError, annotation_files, choose_videos, copy_root
from pipeline.data.tracks import AnnotationError, tracks_from_files
from pipeline.data.windows import cut_pieces, cut_windows
from pipeline.io import write_json


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root")
    parser.add_argument("--manifest", type=Path, required=True, help="its manifest")
    parser.add_argument("--windows", type=Path, required=True, help="folder of window tables")
    parser.add_argument("--out", type=Path, required=True, help="metrics JSON")
    args = parser.parse_args(argv)
    params = read_params()
    windows = load_section(WindowParams, "windows", params)
    compat = load_section(CompatParams, "compat", params)
    sdd = load_section(DataParams, "data", params).sdd
    val_videos = set(load_section(SplitParams, "split", params).val_videos)
    t_f = windows.release_horizon

    raw = pd.read_parquet(args.windows / f"raw_tf{t_f}.parquet")
    release = pd.read_parquet(args.windows / f"release_tf{t_f}.parquet")
    try:
        sources = choose_videos(args.sdd, read_manifest(args.manifest), copy_root(sdd))
        other_tracks = tracks_from_files(annotation_files(sources),
                                         drop_first_row=not compat.drop_first_row)
    except (AnnotationError, ChecksumError, SourceError) as e:
        sys.exit(f"audit: {e}")
    other = cut_windows(cut_pieces(other_tracks, windows.label, windows.stride),
                        windows.window_length(t_f))
    videos = sorted(other_tracks["scene_id"].unique())
    per_video, unexplained = audit(raw, release, other, not compat.drop_first_row, videos, val_videos)

    totals = {key: sum(v[key] for v in per_video.values())
              for key in ("ours", "release", "exact_matches")}
    totals.update(videos_with_raw=len(videos), videos_audited=len(per_video),
                  videos_with_windows=sum(v["ours"] + v["release"] > 0 for v in per_video.values()),
                  unexplained_mismatches=len(unexplained))
    print(f"audit: {totals}")
    if unexplained:  # before writing: a failed stage leaves no output behind
        sys.exit("audit: unexplained mismatches between our windows and the release:\n  "
                 + "\n  ".join(unexplained))
    write_json({"t_f": t_f, "compat_drop_first_row": compat.drop_first_row,
                "totals": totals, "videos": per_video}, args.out, sort_keys=True)


if __name__ == "__main__":
    main()
