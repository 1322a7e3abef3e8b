"""Stage `budget_run@<benchmark>-<model>-x<factor>` (studies/dvc.yaml, frozen): a model of the
paper's tables trained afresh for `factor` x the active profile's epochs and scored as its headline
run, one point of the report's budget curve (does more training close the gap to the paper?).

The pipeline's own training and scoring stages, unchanged, run as commands in the scratch folder
beside a copy of params.yaml whose epochs key is multiplied by `--factor`; nothing else moves. The
baselines keep a constant learning rate, so their schedule stretches with the epochs by itself;
each trains from scratch (a longer run never continues a shorter one's checkpoint), validates
after every epoch and keeps the epoch its validation selects, as the headline does.

Kinds:
- `long_term_baseline` (Table 3): `train_baseline` + `evaluate_baseline` at `--horizon`, on
  `--windows`, the horizon's table (`data/horizon_windows/tf<horizon>.parquet`); epochs key
  `<model>.<profile>.epochs`.
- `short_term_baseline` (Tables 1-2): `train_short_term_baseline` + `evaluate_short_term_baseline`
  on `--dataset`; epochs key `short_term_models.<profile>.epochs.<model>.<sdd|ethucy>`.

Writes `--result`: the scoring stage's record plus the factor, the epochs and their key, the
validation curve (val ADE per epoch, from the checkpoint's history), the stage's seconds and the
machine. Checkpoints stay in `--scratch` (not an output; a stopped run resumes there). Params:
those of the two stages.

    python -m pipeline.stages.budget_run --kind long_term_baseline --model pecnet --horizon 30 \
        --factor 4 --windows data/horizon_windows/tf30.parquet --scratch checkpoints/studies/budget/sdd_long_pecnet_x4 \
        --result studies/budget/sdd_long_pecnet_x4.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from pipeline.checkpoints import read
from pipeline.config.loading import read_params
from pipeline.dataset_list import SHORT_TERM_DATASETS
from pipeline.io import write_json
from pipeline.model_list import TRAINED_BASELINES
from pipeline.report.run_provenance import machine
from pipeline.runners.studies import dotted, run_stage, scratch_params

KINDS = ("long_term_baseline", "short_term_baseline")


def epochs_key(kind: str, model: str, profile: str, dataset: str | None) -> str:
    if kind == "long_term_baseline":
        return f"{model}.{profile}.epochs"
    benchmark = "sdd" if dataset == "sdd" else "ethucy"
    return f"short_term_models.{profile}.epochs.{model}.{benchmark}"


def stage_commands(kind: str, model: str, scratch: Path, horizon: int | None, dataset: str | None,
                   windows: Path) -> list[tuple[str, list[str]]]:
    """(stage, arguments) of the training, then the scoring, all paths absolute."""
    model_dir, train, run = scratch / "model", scratch / "train.json", scratch / "run.json"
    predictions = scratch / "predictions.parquet"
    if kind == "long_term_baseline":
        common = ["--model", model, "--horizon", str(horizon), "--table", str(windows),
                  "--checkpoint-dir", str(model_dir)]
        return [("train_baseline", [*common, "--metrics", str(train)]),
                ("evaluate_baseline", [*common, "--metrics", str(run),
                                       "--predictions", str(predictions)])]
    common = ["--dataset", dataset, "--model", model, "--windows", str(windows),
              "--checkpoint-dir", str(model_dir)]
    return [("train_short_term_baseline", [*common, "--metrics", str(train)]),
            ("evaluate_short_term_baseline", [*common, "--train-metrics", str(train),
                                              "--metrics", str(run),
                                              "--predictions", str(predictions)])]


def validation_curve(model_dir: Path) -> list[float]:
    """Val ADE after each epoch, as the training's last checkpoint recorded it ([] if none)."""
    history = read(model_dir / "last.pt").state.get("history") or []
    return [float(entry["val_ade"]) for entry in history if "val_ade" in entry]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kind", required=True, choices=KINDS)
    parser.add_argument("--model", required=True, choices=TRAINED_BASELINES)
    parser.add_argument("--factor", type=int, required=True, help="x the profile's epochs")
    parser.add_argument("--horizon", type=int, help="long_term_baseline: t_f (s)")
    parser.add_argument("--dataset", choices=SHORT_TERM_DATASETS,
                        help="short_term_baseline: the benchmark")
    parser.add_argument("--windows", type=Path, required=True,
                        help="the horizon's table (long-term) or data/short_term (short-term)")
    parser.add_argument("--scratch", type=Path, required=True,
                        help="checkpoints and predictions (kept for resuming; not an output)")
    parser.add_argument("--result", type=Path, required=True, help="the run's record (JSON)")
    args = parser.parse_args(argv)
    if (args.kind == "long_term_baseline") != (args.horizon is not None) or \
            (args.kind == "short_term_baseline") != (args.dataset is not None):
        parser.error("long_term_baseline takes --horizon, short_term_baseline --dataset")
    if args.factor < 1:
        parser.error(f"--factor {args.factor}: a multiple of the profile's epochs, at least 1")
    params = read_params()
    key = epochs_key(args.kind, args.model, params["profile"], args.dataset)
    epochs = dotted(params, key) * args.factor
    scratch = scratch_params(args.scratch.resolve(), params, {key: epochs})
    started = time.perf_counter()
    for stage, stage_args in stage_commands(args.kind, args.model, scratch, args.horizon,
                                            args.dataset, args.windows.resolve()):
        run_stage(stage, stage_args, scratch)
    record: dict[str, Any] = json.loads((scratch / "run.json").read_text())
    write_json({**record, "factor": args.factor, "epochs": epochs, "epochs_key": key,
                "val_ade_per_epoch": validation_curve(scratch / "model"),
                "stage_seconds": time.perf_counter() - started, "machine": machine()}, args.result)
    print(f"budget_run: {args.kind} {args.model} x{args.factor} ({epochs} epochs) -> {args.result}")


if __name__ == "__main__":
    main()
