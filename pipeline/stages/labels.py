"""Stage `labels`: import the hand-labelled semantic masks of all SDD videos, validated.

A mask that does not fit its image or holds an unknown value stops the stage with a message naming
the file (`pipeline.data.labels`). Writes one label map per video, `index.json` and colour overlays
for the report. Params: `labels`.

    python -m pipeline.stages.labels --sdd data/raw/sdd --release data/raw/ynet-release \
        --out data/labels --figures reports/figures/segmentation/labels
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.labels import LabelsParams
from pipeline.config.loading import load_section, read_params
from pipeline.data.labels import import_labels


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sdd", type=Path, required=True, help="SDD root holding annotations/")
    parser.add_argument("--release", type=Path, required=True, help="ynet-release root")
    parser.add_argument("--out", type=Path, required=True, help="label maps + index.json folder")
    parser.add_argument("--figures", type=Path, required=True, help="overlay PNG folder")
    args = parser.parse_args(argv)
    params = load_section(LabelsParams, "labels", read_params())
    index = import_labels(args.sdd, args.release, args.out, args.figures, params)
    splits = [v["split"] for v in index["videos"].values()]
    print(f"labels: {len(splits)} videos validated "
          f"({splits.count('train')} train, {splits.count('test')} test, {splits.count('none')} other)")


if __name__ == "__main__":
    main()
