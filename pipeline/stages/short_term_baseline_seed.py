"""Stage `short_term_baseline_seed@<dataset>-<model>-<seed>` (studies/dvc.yaml, frozen): one
short-term baseline of the paper's Tables 1-2 trained again with another training seed and scored
exactly as the headline run, for the tables' training-seed spread.

`train_short_term_baseline` with `train_baseline.seed` replaced by `--seed` (initial weights, batch
order, training noise and latents, the validation draws that select the epoch), then
`evaluate_short_term_baseline` with the headline's own scoring seed, so that two seeds differ in
training alone. Both stages run as they are, as commands in the scratch folder beside a copy of
params.yaml that differs in that one key (what `dvc exp run -S train_baseline.seed=N` would give
them): their code, fingerprints and lock entries stay the main pipeline's. Writes one JSON,
`--result`: the run record `evaluate_short_term_baseline` writes, plus the training seed and the
machine it ran on (a CPU kind moves the last bits of a training:
docs/experiments/2026-11-28-other-cpu.md). Checkpoints and predictions stay in `--scratch`, which
is no output: a stopped run resumes there, and only the record is committed. Params: those of the
two stages.

    python -m pipeline.stages.short_term_baseline_seed --dataset sdd --model pecnet --seed 1 \
        --windows data/short_term --scratch checkpoints/studies/short_term_seeds/sdd_pecnet_seed1 \
        --result studies/short_term_seeds/sdd_pecnet_seed1.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from pipeline.config import DATASETS, read_params
from pipeline.io import write_json
from pipeline.model_list import TRAINED_BASELINES
from pipeline.report.run_provenance import machine
from pipeline.runners.studies import run_stage, scratch_params

SEED_KEY = "train_baseline.seed"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=DATASETS)
    parser.add_argument("--model", required=True, choices=TRAINED_BASELINES)
    parser.add_argument("--seed", type=int, required=True, help="training seed")
    parser.add_argument("--windows", type=Path, required=True, help="short_term_windows' folder")
    parser.add_argument("--scratch", type=Path, required=True,
                        help="checkpoints and predictions (kept for resuming; not an output)")
    parser.add_argument("--result", type=Path, required=True, help="the run's record (JSON)")
    args = parser.parse_args(argv)
    scratch = scratch_params(args.scratch.resolve(), read_params(), {SEED_KEY: args.seed})
    run = ["--dataset", args.dataset, "--model", args.model, "--windows", str(args.windows.resolve()),
           "--checkpoint-dir", str(scratch / "model")]
    train_record, run_record = scratch / "train.json", scratch / "run.json"
    started = time.perf_counter()
    run_stage("train_short_term_baseline", [*run, "--metrics", str(train_record)], scratch)
    run_stage("evaluate_short_term_baseline", [*run, "--train-metrics", str(train_record),
                                               "--metrics", str(run_record),
                                               "--predictions", str(scratch / "predictions.parquet")],
              scratch)
    record = json.loads(run_record.read_text())
    write_json({**record, "training_seed": args.seed, "stage_seconds": time.perf_counter() - started,
                "machine": machine()}, args.result)
    print(f"short_term_baseline_seed: {args.dataset} {args.model} seed {args.seed} -> {args.result}")


if __name__ == "__main__":
    main()
