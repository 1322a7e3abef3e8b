"""Upstream PECNet's test-set epoch selection on a short-term benchmark (stage
`short_term_pecnet_test_selection@<fold>`): a labelled compat diagnostic, never a headline number.

The PECNet paper's ETH/UCY numbers (quoted in the Y-net paper's Table 2) come from a training loop
that scores the TEST set after every epoch and reports the lowest test ADE (of the sample with the
best endpoint) and, separately, the lowest test FDE over its epochs. Here PECNet is retrained
exactly as `train_short_term_baseline@<fold>-pecnet` trains it (the benchmark's unit and settings,
`pipeline.runners.short_term_baselines`; the seeded validation sample; the training seed; a
scratch folder), and after every epoch the test windows are sampled once with the K and the seed
of the headline's first scoring round (`evaluate_short_term_baseline`: K = the benchmark's first
K, seed `short_term_models.<profile>.seed`). The epoch kept on validation therefore scores exactly
what the headline's first round scores, which the record checks beside the training itself.

A compat switch: it runs only on the folds of `short_term_pecnet_test_selection.folds`
(`switched_off_record` elsewhere), since sampling a large fold's test set after every epoch costs
more than its training.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import torch

from pipeline.benchmarks.registry import short_term
from pipeline.device import CPU, describe
from pipeline.model_list import PECNET
from pipeline.studies.pecnet_test_selection import (LABEL, PROTOCOLS, compat_summary,
                                                    retrain_scoring_splits)
from pipeline.runners.short_term import sample_windows
from pipeline.runners.short_term_baselines import BaselineOverrides, baseline_config

if TYPE_CHECKING:  # annotations only: a stage's code holds the sections it reads (code_graph)
    from pipeline.config.pecnet import PecnetConfig
    from pipeline.config.short_term import ShortTermParams
    from pipeline.config.short_term_models import ShortTermModelsParams
    from pipeline.config.short_term_pecnet_test_selection import ShortTermPecnetTestSelectionParams
    from pipeline.config.train_baseline import TrainBaselineParams

MODEL = PECNET
SWITCH = "short_term_pecnet_test_selection"
SELECTION = "raw"  # the epoch `evaluate_short_term_baseline` scores: best.pt, the lowest val ADE


@dataclass(frozen=True)
class RetrainSettings:
    """What the retrain is configured by: the headline's training of PECNet on a short-term
    benchmark, as the stage read it from params.yaml."""

    profile: str
    short_term_models: ShortTermModelsParams  # of the active profile: epochs, K, val windows, seed
    short_term: ShortTermParams  # the windows' shape
    train_baseline: TrainBaselineParams  # seed and threads
    pecnet: PecnetConfig  # pecnet.<profile>, before the benchmark's epochs and overrides
    overrides: BaselineOverrides


def switched_on(dataset: str, switch: ShortTermPecnetTestSelectionParams) -> bool:
    """Whether the switch lists `dataset` (`short_term_pecnet_test_selection.folds`)."""
    return dataset in switch.folds


def switched_off_record(dataset: str, profile: str) -> dict:
    """What the stage writes for a fold the switch does not list (the report then names no
    compat number for it)."""
    return {"diagnostic": LABEL, "model": MODEL, "dataset": dataset, "profile": profile,
            "not_run_reason": f"compat switch off for {dataset} ({SWITCH}.folds in params.yaml)"}


def headline_facts(training_facts: Path, run_metrics: Path) -> dict[str, Any]:
    """What the headline stages recorded: the kept epoch and its validation ADE
    (`metrics/short_term/train/<fold>_pecnet.json`) and the first scoring round's test ADE / FDE
    at the benchmark's first K (`metrics/short_term/runs/<fold>_pecnet.json`); a ValueError names
    the file that lacks them."""
    try:
        train = json.loads(Path(training_facts).read_text())["train"]
        kept = {"best_epoch": int(train["best_epoch"]), "best_val_ade": float(train["best_val_ade_px"])}
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{training_facts}: no train.best_epoch / best_val_ade_px ({e})") from e
    try:
        run = json.loads(Path(run_metrics).read_text())
        first_k = run[f"k{run['ks'][0]}"]
        first_round = first_k["per_round"][0]
        scored = {"k": int(run["ks"][0]), "ade": float(first_round["ade"]),
                  "fde": float(first_round["fde"])}
    except (OSError, ValueError, KeyError, TypeError, IndexError) as e:
        raise ValueError(f"{run_metrics}: no first round's test ADE / FDE ({e})") from e
    return {**kept, "first_round": scored}


def fold_record(dataset: str, retrain: RetrainSettings, windows: Path, training_facts: Path,
                run_metrics: Path, scratch: Path, device: torch.device = CPU) -> dict:
    """One benchmark's diagnostic: PECNet retrained in the fresh folder `scratch` as the headline
    trains it on `dataset`, its per-epoch validation and test scores, `compat_summary`, and whether
    the retrain reproduced the headline's epoch and its first round's test scores."""
    if Path(scratch).exists():
        raise ValueError(f"{scratch}: exists; the retrain needs a fresh folder (no resume)")
    headline = headline_facts(training_facts, run_metrics)  # read first: a bad file fails early
    settings, shape, training = retrain.short_term_models, retrain.short_term, retrain.train_baseline
    benchmark = short_term(dataset)
    k = benchmark.ks(settings)[0]
    config = baseline_config(MODEL, dataset, retrain.pecnet, retrain.overrides,
                             benchmark.epochs(settings, MODEL))
    bench = benchmark.load_in_unit(windows, shape.n_past, shape.n_future)
    val = sample_windows(bench.val, settings.val_windows, settings.seed)
    t0 = time.perf_counter()
    timed, fitted = retrain_scoring_splits(bench.train, val, bench.test, config, training.seed, k,
                                           settings.seed, Path(scratch), device)
    result = fitted.fit_result
    epochs = [{key: value for key, value in entry.items() if key != "test_seconds"}
              for entry in timed]
    summary = compat_summary(epochs, SELECTION)
    kept_test = summary["validation_selected"]["test"]["headline"]
    return {
        "diagnostic": LABEL, "model": MODEL, "dataset": dataset, "profile": retrain.profile,
        "unit": bench.unit, "device": describe(device), "seed": training.seed,
        "threads": training.threads, "k": k, "test_seed": settings.seed,
        "protocols": dict(PROTOCOLS),
        "n_train": len(bench.train), "n_val": len(val), "n_test": len(bench.test),
        "epochs": result.epochs, "train_seconds": result.train_seconds,
        "test_seconds": sum(entry["test_seconds"] for entry in timed),
        "wall_seconds": time.perf_counter() - t0,
        "training_reproduced": {
            "headline": headline,
            "retrain": {"best_epoch": result.best_epoch, "best_val_ade": result.best_val_ade,
                        "first_round": {"k": k, **kept_test}},
            "same": (headline["best_epoch"] == result.best_epoch
                     and headline["best_val_ade"] == result.best_val_ade
                     and headline["first_round"] == {"k": k, **kept_test})},
        **summary,
        "per_epoch": epochs,
    }
