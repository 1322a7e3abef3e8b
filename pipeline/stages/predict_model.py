"""Stage `predict_model@<name>-<t_f>`: score one registered model (params.yaml `models`; README
"Your model here"), as its `fit_model` stage left it, on the test windows of one horizon table.

K samples per window in seeded rounds, exactly as every baseline is scored (`evaluate_baseline`:
split, K, rounds, seeds), best-of-K ADE / FDE written in the layout of
`metrics/baselines/<model>_tf<H>.json`, and every round's predictions in original pixels
(`pipeline.harness.predictions`), which `score_predictions` scores with the other models'
(`pipeline.harness.model_runs.predict_to_files`). Params: `models.<name>.class`,
`models.<name>.settings`, `evaluate_baseline`, `windows.n_past`.

    python -m pipeline.stages.predict_model --model constant_velocity --horizon 30 \
        --table data/horizon_windows/tf30.parquet --workdir checkpoints/models/constant_velocity_tf30 \
        --metrics metrics/baselines/constant_velocity_tf30.json \
        --predictions data/predictions/long_term/tf30/constant_velocity.parquet
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.windows import WindowParams
from pipeline.harness.model_runs import predict_to_files, registered
from pipeline.models import load_models


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, help="a name of params.yaml `models`")
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--workdir", type=Path, required=True, help="what stage fit_model wrote")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--predictions", type=Path, required=True,
                        help="every round's test predictions written (parquet)")
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    args = parser.parse_args(argv)
    params = read_params(args.params)
    predict_to_files(registered(args.model, load_models(params)), args.horizon, args.table,
                     args.workdir, args.metrics, args.predictions,
                     load_section(EvaluateBaselineParams, "evaluate_baseline", params),
                     load_section(WindowParams, "windows", params).n_past)


if __name__ == "__main__":
    main()
