"""Stage `score_predictions`: the metrics beyond the paper's tables, from the stored long-term SDD
predictions alone (no model runs): best-endpoint ADE, miss rate, KDE NLL, off-limits share beside
the ground truth's, collisions, and the paper's min-ADE / min-FDE, each as mean and std over the
stored rounds and per scene (`pipeline.harness.stored_scores`).

Scores `<predictions>/tf<H>/<model>.parquet` against `<horizon-windows>/tf<H>.parquet` for every
t_f in `windows.horizons`, and `<predictions>/<release>/<model>.parquet` against the release's
table (named after its file, e.g. `release_tf30`). Params: `score_predictions`,
`windows.horizons`, `windows.n_past`.

    python -m pipeline.stages.score_predictions --predictions data/predictions/long_term \
        --horizon-windows data/horizon_windows --release-windows data/windows/release_tf30.parquet \
        --labels data/labels --scales data/raw/sdd/estimated_scales.yaml \
        --out metrics/beyond/long_term.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config import ScorePredictionsParams, WindowParams, load_section, read_params
from pipeline.harness.stored_scores import SceneMaps, score_tables
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
    parser.add_argument("--out", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    args = parser.parse_args(argv)
    params = read_params(args.params)
    settings = load_section(ScorePredictionsParams, "score_predictions", params)
    windows = load_section(WindowParams, "windows", params)
    tables = {f"tf{h}": args.horizon_windows / f"tf{h}.parquet" for h in windows.horizons}
    tables[args.release_windows.stem] = args.release_windows
    record = score_tables(tables, args.predictions, windows.n_past,
                          SceneMaps(args.labels, args.scales), settings)
    write_json(record, args.out)


if __name__ == "__main__":
    main()
