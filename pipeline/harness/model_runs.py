"""Fitting and scoring one registered model (params.yaml `models`, contract: `pipeline.models`)
at one horizon: what the stages `fit_model` and `predict_model` do.

`fit_to_workdir` hands the model the train and val windows of a horizon table and a fresh
workdir, times the fit and records its facts in the workdir (`FIT_FACTS`); the workdir replaces
the old one only when `fit` returns. `predict_to_files` scores the model exactly as
`baseline_runs.score_to_file` scores a baseline (with the same loop, `score_rounds`): split, K,
rounds and round seeds of `evaluate_baseline`, the shared best-of-K metric over seeded rounds, the metrics file in the
layout of `metrics/baselines/<model>_tf<H>.json` and every round's predictions in the stored
format (`pipeline.harness.predictions`), which `score_predictions` then scores beside the others.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.config.loading import ParamsError
from pipeline.data.window_table import WindowArrays, load_windows
from pipeline.harness.metrics import seeded_rounds, window_errors
from pipeline.harness.predictions import PredictionRounds
from pipeline.io import atomic_dir, write_json
from pipeline.models import ModelEntry, WindowSet, check_predictions, load_model, window_set

if TYPE_CHECKING:  # annotations only: a stage's code holds the sections it reads (code_graph)
    from pipeline.config.evaluate_baseline import EvaluateBaselineParams
    from pipeline.config.train_baseline import TrainBaselineParams

FIT_FACTS = "fit.json"  # written by the harness into every workdir, beside the model's own files


def registered(name: str, models: Mapping[str, ModelEntry]) -> ModelEntry:
    """Model `name`'s line of the registry `models` (`load_models`), or a ParamsError listing the
    registered ones."""
    if name not in models:
        raise ParamsError(f"params.yaml:models: no model {name!r}; registered: {sorted(models)}")
    return models[name]


def limit_torch_threads(threads: int) -> None:
    """`threads` torch CPU threads when the model imported torch (constant velocity does, through
    the baselines); a model without torch does not pay for importing it."""
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(threads)


def fit_to_workdir(entry: ModelEntry, horizon: int, table: Path, workdir: Path,
                   settings: TrainBaselineParams, n_past: int) -> dict:
    """What stage `fit_model` does: the model of registry line `entry` fitted on `table`'s train
    windows (val for selection) under `settings` (section `train_baseline`: seed, threads) and
    `n_past` (`windows.n_past`), its files and the fit's facts (returned too) written to
    `workdir`."""
    name = entry.name
    arrays = load_windows(table, n_past, horizon)
    train = window_set(arrays, "train", with_future=True)
    val = window_set(arrays, "val", with_future=True)
    if len(train) == 0:
        raise ValueError(f"{table}: no train windows to fit {name!r} on")
    model = load_model(entry)
    limit_torch_threads(settings.threads)
    print(f"fit_model {name} t_f = {horizon}: {len(train)} train, {len(val)} val windows", flush=True)
    with atomic_dir(workdir, mode=0o755) as staged:
        t0 = time.perf_counter()
        model.fit(train, val, staged, settings.seed)
        seconds = time.perf_counter() - t0
        if (staged / FIT_FACTS).exists():
            raise ValueError(f"model {name!r}: fit wrote {FIT_FACTS}, the harness's file; name "
                             "yours otherwise")
        facts = {"model": name, "class": entry.class_name, "settings": entry.settings,
                 "horizon": horizon, "window_table": str(table), "seed": settings.seed,
                 "n_train": len(train), "n_val": len(val), "fit_seconds": seconds}
        write_json(facts, staged / FIT_FACTS)
    return facts


def fit_facts(workdir: Path, name: str, horizon: int) -> dict[str, Any]:
    """The facts `fit_to_workdir` recorded, checked to be model `name`'s at `horizon`."""
    path = Path(workdir) / FIT_FACTS
    try:
        facts = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: no fit record ({e}); run stage fit_model@{name}-{horizon} "
                         "first") from e
    if not isinstance(facts, dict) or (facts.get("model"), facts.get("horizon")) != (name, horizon):
        got = (facts.get("model"), facts.get("horizon")) if isinstance(facts, dict) else facts
        raise ValueError(f"{path}: fitted for (model, horizon) {got}, not {(name, horizon)}")
    return facts


def split_to_score(arrays: WindowArrays, split: str) -> tuple[WindowSet, np.ndarray]:
    """The windows of `split` as a model sees them (no future) and their true futures (N, n_f, 2)."""
    return window_set(arrays, split, with_future=False), arrays.future[arrays.split == split]


def score_rounds(name: str, model, test: WindowSet, truth: np.ndarray, workdir: Path, k: int,
                 rounds: int, seed: int, kept: PredictionRounds | None = None) -> dict:
    """`seeded_rounds` of best-of-`k` errors of any model written to `pipeline.models`' contract
    (the registered ones, and the paper's baselines as `baselines.Baseline`): round r is
    `predict(test, k, workdir, seed + r)`, checked (`check_predictions`) and scored against `truth`
    (N, n_f, 2); `kept` receives each round's predictions, exactly as scored."""
    t0 = time.perf_counter()

    def score_round(round_seed: int):
        pred = check_predictions(name, model.predict(test, k, workdir, round_seed), len(test), k,
                                 test.n_future)  # (N, k, n_f, 2)
        if kept is not None:
            kept.add(round_seed, pred)
        return window_errors(pred, truth)

    scored = seeded_rounds(score_round, rounds, seed)
    seconds = time.perf_counter() - t0
    per_round = scored.pop("per_round")
    return {**scored, "k": k, "n_windows": len(test), "eval_seconds": seconds,
            "eval_seconds_per_round": seconds / rounds, "per_round": per_round}


def predict_to_files(entry: ModelEntry, horizon: int, table: Path, workdir: Path, metrics: Path,
                     predictions: Path, evaluation: EvaluateBaselineParams, n_past: int) -> dict:
    """What stage `predict_model` does: the model of registry line `entry`, as fitted in
    `workdir`, scored on split `evaluation.split` of `table` (K, rounds, seed, threads of section
    `evaluate_baseline`; `n_past`: `windows.n_past`), the metrics record written to `metrics` (and
    returned) and every round's predictions to `predictions`."""
    name = entry.name
    facts = fit_facts(workdir, name, horizon)
    arrays = load_windows(table, n_past, horizon)
    test, truth = split_to_score(arrays, evaluation.split)
    if len(test) == 0:
        raise ValueError(f"{table}: no {evaluation.split} windows")
    model = load_model(entry)
    limit_torch_threads(evaluation.threads)
    print(f"predict_model {name} t_f = {horizon}: {len(test)} {evaluation.split} windows", flush=True)
    kept = PredictionRounds(test.window_id)
    scores = score_rounds(name, model, test, truth, Path(workdir), evaluation.k, evaluation.rounds,
                          evaluation.seed, kept)
    record = {"model": name, "horizon": horizon, "split": evaluation.split, "seed": evaluation.seed,
              **scores, "train_seconds": facts["fit_seconds"]}
    kept.write(predictions, {
        "model": name, "benchmark": SDD_LONG_TERM.prediction_benchmark(table),
        "unit": SDD_LONG_TERM.unit,
        "split": evaluation.split, "k": evaluation.k, "horizon": horizon,
        "window_table": str(table), "checkpoint_dir": str(workdir)})
    write_json(record, metrics)
    return record
