"""Stage `score_short_term_predictions`: the metrics beyond the paper's Tables 1 and 2, from the
stored short-term predictions alone (no model runs): the paper's min-ADE / min-FDE (pixels for
TrajNet SDD, metres for ETH/UCY), joint ADE / FDE, best-endpoint ADE, S-GAN's sequence ADE / FDE,
miss rate, KDE NLL, off-limits share (SDD: hand labels; ETH/UCY: not road) beside the ground
truth's, collisions, each as mean and std over the stored rounds and per scene
(`pipeline.harness.stored_scores`; each benchmark's tables, units and masks: `pipeline.benchmarks`).

Scores `<predictions>/<dataset>/<model>.parquet` for every short-term benchmark of the registry
(sdd and the five ETH/UCY folds) against the test windows of the dataset's table in `--windows`;
a file that says why nothing was predicted is listed with its reason. Params:
`score_predictions`, `short_term.n_past`.

    python -m pipeline.stages.score_short_term_predictions --predictions data/predictions/short_term \
        --windows data/short_term --labels data/labels --scales data/raw/sdd/estimated_scales.yaml \
        --out metrics/beyond/short_term.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.benchmarks.registry import SHORT_TERM
from pipeline.benchmarks.sdd_long_term import read_scales, sdd_label_masks
from pipeline.config.loading import load_section, read_params
from pipeline.config.score_predictions import ScorePredictionsParams
from pipeline.config.short_term import ShortTermParams
from pipeline.harness.stored_scores import score_benchmarks, short_term_tables
from pipeline.io import exit_on_bad_intermediate, write_json


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--predictions", type=Path, required=True,
                        help="folder of <dataset>/<model>.parquet predictions files")
    parser.add_argument("--windows", type=Path, required=True,
                        help="short_term_windows output folder (tables and ETH/UCY maps)")
    parser.add_argument("--labels", type=Path, required=True, help="hand-labelled masks folder")
    parser.add_argument("--scales", type=Path, required=True,
                        help="SDD's estimated_scales.yaml (metres per pixel per video)")
    parser.add_argument("--out", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    args = parser.parse_args(argv)
    params = read_params(args.params)
    settings = load_section(ScorePredictionsParams, "score_predictions", params)
    n_past = load_section(ShortTermParams, "short_term", params).n_past
    benchmarks = short_term_tables(args.windows, args.predictions, SHORT_TERM, n_past,
                                   sdd_label_masks(args.labels, settings.forbidden_classes),
                                   read_scales(args.scales), args.scales)
    write_json(score_benchmarks(benchmarks, settings), args.out)


if __name__ == "__main__":
    main()
