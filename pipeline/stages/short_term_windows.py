"""Stage `short_term_windows`: the short-term benchmarks' windows (n_p = 8 + n_f = 12 at 2.5 FPS).

TrajNet SDD in pixels (equal to the release's `test_trajnet.pkl`), the five ETH/UCY leave-one-out
folds in pixels and metres via the authors' homographies, and road / not-road maps of the ETH/UCY
scenes (`pipeline.benchmarks.short_term_windows`, `.trajnet_sdd`, `.ethucy`). Params:
`short_term`.

    python -m pipeline.stages.short_term_windows --trajnet-sdd data/raw/trajnet-sdd --sgan data/raw/sgan \
        --ynet-release data/raw/ynet-release --ethucy-scenes data/raw/ethucy-scenes \
        --out data/short_term --stats metrics/short_term_windows.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pipeline.benchmarks.short_term import ShortTermInputError
from pipeline.benchmarks.short_term_windows import build
from pipeline.config.loading import load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.data.homography import HomographyError
from pipeline.io import write_json


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trajnet-sdd", type=Path, required=True, help="fetched trajnet-sdd root")
    parser.add_argument("--sgan", type=Path, required=True, help="fetched sgan root")
    parser.add_argument("--ynet-release", type=Path, required=True, help="fetched ynet-release root")
    parser.add_argument("--ethucy-scenes", type=Path, required=True, help="fetched ethucy-scenes root")
    parser.add_argument("--out", type=Path, required=True, help="folder of tables and maps")
    parser.add_argument("--stats", type=Path, required=True, help="metrics JSON (window counts)")
    args = parser.parse_args(argv)
    params = load_section(ShortTermParams, "short_term", read_params())
    try:
        stats = build(args.trajnet_sdd, args.sgan, args.ynet_release, args.ethucy_scenes, args.out,
                      params)
    except (ShortTermInputError, HomographyError) as e:
        sys.exit(f"short_term_windows: {e}")
    write_json(stats, args.stats, sort_keys=True)
    print("short_term_windows:", json.dumps({k: stats[k] for k in ("sdd_trajnet", "ethucy")}))


if __name__ == "__main__":
    main()
