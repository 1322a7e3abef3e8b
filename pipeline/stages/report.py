"""Stage `report`: the HTML page with the paper's numbers beside ours, its figures and dvc plots.

Reads every metrics file that exists under `--metrics` (a missing or malformed one becomes an
explained absence), the paper's values (`--paper`), the data manifests and `dvc.lock` (provenance,
and the params each stage ran with: the page shows those, not params.yaml, so editing a section no
stage reads re-renders nothing); the page's contents are documented in `pipeline.report.page`.
Also writes `--headline`, the small ADE / FDE files `dvc metrics show` prints. Params: `report`,
`models` (the registered models: a Table 3 column, a Figure 4 line and "Beyond the paper's tables"
rows each, under their label and colour; README "Your model here").

    python -m pipeline.stages.report --metrics metrics --paper pipeline/report/paper_values.yaml \
        --scene-counts reports/data/windows_per_scene.json \
        --gallery reports/figures/gallery --manifests manifests --dvc-lock dvc.lock \
        --animations reports/figures/animations --horizon-figures reports/figures/horizons \
        --out reports/index.html \
        --figures reports/figures/report --plots reports/plots --headline reports/headline
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from pipeline.config.loading import load_section, read_params
from pipeline.config.report import ReportParams
from pipeline.models import load_models
from pipeline.report.page import Inputs, write_report
from pipeline.report.run_provenance import read_lock


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--metrics", type=Path, default=Path("metrics"), help="metrics folder")
    parser.add_argument("--paper", type=Path, default=Path("pipeline/report/paper_values.yaml"))
    parser.add_argument("--scene-counts", type=Path, default=Path("reports/data/windows_per_scene.json"))
    parser.add_argument("--gallery", type=Path, default=Path("reports/figures/gallery"),
                        help="stage report_figures' folder (Figure 6, the segmentation gallery)")
    parser.add_argument("--manifests", type=Path, default=Path("manifests"))
    parser.add_argument("--dvc-lock", type=Path, default=Path("dvc.lock"))
    parser.add_argument("--stage-times", type=Path, default=Path("reports/stage_times.json"),
                        help="tools/timed_repro.py's stage times (shown when present)")
    parser.add_argument("--animations", type=Path, default=Path("reports/figures/animations"),
                        help="stage animations' folder (index.json and the animated windows)")
    parser.add_argument("--horizon-figures", type=Path, default=Path("reports/figures/horizons"),
                        help="stage horizon_analysis' figures folder")
    parser.add_argument("--short-term-seeds", type=Path, default=Path("studies/short_term_seeds"),
                        help="the study's runs of Tables 1-2's baselines with other training seeds")
    parser.add_argument("--budget", type=Path, default=Path("studies/budget"),
                        help="the budget-curve study's runs")
    parser.add_argument("--params", type=Path, default=Path("params.yaml"),
                        help="read for its `report` and `models` sections only")
    parser.add_argument("--out", type=Path, required=True, help="the HTML page written")
    parser.add_argument("--figures", type=Path, required=True, help="folder of the page's PNG figures")
    parser.add_argument("--plots", type=Path, required=True, help="folder of the dvc plots JSON series")
    parser.add_argument("--headline", type=Path, required=True,
                        help="folder of the headline metrics (ADE / FDE per table and model)")
    args = parser.parse_args(argv)
    params = read_params(args.params)
    report_params = load_section(ReportParams, "report", params)
    own_outputs = tuple(Path(os.path.relpath(path.resolve(), Path.cwd())).as_posix()
                        for path in (args.out, args.figures, args.plots, args.headline,
                                     args.stage_times))  # the stage times: make repro writes them
    inputs = Inputs(args.metrics, args.paper, args.scene_counts, args.gallery, args.manifests,
                    own_outputs=own_outputs,
                    stage_times=args.stage_times, animations=args.animations,
                    horizon_figures=args.horizon_figures, short_term_seeds=args.short_term_seeds,
                    budget=args.budget)
    write_report(inputs, read_lock(args.dvc_lock), report_params, args.out, args.figures,
                 args.plots, args.headline, registered=load_models(params))


if __name__ == "__main__":
    main()
