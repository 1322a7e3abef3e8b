"""Speed of the data stages on the real mirror (parse 23 raw videos, cut windows, import the release).

The authors' long-term preprocessing of the same 23 raw videos into 62 windows took
1.07 / 1.20 / 1.42 s (min / median / max) on this machine.
Run from the repository root: `python -m bench.bench_data [--mirror ../shared/data] [--repeats 5]
[--smoke]`; `--smoke` times each step once (a few seconds on the real mirror).
"""

import statistics
import time
from pathlib import Path

from bench import common
from pipeline.config.windows import WindowParams
from pipeline.data.checksums import read_manifest
from pipeline.data.tracks import build_tracks
from pipeline.data.windows import cut_pieces, cut_windows, raw_windows, release_windows

MIRROR_HOW = ("the data mirror (params.yaml fetch.locations); or `dvc repro fetch` and "
              "--mirror data/raw")


def timed(fn, repeats: int) -> tuple[list[float], object]:
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return times, result


def show(name: str, times: list[float]) -> None:
    print(f"{name:<55} {min(times):6.2f} / {statistics.median(times):6.2f} / {max(times):6.2f} s")


def main() -> None:
    parser = common.parser(__doc__)
    parser.add_argument("--mirror", type=Path, default=Path("../shared/data"))
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    if args.smoke:
        args.repeats = 1
    common.require("bench_data", {args.mirror / "sdd": MIRROR_HOW,
                                  args.mirror / "ynet-release": MIRROR_HOW})
    params = WindowParams()
    print(f"{'what (min / median / max)':<55} {'':>22}")
    times, tracks = timed(lambda: build_tracks(args.mirror / "sdd"), args.repeats)
    show(f"parse {tracks['scene_id'].nunique()} videos, {len(tracks):,} rows", times)

    def tf30():
        pieces = cut_pieces(tracks, params.label, params.stride)
        return cut_windows(pieces, params.window_length(30))
    times, windows = timed(tf30, args.repeats)
    show(f"cut t_f=30 windows ({windows['window_key'].nunique()} windows)", times)

    times, _ = timed(lambda: cut_windows(cut_pieces(build_tracks(args.mirror / "sdd"), params.label,
                                                     params.stride), 35), args.repeats)
    show("parse + cut t_f=30 (authors' figure: 1.07 / 1.20 / 1.42 s)", times)

    times, tables = timed(lambda: raw_windows(tracks, params, set()), args.repeats)
    show(f"cut all {len(params.horizons)} horizons with splits", times)

    manifest = read_manifest(Path("manifests/ynet-release.sha256"))
    times, release = timed(lambda: release_windows(args.mirror / "ynet-release", manifest, params,
                                                   set()), args.repeats)
    show(f"verify + import release ({release['window_id'].nunique()} windows)", times)


if __name__ == "__main__":
    main()
