"""Stage `budget_run_ynet@<benchmark>-ynet-x<factor>` (studies/dvc.yaml, frozen): Y-net trained
afresh for `factor` x the active profile's epochs and scored as its headline run, one point of the
report's budget curve (`pipeline.runners.budget`; the baselines' points: `budget_run`).

Kinds: `short_term_ynet` (Tables 1-2: `train_short_term_ynet` + `evaluate_short_term_ynet` on
`--dataset`, with `--maps`, `--sdd`, `--ethucy-scenes` as those stages) and `long_term_ynet`
(Table 3: `train_ynet` + `evaluate_ynet` on `--windows`, the release windows at t_f = 30 s, with
`--maps` = data/semantic_maps and `--sdd`).

Writes `--result`: the scoring stage's record plus the factor, the epochs and their key, the
validation curve (val ADE per epoch), the stage's seconds and the machine. Checkpoints stay in
`--scratch` (not an output; a stopped run resumes there). Params: those of the two stages.

    python -m pipeline.stages.budget_run_ynet --kind short_term_ynet --dataset sdd --factor 2 \
        --windows data/short_term --maps data/semantic_maps --sdd data/raw/sdd \
        --ethucy-scenes data/raw/ethucy-scenes --scratch checkpoints/studies/budget/sdd_ynet_x2 \
        --result studies/budget/sdd_ynet_x2.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.benchmarks.registry import SHORT_TERM
from pipeline.config.loading import read_params
from pipeline.io import write_json
from pipeline.report.run_provenance import machine
from pipeline.runners.budget import YNET_KINDS, BudgetPoint, option_error, run_budget_point


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kind", required=True, choices=list(YNET_KINDS))
    parser.add_argument("--factor", type=int, required=True, help="x the profile's epochs")
    parser.add_argument("--dataset", choices=SHORT_TERM,
                        help="short_term_ynet: the benchmark")
    parser.add_argument("--windows", type=Path, required=True,
                        help="the release windows (long-term) or data/short_term (short-term)")
    parser.add_argument("--maps", type=Path, required=True, help="the scene maps Y-net reads")
    parser.add_argument("--sdd", type=Path, required=True, help="the fetched SDD root")
    parser.add_argument("--ethucy-scenes", type=Path,
                        help="short_term_ynet: the fetched ETH/UCY images")
    parser.add_argument("--scratch", type=Path, required=True,
                        help="checkpoints and predictions (kept for resuming; not an output)")
    parser.add_argument("--result", type=Path, required=True, help="the run's record (JSON)")
    args = parser.parse_args(argv)
    error = option_error(args.kind, args.factor, {"--dataset": args.dataset,
                                                  "--ethucy-scenes": args.ethucy_scenes})
    if error:
        parser.error(error)
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_arguments(argv)
    (model,) = YNET_KINDS[args.kind]
    point = BudgetPoint(args.kind, model, args.factor, args.windows, dataset=args.dataset,
                        maps=args.maps, sdd=args.sdd, ethucy_scenes=args.ethucy_scenes)
    record = run_budget_point(point, args.scratch, read_params())
    write_json({**record, "machine": machine()}, args.result)
    print(f"budget_run_ynet: {args.kind} x{args.factor} ({record['epochs']} epochs) -> {args.result}")


if __name__ == "__main__":
    main()
