"""Training and scoring one baseline at one horizon: what the baseline stages share.

`train` fits S-GAN or PECNet on a window table's `train` split (keeping, for every rule of
`pipeline.harness.epoch_selection`, the epoch it selects on the min-over-K ADE on `val`, never
`test`; `evaluate_baseline.epoch_selection` says which is scored) and `train_record` is what the stages `train_baseline` and
`train_baseline_seed` do with it (one training seed each), `score_split` and `ka_rows` score a
baseline, behind the models' contract (`baselines.Baseline`), with the loop every model is scored
with (`pipeline.harness.model_runs.score_rounds`: the shared metric over seeded rounds; stages
`evaluate_baseline`, `evaluate_rpecnet`, `evaluate_pecnet_ka`, `evaluate_ind`; constant velocity
and the other registered models go through `predict_model`), keeping every round's predictions
where asked, `training_facts` reads what a checkpoint folder records about its
training. `score_to_file` is what the long-term baseline stages do: the metrics file and the file of
every test prediction (`pipeline.harness.predictions`), or only the metrics for the extra training
seeds (`evaluate_baseline_seed`, `evaluate_rpecnet_seed`). Checkpoints:
`pipeline.runners.baselines.common`.
Each model's settings are its config dataclass (`pipeline.config.sgan` / `.pecnet`: sections `sgan`
/ `pecnet`, one per profile), of the class `baselines.config_class` names; the stages read the
params and hand the sections down.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.data.window_table import WindowArrays, load_windows
from pipeline.device import CPU, SCORING, TRAINING, describe, select_device
from pipeline.runners import baselines
from pipeline.runners.baselines.common import best_path, fit_result_from, load_checkpoint
from pipeline.harness.model_runs import score_rounds, split_to_score
from pipeline.harness.predictions import PredictionRounds
from pipeline.io import write_json
from pipeline.models import WindowSet, window_set
from pipeline.preemption import NEVER, Preemption

if TYPE_CHECKING:  # annotations only: a stage's code holds the sections it reads (code_graph)
    from pipeline.config.evaluate_baseline import EvaluateBaselineParams
    from pipeline.config.runtime import RuntimeParams
    from pipeline.config.train_baseline import TrainBaselineParams


def run_arguments(description: str, checkpoint_help: str) -> argparse.ArgumentParser:
    """The command line the stages of one trained baseline at one horizon share: --model (S-GAN or
    PECNet), --horizon, --table, --checkpoint-dir, --metrics; a stage adds its own."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--model", required=True, choices=baselines.TRAINABLE)
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help=checkpoint_help)
    parser.add_argument("--metrics", type=Path, required=True, help="JSON written")
    return parser


def train(model: str, arrays: WindowArrays, config, checkpoint_dir: Path, seed: int,
          device: torch.device = CPU, preemption: Preemption = NEVER) -> dict:
    """Fit `model` on the train split (selecting on val) on `device`; returns the training facts
    (the per-epoch history stays in the checkpoint's last.pt). Raises `StopRequested` (after a
    mid-epoch checkpoint) when `preemption` says so."""
    train_set = window_set(arrays, "train", with_future=True)
    val_set = window_set(arrays, "val", with_future=True)
    baseline = baselines.Baseline(model, config, device, preemption=preemption)
    baseline.fit(train_set, val_set, checkpoint_dir, seed)
    result = baseline.fit_result
    return {
        "n_train": len(train_set), "n_val": len(val_set), "epochs": result.epochs,
        "best_epoch": result.best_epoch, "best_val_ade": result.best_val_ade,
        "selected_epochs": result.selected, "train_seconds": result.train_seconds,
        "seconds_per_epoch": result.train_seconds / max(result.epochs, 1),
    }


@dataclass(frozen=True)
class BaselineTraining:
    """What training one baseline is configured by (stages `train_baseline`,
    `train_baseline_seed`), as the stage read it from params.yaml."""

    profile: str
    config: Any  # the model's config dataclass: `<model>.<profile>`
    train_baseline: TrainBaselineParams  # seed and threads
    n_past: int  # windows.n_past
    runtime: RuntimeParams


def train_record(model: str, horizon: int, table: Path, checkpoint_dir: Path,
                 training: BaselineTraining, seed: int | None = None) -> dict:
    """What the stages `train_baseline` (`seed` None: `train_baseline.seed`) and
    `train_baseline_seed` (an extra training seed) do: `train` on `table` under `training`.
    Returns the training facts with the settings they ran under (the layout of
    `metrics/baselines/train_<model>_tf<H>.json`); raises `StopRequested` as `train` does."""
    settings, config = training.train_baseline, training.config
    seed = settings.seed if seed is None else seed
    n_past, runtime = training.n_past, training.runtime
    torch.set_num_threads(settings.threads)
    device = select_device(runtime.device, purpose=TRAINING)
    print(f"train_baseline {model} t_f = {horizon}, seed {seed}: {describe(device)}", flush=True)
    arrays = load_windows(table, n_past, horizon)
    t0 = time.perf_counter()
    with Preemption(runtime.max_minutes) as preemption:
        facts = train(model, arrays, config, checkpoint_dir, seed, device, preemption)
    return {"model": model, "horizon": horizon, "profile": training.profile, "seed": seed,
            "threads": settings.threads, "device": describe(device),
            "wall_seconds": time.perf_counter() - t0, **facts}


def validation_curve(checkpoint_dir: Path) -> list[float]:
    """Validation ADE per epoch (px), as the folder's `last.pt` recorded it: the curve the kept
    epoch was selected on (its minimum is `best_val_ade`)."""
    return [float(epoch["val_ade"]) for epoch in fit_result_from(checkpoint_dir).history]


def training_seed(checkpoint_dir: Path) -> int:
    """The seed the model kept in `checkpoint_dir` was trained with (its `best.pt` records it)."""
    return int(load_checkpoint(best_path(checkpoint_dir))["meta"]["seed"])


def training_facts(model: str, checkpoint_dir: Path, selection: str = "raw") -> dict:
    """What the checkpoint records about its training: `best_epoch`
    and `best_val_ade` are those of the epoch selection rule `selection` scored (its validation
    ADE unsmoothed), `lowest_val_epoch` the epoch `raw` keeps."""
    result = fit_result_from(checkpoint_dir)
    kept = load_checkpoint(best_path(checkpoint_dir, selection))
    return {"train_seconds": result.train_seconds, "trained_epochs": result.epochs,
            "epoch_selection": selection, "best_epoch": kept["epoch"], "best_val_ade": kept["val_ade"],
            "lowest_val_epoch": result.best_epoch, "trained_horizon": kept["meta"]["n_future"]}


def ka_rows(baseline: baselines.Baseline, test: WindowSet, truth: np.ndarray, checkpoint_dir: Path,
            k_as: list[int], k_per_ka: int, rounds: int, seed: int) -> list[dict]:
    """One metrics row per K_a: best of K = k_per_ka x K_a samples (mean and std over rounds) of
    `baseline` as kept in `checkpoint_dir`, on the `test` windows (true futures `truth`)."""
    baseline.loaded(checkpoint_dir)  # before the clock, as for every scored model
    rows = []
    for k_a in k_as:
        scores = score_rounds(baseline.name, baseline, test, truth, checkpoint_dir, k_per_ka * k_a,
                              rounds, seed)
        scores.pop("per_round")
        rows.append({"k_a": k_a, **scores})
    return rows


def score_split(model: str, table: Path, horizon: int, checkpoint_dir: Path, n_past: int,
                params: EvaluateBaselineParams, device: torch.device = CPU
                ) -> tuple[dict, PredictionRounds]:
    """The metrics record of one baseline on split `params.split` of a window table (the layout of
    `metrics/baselines/<model>_tf<H>.json`) and every round's predictions, in original pixels."""
    baseline = baselines.Baseline(model, device=device, selection=params.epoch_selection)
    baseline.loaded(checkpoint_dir)
    test, truth = split_to_score(load_windows(table, n_past, horizon), params.split)
    if len(test) == 0:
        raise ValueError(f"{table}: no {params.split} windows")
    kept = PredictionRounds(test.window_id)
    scores = score_rounds(model, baseline, test, truth, checkpoint_dir, params.k, params.rounds,
                          params.seed, kept)
    return ({"model": model, "horizon": horizon, "split": params.split, "seed": params.seed,
             **scores, **training_facts(model, checkpoint_dir, params.epoch_selection)}, kept)


def score_to_file(model: str, table: Path, horizon: int, checkpoint_dir: Path, metrics: Path,
                  predictions: Path | None, evaluation: EvaluateBaselineParams, n_past: int,
                  runtime: RuntimeParams, extra: Mapping[str, Any] | None = None) -> None:
    """What the stages `evaluate_baseline`, `evaluate_rpecnet` and their extra-seed twins do:
    `score_split` under `evaluation` (section `evaluate_baseline`, its threads), `n_past`
    (`windows.n_past`) and `runtime.device`, written to `metrics` (with `extra`'s keys after the
    rest), and every round's test predictions written to `predictions` (no weights: these models
    give none; None: not kept, as for the extra training seeds)."""
    torch.set_num_threads(evaluation.threads)
    device = select_device(runtime.device, purpose=SCORING)
    print(f"evaluate_baseline {model} t_f = {horizon}: {describe(device)}", flush=True)
    scores, kept = score_split(model, table, horizon, checkpoint_dir, n_past, evaluation, device)
    if predictions is not None:
        kept.write(predictions, {
            "model": model, "benchmark": SDD_LONG_TERM.prediction_benchmark(table),
            "unit": SDD_LONG_TERM.unit,
            "split": evaluation.split, "k": evaluation.k, "horizon": horizon,
            "window_table": str(table),
            "checkpoint_dir": str(checkpoint_dir)})
    write_json({**scores, **(extra or {})}, metrics)
