"""Stage `horizon_analysis`: why Y-net's error stops growing after 30 s (data, model or leak).

Per horizon, on the test split: the windows' data, constant velocity and the straight line to the
true goal, every stored model's scores on its own windows; one population (the longest horizon's
test windows truncated at every horizon) scored with the longest horizon's stored predictions over
their first t seconds and with each horizon's own Y-net run on the truncated windows (one round,
the sampling its evaluation stored; a horizon the profile does not train says so); a leak check
over every window table; Y-net's validation curves (`pipeline.studies.horizon_analysis`,
`pipeline.studies.horizon_reruns`). Writes the record and two figures (`pipeline.report.horizons`).
Params: `windows.horizons`, `windows.n_past`, `windows.release_horizon`, `eval.<profile>`'s
`batch_size`, `chunk_size`, `bf16`; `models` (the registered models' labels and colours).

    python -m pipeline.stages.horizon_analysis --horizon-windows data/horizon_windows \
        --release-windows data/windows/release_tf30.parquet \
        --predictions data/predictions/long_term \
        --ynet-checkpoints checkpoints/ynet_tf5 ... checkpoints/ynet_tf60 \
        --main-model data/ynet/model.pt --main-history reports/training/ynet_train.csv \
        --semantic-maps data/semantic_maps --sdd data/raw/sdd \
        --out metrics/horizon_analysis.json --figures reports/figures/horizons
"""

from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

import pandas as pd

from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.windows import WindowParams
from pipeline.studies import horizon_analysis as analysis
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.models import all_models, load_models
from pipeline.report.horizons import draw_figures, print_summary
from pipeline.studies.horizon_reruns import own_horizon_ynet


def checkpoint_dirs(paths: list[Path]) -> dict[int, Path]:
    """{t_f: folder} of Y-net horizon checkpoint folders named `..._tf<t_f>`."""
    found = {}
    for path in paths:
        match = re.search(r"_tf(\d+)$", path.name)
        if not match:
            raise SystemExit(f"horizon_analysis: {path} is not named <...>_tf<t_f>")
        found[int(match.group(1))] = path
    return found


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon-windows", type=Path, required=True,
                        help="folder of tf<t>.parquet")
    parser.add_argument("--release-windows", type=Path, required=True)
    parser.add_argument("--predictions", type=Path, required=True,
                        help="stored long-term predictions: tf<t>/<model>.parquet, release_tf30/")
    parser.add_argument("--ynet-checkpoints", type=Path, nargs="+", required=True,
                        help="train_ynet_horizon folders <...>_tf<t> (best.pt, history.csv)")
    parser.add_argument("--main-model", type=Path, required=True, help="the main 30-s Y-net")
    parser.add_argument("--main-history", type=Path, required=True, help="its history CSV")
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root (scene sizes)")
    parser.add_argument("--out", type=Path, required=True, help="metrics JSON")
    parser.add_argument("--figures", type=Path, required=True, help="folder of the PNG figures")
    args = parser.parse_args(argv)
    params = read_params()
    windows = load_section(WindowParams, "windows", params)
    eval_params = load_profile(EvalParams, "eval", params)
    horizons, n_past, main_t = sorted(windows.horizons), windows.n_past, windows.release_horizon
    start = time.perf_counter()

    tables = {f"tf{t}": pd.read_parquet(args.horizon_windows / f"tf{t}.parquet") for t in horizons}
    tables[args.release_windows.stem] = release = pd.read_parquet(args.release_windows)
    main_file = args.predictions / args.release_windows.stem / f"{analysis.SUBJECT}.parquet"
    per_horizon, metadata = [], {}
    for t in horizons:
        subject = (main_file, release) if t == main_t else ()
        inputs, metadata[t] = analysis.read_horizon(t, tables[f"tf{t}"],
                                                    args.predictions / f"tf{t}", n_past, *subject)
        per_horizon.append(inputs)

    folders = checkpoint_dirs(args.ynet_checkpoints)
    runs = analysis.subject_runs(
        horizons, metadata,
        models={main_t: args.main_model, **{t: f / "best.pt" for t, f in folders.items()}},
        histories={main_t: args.main_history, **{t: f / "history.csv" for t, f in folders.items()}})

    longest = per_horizon[-1].arrays
    own = own_horizon_ynet(longest, horizons, runs.models, args.semantic_maps, args.sdd,
                           eval_params)
    record = analysis.analyse(horizons, per_horizon, tables, runs.curves, own,
                              per_window={t: (analysis.SUBJECT,) for t in horizons if t > main_t})
    shown = {model.name: model for model in all_models(load_models(params))}
    record["figures"] = draw_figures(record, args.figures, shown)
    record["seconds"] = time.perf_counter() - start
    write_json(record, args.out)
    print_summary(record)


if __name__ == "__main__":
    main()
