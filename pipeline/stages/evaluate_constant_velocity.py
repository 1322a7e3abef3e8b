"""Stage `evaluate_constant_velocity@<t_f>`: the constant-velocity baseline (the last observed
velocity extrapolated; nothing trained) scored with the shared metric at horizon t_f (as
`evaluate_baseline --model constant_velocity`; layout of `metrics/baselines/<model>_tf<H>.json`),
every round's predictions written (K identical samples per window, as scored). Params:
`evaluate_baseline`, `windows.n_past`, `runtime.device`.

    python -m pipeline.stages.evaluate_constant_velocity --horizon 30 \
        --table data/horizon_windows/tf30.parquet --metrics metrics/baselines/constant_velocity_tf30.json \
        --predictions data/predictions/long_term/tf30/constant_velocity.parquet
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config import read_params
from pipeline.harness.baseline_runs import score_to_file

MODEL = "constant_velocity"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--predictions", type=Path, required=True,
                        help="every round's test predictions written (parquet)")
    args = parser.parse_args(argv)
    score_to_file(MODEL, args.table, args.horizon, None, args.metrics, args.predictions,
                  read_params())


if __name__ == "__main__":
    main()
