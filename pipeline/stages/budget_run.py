"""Stage `budget_run@<benchmark>-<model>-x<factor>` (studies/dvc.yaml, frozen): a baseline of the
paper's tables (S-GAN, PECNet) trained afresh for `factor` x the active profile's epochs and scored
as its headline run, one point of the report's budget curve (`pipeline.runners.budget`; Y-net's
points: `budget_run_ynet`).

Kinds: `long_term_baseline` (Table 3: `train_baseline` + `evaluate_baseline` at `--horizon` on
`--windows`, the horizon's table) and `short_term_baseline` (Tables 1-2:
`train_short_term_baseline` + `evaluate_short_term_baseline` on `--dataset`).

Writes `--result`: the scoring stage's record plus the factor, the epochs and their key, the
validation curve (val ADE per epoch), the stage's seconds and the machine. Checkpoints stay in
`--scratch` (not an output; a stopped run resumes there). Params: those of the two stages.

    python -m pipeline.stages.budget_run --kind long_term_baseline --model pecnet --horizon 30 \
        --factor 4 --windows data/horizon_windows/tf30.parquet --scratch checkpoints/studies/budget/sdd_long_pecnet_x4 \
        --result studies/budget/sdd_long_pecnet_x4.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.benchmarks.registry import SHORT_TERM
from pipeline.config.loading import read_params
from pipeline.io import write_json
from pipeline.model_list import TRAINED_BASELINES
from pipeline.report.run_provenance import machine
from pipeline.runners.budget import BASELINE_KINDS, BudgetPoint, option_error, run_budget_point


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kind", required=True, choices=list(BASELINE_KINDS))
    parser.add_argument("--model", required=True, choices=TRAINED_BASELINES)
    parser.add_argument("--factor", type=int, required=True, help="x the profile's epochs")
    parser.add_argument("--horizon", type=int, help="long_term_baseline: t_f (s)")
    parser.add_argument("--dataset", choices=SHORT_TERM,
                        help="short_term_baseline: the benchmark")
    parser.add_argument("--windows", type=Path, required=True,
                        help="the horizon's table (long-term) or data/short_term (short-term)")
    parser.add_argument("--scratch", type=Path, required=True,
                        help="checkpoints and predictions (kept for resuming; not an output)")
    parser.add_argument("--result", type=Path, required=True, help="the run's record (JSON)")
    args = parser.parse_args(argv)
    error = option_error(args.kind, args.factor, {"--horizon": args.horizon,
                                                  "--dataset": args.dataset})
    if error:
        parser.error(error)
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_arguments(argv)
    point = BudgetPoint(args.kind, args.model, args.factor, args.windows, horizon=args.horizon,
                        dataset=args.dataset)
    record = run_budget_point(point, args.scratch, read_params())
    write_json({**record, "machine": machine()}, args.result)
    print(f"budget_run: {args.kind} {args.model} x{args.factor} ({record['epochs']} epochs) "
          f"-> {args.result}")


if __name__ == "__main__":
    main()
