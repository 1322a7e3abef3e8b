"""A labelled compat diagnostic, never a headline number: how far upstream PECNet's test-set epoch
selection moves its scores (stages `pecnet_test_selection`, long-term, and
`short_term_pecnet_test_selection`, ETH/UCY: `pipeline.studies.short_term_test_selection`).

Upstream's training loop scores the TEST set after every epoch and reports the lowest test ADE and,
separately, the lowest test FDE seen over all epochs (each possibly from a different epoch). Our
headline scores the epoch kept on validation (`train_baseline` / `evaluate_baseline`). Here PECNet
is retrained exactly as `train_baseline@pecnet-<t_f>` trains it (`baseline_runs.train_record`'s
settings: `pecnet.<profile>`, `train_baseline.seed` and threads, `windows.n_past`,
`runtime.device`; another folder), and after every epoch (`Pecnet.fit`'s `after_epoch`) the test
windows are sampled once, K samples with the same seed every epoch, and scored two ways
(`PROTOCOLS`):

- `headline`: ours, min over K of ADE and, independently, of FDE per window
  (`scoring.min_ade_fde`, the metric of every metrics file);
- `pecnet`: upstream's test code, the ADE of the sample with the best endpoint
  (`scoring.best_endpoint_ade`) and min FDE (the same FDE as `headline`'s).

`compat_summary` turns the per-epoch record into the epoch kept on validation (by the rule
`evaluate_baseline.epoch_selection` scores) with its test numbers, and upstream's numbers: per
protocol the lowest test ADE and the lowest test FDE over epochs, each with its epoch. Epochs are
0-based, as `metrics/baselines/train_<model>_tf<H>.json`'s `best_epoch`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TYPE_CHECKING

import numpy as np
import torch

from pipeline.data.window_table import WindowArrays, load_windows
from pipeline.device import CPU, TRAINING, describe, select_device
from pipeline.device import generator as seeded_generator
from pipeline.harness import epoch_selection
from pipeline.data.window_table import select_split
from pipeline.model_list import PECNET
from pipeline.runners.baselines.pecnet import Pecnet
from pipeline.harness.scoring import best_endpoint_ade, min_ade_fde

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.pecnet import PecnetConfig
    from pipeline.config.pecnet_test_selection import PecnetTestSelectionParams
    from pipeline.config.runtime import RuntimeParams
    from pipeline.config.train_baseline import TrainBaselineParams

PROTOCOLS = {
    "headline": "ours: min over K of ADE and, independently, min over K of FDE per window",
    PECNET: "upstream PECNet's test code: ADE of the sample with the best endpoint; min FDE",
}
METRICS = ("ade", "fde")
LABEL = ("compat diagnostic: upstream selects epochs on the TEST set (best test ADE and best test "
         "FDE over epochs, each its own epoch); never a headline number, which keeps the epoch "
         "chosen on validation")


@dataclass(frozen=True)
class DiagnosticSettings:
    """What the long-term diagnostic is configured by, as stage `pecnet_test_selection` read it
    from params.yaml: its own section and the headline training it repeats."""

    profile: str
    diagnostic: PecnetTestSelectionParams  # horizons, K and test seed
    pecnet: PecnetConfig  # pecnet.<profile>
    train_baseline: TrainBaselineParams  # seed and threads
    epoch_selection: str  # evaluate_baseline.epoch_selection: the rule the headline scores
    n_past: int  # windows.n_past
    runtime: RuntimeParams


def epoch_test_scores(pred: Any, truth: Any) -> dict[str, dict[str, float]]:
    """{protocol: {"ade", "fde"}}: means over windows of one sampling `pred` (N, K, n_f, 2) of
    `truth` (N, n_f, 2), in their unit (pixels, metres), under each of `PROTOCOLS`."""
    independent = min_ade_fde(pred, truth)  # (N,) each
    fde = float(independent["fde"].mean())
    return {"headline": {"ade": float(independent["ade"].mean()), "fde": fde},
            PECNET: {"ade": float(best_endpoint_ade(pred, truth).mean()), "fde": fde}}


def summary_line(kept: Mapping[str, Any], compat: Mapping[str, Any], protocol: str,
                 decimals: int = 2, unit: str = "") -> str:
    """One protocol's line of a stage's log: the epoch kept on validation with its test ADE / FDE,
    then upstream's selection on test (`compat_summary`'s parts)."""
    best_ade, best_fde = compat[protocol]["best_ade"], compat[protocol]["best_fde"]
    unit = f" {unit}" if unit else ""
    return (f"{protocol}: epoch {kept['epoch']} kept on val: {kept['test'][protocol]['ade']:.{decimals}f}"
            f" / {kept['test'][protocol]['fde']:.{decimals}f}{unit}; compat (selected on test): ADE "
            f"{best_ade['value']:.{decimals}f} @ {best_ade['epoch']}, FDE "
            f"{best_fde['value']:.{decimals}f} @ {best_fde['epoch']}")


def check_epochs(epochs: Sequence[Mapping[str, Any]]) -> None:
    """Fail unless `epochs` is the record of epochs 0, 1, ... with a validation ADE and every
    protocol's test ADE and FDE."""
    if not epochs:
        raise ValueError("no epochs to summarise")
    for i, entry in enumerate(epochs):
        if entry.get("epoch") != i:
            raise ValueError(f"epoch record {i} is epoch {entry.get('epoch')!r}: expected 0, 1, ... in order")
        missing = [f"{p}.{m}" for p in PROTOCOLS for m in METRICS
                   if m not in (entry.get("test") or {}).get(p, {})]
        if "val_ade" not in entry or missing:
            raise ValueError(f"epoch {i}: missing {['val_ade'] * ('val_ade' not in entry) + missing}")


def lowest_over_epochs(epochs: Sequence[Mapping[str, Any]], protocol: str, metric: str) -> dict:
    """{"value", "epoch"}: the lowest test `metric` under `protocol` over epochs, the first on
    ties."""
    values = np.array([entry["test"][protocol][metric] for entry in epochs], dtype=float)
    epoch = int(np.argmin(values))
    return {"value": float(values[epoch]), "epoch": epoch}


def compat_summary(epochs: Sequence[Mapping[str, Any]], selection: str = "raw") -> dict:
    """What the per-epoch record says (`epochs`: [{"epoch", "val_ade", "test": {protocol: {"ade",
    "fde"}}}], epoch 0 first).

    Returns {"validation_selected": {"rule", "epoch", "val_ade", "test"}: the epoch the rule
    `selection` keeps on the validation curve (what the headline scores) and its test scores;
    "compat": {protocol: {"best_ade": {"value", "epoch"}, "best_fde": {...}}}: upstream's
    selection on test; "compat_minus_validation_selected": {protocol: {"ade", "fde"}}: how far
    selecting on test lowers each (<= 0)}."""
    check_epochs(epochs)
    curve = np.array([entry["val_ade"] for entry in epochs], dtype=float)
    kept = epochs[epoch_selection.selected_epoch(curve, selection)]
    compat = {protocol: {f"best_{metric}": lowest_over_epochs(epochs, protocol, metric)
                         for metric in METRICS} for protocol in PROTOCOLS}
    return {
        "validation_selected": {"rule": selection, "epoch": int(kept["epoch"]),
                                "val_ade": float(kept["val_ade"]), "test": kept["test"]},
        "compat": compat,
        "compat_minus_validation_selected": {
            protocol: {metric: compat[protocol][f"best_{metric}"]["value"] - kept["test"][protocol][metric]
                       for metric in METRICS} for protocol in PROTOCOLS},
    }


def retrain_scoring_test(arrays: WindowArrays, config: PecnetConfig, seed: int, k: int,
                         test_seed: int, checkpoint_dir: Path, device: torch.device = CPU
                         ) -> tuple[list[dict], Pecnet]:
    """`retrain_scoring_splits` on `arrays`' train, val and test splits, as `baseline_runs.train`
    fits PECNet on a long-term window table."""
    return retrain_scoring_splits(*(select_split(arrays, split) for split in ("train", "val", "test")),
                                  config, seed, k, test_seed, checkpoint_dir, device)


def retrain_scoring_splits(train_set: WindowArrays, val_set: WindowArrays, test_set: WindowArrays,
                           config: PecnetConfig, seed: int, k: int, test_seed: int,
                           checkpoint_dir: Path, device: torch.device = CPU
                           ) -> tuple[list[dict], Pecnet]:
    """PECNet fitted on `train_set` (epochs kept on `val_set`), `test_set` scored after every
    epoch (best of `k`, a generator seeded with `test_seed` each time), in the windows' own unit.
    Returns the per-epoch record (`compat_summary`'s input, with the test sampling's seconds) and
    the fitted model (its `fit_result`)."""
    if len(test_set) == 0:
        raise ValueError("no test windows to score")
    scores: dict[int, dict] = {}

    def score_test(model: Pecnet, epoch: int) -> None:
        t0 = time.perf_counter()
        pred = model.predict(test_set, k, seeded_generator(device, test_seed))  # (N, k, n_f, 2)
        scores[epoch] = {"test": epoch_test_scores(pred, test_set.future),
                         "test_seconds": time.perf_counter() - t0}

    fitted = Pecnet.fit(train_set, val_set, config, checkpoint_dir, seed, device=device,
                        after_epoch=score_test)
    history = fitted.fit_result.history
    missing = [entry["epoch"] for entry in history if entry["epoch"] not in scores]
    if missing:  # only a resumed folder could skip epochs: the caller gives a fresh one
        raise ValueError(f"{checkpoint_dir}: epochs {missing} trained before this run, not scored on test")
    return [{"epoch": entry["epoch"], "val_ade": entry["val_ade"], **scores[entry["epoch"]]}
            for entry in history], fitted


def headline_training(path: Path) -> dict:
    """`best_epoch` and `best_val_ade` of a `train_baseline` facts file
    (`metrics/baselines/train_pecnet_tf<H>.json`), or a ValueError naming the file."""
    try:
        facts = json.loads(Path(path).read_text())
        return {"best_epoch": int(facts["best_epoch"]), "best_val_ade": float(facts["best_val_ade"])}
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{path}: no train_baseline best_epoch / best_val_ade ({e})") from e


def horizon_record(horizon: int, table: Path, training_facts: Path, settings: DiagnosticSettings,
                   scratch: Path, device: torch.device = CPU) -> dict:
    """One horizon's diagnostic: the retrain on `table` in the fresh folder `scratch`, its
    per-epoch validation and test scores, `compat_summary` under `evaluate_baseline.epoch_selection`,
    and whether its validation selection is `train_baseline`'s (`training_facts`)."""
    diagnostic, seed = settings.diagnostic, settings.train_baseline.seed
    selection = settings.epoch_selection
    headline = headline_training(training_facts)  # read first: a bad file fails before training
    arrays = load_windows(table, settings.n_past, horizon)
    timed, fitted = retrain_scoring_test(arrays, settings.pecnet, seed, diagnostic.k,
                                         diagnostic.seed, scratch, device)
    result = fitted.fit_result
    epochs = [{key: value for key, value in entry.items() if key != "test_seconds"} for entry in timed]
    summary = compat_summary(epochs, selection)
    return {
        "horizon": horizon, "n_train": int((arrays.split == "train").sum()),
        "n_val": int((arrays.split == "val").sum()), "n_test": int((arrays.split == "test").sum()),
        "epochs": result.epochs, "train_seconds": result.train_seconds,
        "test_seconds": sum(entry["test_seconds"] for entry in timed),
        "training_reproduced": {
            "train_baseline": headline, "retrain": {"best_epoch": result.best_epoch,
                                                    "best_val_ade": result.best_val_ade},
            "same": (headline["best_epoch"] == result.best_epoch
                     and headline["best_val_ade"] == result.best_val_ade)},
        **summary,
        "per_epoch": epochs,
    }


def by_horizon(paths: Sequence[Path], prefix: str, horizons: Sequence[int], what: str) -> dict[int, Path]:
    """{t_f: path} of files named `<prefix><t_f>.<ext>` (`tf30.parquet`, `train_pecnet_tf30.json`),
    one for each of `horizons` and no other: a ValueError names what is missing or extra."""
    found: dict[int, Path] = {}
    for path in map(Path, paths):
        tail = path.stem.removeprefix(prefix)
        if not path.stem.startswith(prefix) or not tail.isdigit() or int(tail) in found:
            raise ValueError(f"{path}: not one {what} named {prefix}<t_f>{path.suffix}")
        found[int(tail)] = path
    if sorted(found) != sorted(horizons):
        raise ValueError(f"{what}s given for t_f {sorted(found)}, pecnet_test_selection.horizons is "
                         f"{sorted(horizons)} (dvc.yaml's cmd and deps must list each horizon)")
    return found


def diagnose(settings: DiagnosticSettings, tables: Sequence[Path], training_facts: Sequence[Path],
             scratch: Path) -> dict:
    """The stage's record: every horizon of `pecnet_test_selection.horizons`, each with its window
    table (`tables`: `tf<H>.parquet`) and headline training facts (`training_facts`:
    `train_pecnet_tf<H>.json`), checkpoints in `scratch/pecnet_tf<H>` (which must not exist yet),
    under `settings`, on `train_baseline.threads` threads."""
    diagnostic = settings.diagnostic
    table_of = by_horizon(tables, "tf", diagnostic.horizons, "window table")
    facts_of = by_horizon(training_facts, "train_pecnet_tf", diagnostic.horizons, "training facts file")
    training, runtime = settings.train_baseline, settings.runtime
    torch.set_num_threads(training.threads)
    device = select_device(runtime.device, purpose=TRAINING)
    t0 = time.perf_counter()
    per_horizon = {}
    for horizon in diagnostic.horizons:
        folder = Path(scratch) / f"pecnet_tf{horizon}"
        if folder.exists():
            raise ValueError(f"{folder}: exists; the retrain needs a fresh folder (no resume)")
        print(f"pecnet_test_selection t_f = {horizon}: {describe(device)}", flush=True)
        per_horizon[f"tf{horizon}"] = horizon_record(horizon, table_of[horizon], facts_of[horizon],
                                                     settings, folder, device)
    return {"diagnostic": LABEL, "model": PECNET, "profile": settings.profile,
            "seed": training.seed, "threads": training.threads, "device": describe(device),
            "k": diagnostic.k, "test_seed": diagnostic.seed, "protocols": dict(PROTOCOLS),
            "per_horizon": per_horizon, "wall_seconds": time.perf_counter() - t0}
