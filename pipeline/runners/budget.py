"""One point of a budget curve (studies/dvc.yaml, `budget_run` and `budget_run_ynet`): a model of
the paper's tables trained afresh for `factor` x the active profile's epochs and scored as its
headline run (does more training close the gap to the paper?).

The pipeline's own training and scoring stages, unchanged, run as commands in the scratch folder
beside a copy of params.yaml whose epochs key is multiplied by the factor; nothing else moves.
Each trains from scratch (a longer run never continues a shorter one's checkpoint), validates after
every epoch and keeps the epoch its validation selects, as the headline does. The schedules stretch
with the epochs: the baselines' learning rate is constant, the short-term Y-net's is constant on
SDD and a half cosine over the run on ETH/UCY, the long-term Y-net's a cosine to 0 over the run.

Kinds (the stages each runs; the epochs key multiplied):
- `long_term_baseline` (Table 3): `train_baseline` + `evaluate_baseline` at the horizon, on the
  horizon's table; `<model>.<profile>.epochs`.
- `short_term_baseline` (Tables 1-2): `train_short_term_baseline` + `evaluate_short_term_baseline`
  on the dataset; `short_term_models.<profile>.epochs.<model>.<benchmark>`.
- `short_term_ynet` (Tables 1-2): `train_short_term_ynet` + `evaluate_short_term_ynet`; as above.
- `long_term_ynet` (Table 3): `train_ynet` + `evaluate_ynet` on the release windows at t_f = 30 s;
  `ynet.<profile>.epochs`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipeline.benchmarks.registry import short_term
from pipeline.checkpoints import read
from pipeline.config.loading import active_profile
from pipeline.model_list import TRAINED_BASELINES, YNET
from pipeline.runners.studies import dotted, run_stage, scratch_params, short_term_commands

BASELINE_KINDS = {"long_term_baseline": TRAINED_BASELINES, "short_term_baseline": TRAINED_BASELINES}
YNET_KINDS = {"short_term_ynet": (YNET,), "long_term_ynet": (YNET,)}


@dataclass(frozen=True)
class BudgetPoint:
    """What one run trains, where, on what: paths as given (made absolute for the stages)."""
    kind: str
    model: str
    factor: int
    windows: Path  # the horizon's table, the release windows or data/short_term
    horizon: int | None = None  # long_term_baseline
    dataset: str | None = None  # short-term kinds
    maps: Path | None = None  # Y-net: its scene maps
    sdd: Path | None = None  # Y-net: the fetched SDD root
    ethucy_scenes: Path | None = None  # short_term_ynet: the fetched ETH/UCY images


def is_long_term(kind: str) -> bool:
    return kind.startswith("long_term_")


def needed_options(kind: str) -> dict[str, bool]:
    """Each optional field of `BudgetPoint` -> whether the kind needs it (else it must be unset)."""
    ynet = kind in YNET_KINDS
    return {"horizon": kind == "long_term_baseline", "dataset": not is_long_term(kind),
            "maps": ynet, "sdd": ynet, "ethucy_scenes": kind == "short_term_ynet"}


def option_error(kind: str, factor: int, options: Mapping[str, Any]) -> str | None:
    """What is wrong with a stage's options (`--name` -> value as given, None where not), if
    anything: an option the kind needs and lacks, one it does not use, a factor below 1."""
    for name, needed in needed_options(kind).items():
        flag = "--" + name.replace("_", "-")
        if flag in options and needed != (options[flag] is not None):
            return f"--kind {kind} {'needs' if needed else 'takes no'} {flag}"
    if factor < 1:
        return f"--factor {factor}: a multiple of the profile's epochs, at least 1"
    return None


def epochs_key(kind: str, model: str, profile: str, dataset: str | None) -> str:
    if is_long_term(kind):
        return f"{model}.{profile}.epochs"
    return f"short_term_models.{profile}.epochs.{model}.{short_term(dataset).settings_key}"


def stage_commands(point: BudgetPoint, scratch: Path, n_past: int) -> list[tuple[str, list[str]]]:
    """(stage, arguments) of the training, then the scoring, all paths absolute."""
    model_dir, train, run = scratch / "model", scratch / "train.json", scratch / "run.json"
    predictions = str(scratch / "predictions.parquet")
    windows = str(point.windows.resolve())
    if point.kind == "long_term_baseline":
        common = ["--model", point.model, "--horizon", str(point.horizon), "--table", windows,
                  "--checkpoint-dir", str(model_dir)]
        return [("train_baseline", [*common, "--metrics", str(train)]),
                ("evaluate_baseline", [*common, "--metrics", str(run), "--predictions", predictions])]
    if point.kind == "long_term_ynet":
        common = ["--windows", windows, "--semantic-maps", str(point.maps.resolve()),
                  "--sdd", str(point.sdd.resolve()), "--n-past", str(n_past)]
        model = str(scratch / "model.pt")
        return [("train_ynet", [*common, "--checkpoint-dir", str(model_dir), "--model", model,
                                "--history", str(scratch / "history.csv"), "--metrics", str(train)]),
                ("evaluate_ynet", [*common, "--model", model, "--metrics", str(run),
                                   "--qualitative", str(scratch / "qualitative.npz"),
                                   "--predictions", predictions])]
    ynet_inputs = (point.maps, point.sdd, point.ethucy_scenes) if point.kind in YNET_KINDS else None
    return short_term_commands(point.model, point.dataset, point.windows, scratch, ynet_inputs)


def validation_curve(model_dir: Path) -> list[float]:
    """Val ADE after each epoch, as the training's last checkpoint recorded it ([] if none): the
    baselines keep their history in the state, Y-net in the state's `progress`."""
    state = read(model_dir / "last.pt").state
    history = state.get("history") or (state.get("progress") or {}).get("history") or []
    return [float(entry["val_ade"]) for entry in history if "val_ade" in entry]


def run_budget_point(point: BudgetPoint, scratch: Path, params: dict[str, Any]) -> dict[str, Any]:
    """Train and score `point` in `scratch` (kept: a stopped run resumes there); the scoring
    stage's record plus the factor, the epochs, their key, the validation curve and the seconds."""
    key = epochs_key(point.kind, point.model, active_profile(params), point.dataset)
    epochs = dotted(params, key) * point.factor
    scratch = scratch_params(scratch.resolve(), params, {key: epochs})
    started = time.perf_counter()
    for stage, stage_args in stage_commands(point, scratch, dotted(params, "windows.n_past")):
        run_stage(stage, stage_args, scratch)
    record: dict[str, Any] = json.loads((scratch / "run.json").read_text())
    return {**record, "factor": point.factor, "epochs": epochs, "epochs_key": key,
            "val_ade_per_epoch": validation_curve(scratch / "model"),
            "stage_seconds": time.perf_counter() - started}
