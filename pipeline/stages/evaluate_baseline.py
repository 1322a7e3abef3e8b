"""Stage `evaluate_baseline@<model>-<t_f>`: score one baseline at one horizon with the shared metric.

Loads the model (`sgan` / `pecnet` from the checkpoint folder trained for this horizon; `rpecnet`
the t_f = 5 PECNet's), draws K samples per window of the
chosen split in `rounds` seeded rounds, and writes best-of-K ADE / FDE, independent and joint, as
mean and spread over rounds, with the training facts the checkpoint records
(`pipeline.runners.baseline_runs.score_split`), and every round's predictions in original pixels
(`pipeline.harness.predictions`; one folder per window table: `tf<H>/` for the horizon tables).
`evaluate_rpecnet` is this stage for one model (constant velocity runs through `predict_model`). Params:
`evaluate_baseline`, `windows.n_past`, `runtime.device`.

    python -m pipeline.stages.evaluate_baseline --model pecnet --horizon 30 \
        --table data/horizon_windows/tf30.parquet --checkpoint-dir checkpoints/pecnet_tf30 \
        --metrics metrics/baselines/pecnet_tf30.json \
        --predictions data/predictions/long_term/tf30/pecnet.parquet
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.windows import WindowParams
from pipeline.runners import baselines
from pipeline.runners.baseline_runs import score_to_file


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, choices=sorted(baselines.BASELINES))
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True,
                        help="trained model (rpecnet: the t_f = 5 PECNet)")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--predictions", type=Path, required=True,
                        help="every round's test predictions written (parquet)")
    args = parser.parse_args(argv)
    params = read_params()
    score_to_file(args.model, args.table, args.horizon, args.checkpoint_dir, args.metrics,
                  args.predictions,
                  load_section(EvaluateBaselineParams, "evaluate_baseline", params),
                  load_section(WindowParams, "windows", params).n_past,
                  load_section(RuntimeParams, "runtime", params))


if __name__ == "__main__":
    main()
