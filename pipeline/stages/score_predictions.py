"""Stage `score_predictions`: the metrics beyond the paper's tables, from the stored long-term
predictions alone (no model runs): best-endpoint ADE, S-GAN's sequence ADE / FDE, miss rate, KDE
NLL, off-limits share beside the ground truth's, collisions, and the paper's min-ADE / min-FDE,
each as mean and std over the stored rounds and per scene (`pipeline.harness.stored_scores`).

Long-term SDD (`--out`): scores `<predictions>/tf<H>/<model>.parquet` against
`<horizon-windows>/tf<H>.parquet` for every t_f in `windows.horizons`, and
`<predictions>/<release>/<model>.parquet` against the release's table (named after its file, e.g.
`release_tf30`). inD (`--ind-out`): `<ind-predictions>/<model>.parquet` against the test windows of
`ind_windows`' t_f = 30 s table, or, inD not provided, the files listed with their reason. Params:
`score_predictions`, `windows.horizons`, `windows.n_past`.

    python -m pipeline.stages.score_predictions --predictions data/predictions/long_term \
        --horizon-windows data/horizon_windows --release-windows data/windows/release_tf30.parquet \
        --labels data/labels --scales data/raw/sdd/estimated_scales.yaml \
        --ind data/ind --ind-predictions data/predictions/ind \
        --out metrics/beyond/long_term.json --ind-out metrics/beyond/ind.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.benchmarks.ind import IND
from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM, read_scales, sdd_label_masks
from pipeline.config.loading import load_section, read_params
from pipeline.config.score_predictions import ScorePredictionsParams
from pipeline.config.windows import WindowParams
from pipeline.harness.stored_scores import score_benchmarks, score_tables
from pipeline.io import exit_on_bad_intermediate, write_json


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--predictions", type=Path, required=True,
                        help="folder of <table>/<model>.parquet predictions files")
    parser.add_argument("--horizon-windows", type=Path, required=True,
                        help="folder of the horizon window tables tf<H>.parquet")
    parser.add_argument("--release-windows", type=Path, required=True,
                        help="the release's window table (parquet)")
    parser.add_argument("--labels", type=Path, required=True, help="hand-labelled masks folder")
    parser.add_argument("--scales", type=Path, required=True,
                        help="SDD's estimated_scales.yaml (metres per pixel per video)")
    parser.add_argument("--ind", type=Path, required=True, help="output folder of ind_windows")
    parser.add_argument("--ind-predictions", type=Path, required=True,
                        help="folder of inD's <model>.parquet predictions files")
    parser.add_argument("--out", type=Path, required=True, help="long-term SDD metrics JSON")
    parser.add_argument("--ind-out", type=Path, required=True, help="inD metrics JSON")
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    args = parser.parse_args(argv)
    params = read_params(args.params)
    settings = load_section(ScorePredictionsParams, "score_predictions", params)
    windows = load_section(WindowParams, "windows", params)
    masks, scales = sdd_label_masks(args.labels, settings.forbidden_classes), read_scales(args.scales)
    paths = {f"tf{h}": args.horizon_windows / f"tf{h}.parquet" for h in windows.horizons}
    paths[args.release_windows.stem] = args.release_windows
    tables = {name: SDD_LONG_TERM.scored_table(path, windows.n_past, masks, scales, args.scales)
              for name, path in paths.items()}
    ind = IND.scored_table(args.ind, settings.forbidden_classes)
    write_json(score_tables(tables, args.predictions, settings), args.out)
    write_json(score_benchmarks({IND.name: (ind, args.ind_predictions)}, settings), args.ind_out)


if __name__ == "__main__":
    main()
