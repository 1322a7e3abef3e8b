"""Stage `fit_model@<name>-<t_f>`: fit one registered model (params.yaml `models`; README "Your
model here") on the train windows of one horizon table, selecting on its val windows.

The model's code is `pipeline/models/<name>.py`, written to the contract of `pipeline.models`;
what its `fit` keeps goes to the workdir, with the fit's facts in `fit.json`
(`pipeline.harness.model_runs.fit_to_workdir`). Params: `models.<name>.class`,
`models.<name>.settings`, `train_baseline` (seed, threads), `windows.n_past`.

    python -m pipeline.stages.fit_model --model constant_velocity --horizon 30 \
        --table data/horizon_windows/tf30.parquet --workdir checkpoints/models/constant_velocity_tf30
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.loading import load_section, read_params
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.harness.model_runs import fit_to_workdir, registered
from pipeline.models import load_models


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, help="a name of params.yaml `models`")
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--workdir", type=Path, required=True,
                        help="folder written: what the fitted model keeps, and fit.json")
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    args = parser.parse_args(argv)
    params = read_params(args.params)
    fit_to_workdir(registered(args.model, load_models(params)), args.horizon, args.table,
                   args.workdir, load_section(TrainBaselineParams, "train_baseline", params),
                   load_section(WindowParams, "windows", params).n_past)


if __name__ == "__main__":
    main()
