"""Stage `report_figures`: the report's figures that are drawn from cached stage outputs, written
small into a committed folder, so that the report renders from git alone.

The qualitative figure (paper Figure 6) comes from the Y-net evaluation's arrays
(`data/ynet_predictions/qualitative.npz`) and the segmentation gallery from `semantic_maps`' figures
(one PNG per video, several MB, git-ignored); both live in the DVC cache only, so a page rendered
from them could not be checked on a fresh clone. This stage draws the figure and the compact JPEGs
once, beside an `index.json` that says what is there and why anything is missing; the report reads
that folder (`--gallery`) and nothing else of these stages. Params: none.

    python -m pipeline.stages.report_figures --qualitative data/ynet_predictions/qualitative.npz \
        --segmentation-figures reports/figures/segmentation/predictions --out reports/figures/gallery
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pipeline.io import atomic_dir, write_json
from pipeline.report.common import FigureSlot
from pipeline.report.data_and_segmentation import segmentation_gallery
from pipeline.report.figures import Qualitative, load_qualitative, plot_qualitative
from pipeline.splits import TEST_VIDEOS

INDEX = "index.json"
QUALITATIVE = "qualitative.png"


def draw_gallery(qualitative: Path, segmentation_figures: Path, out: Path) -> dict[str, Any]:
    """Draw into `out` (an existing folder); the index, whose file names are relative to it."""
    def slot(name: str) -> FigureSlot:
        return FigureSlot(out / name, name)

    examples = load_qualitative(qualitative)
    if isinstance(examples, Qualitative):
        plot_qualitative(examples.examples, out / QUALITATIVE)
        figure = {"file": QUALITATIVE, "absent": None, "problems": list(examples.problems)}
    else:
        figure = {"file": None, "absent": examples.reason, "problems": []}
    return {"qualitative": figure,
            "segmentation": segmentation_gallery(segmentation_figures, TEST_VIDEOS, slot)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--qualitative", type=Path, required=True, help="evaluate_ynet's arrays (.npz)")
    parser.add_argument("--segmentation-figures", type=Path, required=True,
                        help="semantic_maps' figures folder")
    parser.add_argument("--out", type=Path, required=True, help="the gallery folder written")
    args = parser.parse_args(argv)
    with atomic_dir(args.out, mode=0o755) as staged:
        index = draw_gallery(args.qualitative, args.segmentation_figures, staged)
        write_json(index, staged / INDEX)
    drawn = sum(1 for row in index["segmentation"]["rows"] for image in row["images"] if image)
    print(f"report_figures: qualitative {'drawn' if index['qualitative']['file'] else 'absent'}, "
          f"{drawn} segmentation figures -> {args.out}")


if __name__ == "__main__":
    main()
