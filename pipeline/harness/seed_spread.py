"""How far training alone moves the long-term baselines (stage `baseline_seed_spread`).

Every other "±" of the report is a spread over seeded *evaluation* rounds of one trained model. Here
each trained baseline (S-GAN and PECNet per horizon; R-PECNet through the t_f = 5 PECNet it rolls
out) was trained once per seed: `train_baseline.seed` (the main model) and `baseline_seeds.extra`,
and every model scored with the same split, K, rounds and round seeds. A seed's value is its mean
over those rounds; the spread over seeds is `pipeline.harness.metrics.summarize_rounds` applied to
the seeds (population std, the definition of the round spread, so the two compare directly).

Files read, under the metrics folder:
- main seed: `baselines/<model>_tf<H>.json` (`evaluate_baseline` / `evaluate_rpecnet`) and its
  training seed from `baselines/train_<trained model>_tf<trained H>.json` (`train_baseline`);
- extra seed s: `baselines/seeds/<model>_tf<H>_seed<s>.json` (`evaluate_baseline_seed` /
  `evaluate_rpecnet_seed`, with `training_seed`).
Each holds the kept epoch (`best_epoch`) and its validation ADE (`best_val_ade`, the minimum of the
validation curve); the extra seeds' full curves are in `baselines/seeds/train_*.json`.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pipeline.harness.metrics import METRIC_KEYS, summarize_rounds
from pipeline.io import IntermediateError, index_value, read_json_index

MODELS = ("sgan", "pecnet", "rpecnet")  # every trained long-term baseline
TRAINED_AS = {"rpecnet": "pecnet"}  # R-PECNet is the t_f = 5 PECNet rolled out
# What must be equal between the seeds' records for only training to differ.
EVALUATION_KEYS = (("split", str), ("k", int), ("rounds", int), ("seed", int), ("n_windows", int))
TRAINING_KEYS = (("best_epoch", int), ("best_val_ade", float), ("trained_epochs", int),
                 ("trained_horizon", int))


def main_record_path(folder: Path, model: str, horizon: int) -> Path:
    return Path(folder) / "baselines" / f"{model}_tf{horizon}.json"


def seed_record_path(folder: Path, model: str, horizon: int, seed: int) -> Path:
    return Path(folder) / "baselines" / "seeds" / f"{model}_tf{horizon}_seed{seed}.json"


def seed_entry(record: Mapping[str, Any], path: Path) -> dict[str, Any]:
    """One seed's values: each metric's mean over the evaluation rounds, the ADE / FDE spread over
    those rounds, and the kept epoch with its validation ADE (checked, the file named)."""
    metrics = {key: index_value(index_value(record, key, dict, path), "mean", float, path, f"{key}.")
               for key in METRIC_KEYS}
    round_std = {key: index_value(record[key], "std", float, path, f"{key}.") for key in ("ade", "fde")}
    training = {key: index_value(record, key, kind, path) for key, kind in TRAINING_KEYS}
    return {**metrics, "round_std": round_std, **training}


def evaluation_of(record: Mapping[str, Any], path: Path) -> dict[str, Any]:
    return {key: index_value(record, key, kind, path) for key, kind in EVALUATION_KEYS}


def spread_entry(model: str, horizon: int, seeds: Mapping[int, tuple[Mapping[str, Any], Path]],
                 main_seed: int) -> dict[str, Any]:
    """The spread over training seeds of one model at one horizon.

    seeds: training seed -> (its metrics record, the file it came from), the main seed included.
    Fails (naming both files) unless every record was scored alike (`EVALUATION_KEYS`)."""
    main_record, main_path = seeds[main_seed]
    evaluation = evaluation_of(main_record, main_path)
    for seed, (record, path) in seeds.items():
        if evaluation_of(record, path) != evaluation:
            raise IntermediateError(f"{path}: scored with {evaluation_of(record, path)}, but {main_path} "
                                    f"with {evaluation}: the seeds must differ only in training")
    per_seed = [{"seed": seed, **seed_entry(record, path)} for seed, (record, path) in sorted(seeds.items())]
    main = next(entry for entry in per_seed if entry["seed"] == main_seed)
    return {"model": model, "horizon": horizon, "seeds": [e["seed"] for e in per_seed],
            "main_seed": main_seed, "evaluation": evaluation,
            "over_training_seeds": summarize_rounds([{k: e[k] for k in METRIC_KEYS} for e in per_seed]),
            "main_round_std": main["round_std"], "per_seed": per_seed}


def main_seed_of(folder: Path, model: str, record: Mapping[str, Any], path: Path) -> tuple[int, Path]:
    """The training seed of a main model, from its `train_baseline` facts (R-PECNet: its PECNet's)."""
    trained = TRAINED_AS.get(model, model)
    train_path = Path(folder) / "baselines" / f"train_{trained}_tf{index_value(record, 'trained_horizon', int, path)}.json"
    return index_value(read_json_index(train_path), "seed", int, train_path), train_path


def read_seeds(folder: Path, model: str, horizon: int, extra: list[int]
               ) -> tuple[dict[int, tuple[dict, Path]], int]:
    """Every seed's record of `model` at `horizon` and the main seed; fails naming the file that is
    missing, malformed, of another training seed, or whose main seed is also an extra one."""
    path = main_record_path(folder, model, horizon)
    record = read_json_index(path)
    main_seed, train_path = main_seed_of(folder, model, record, path)
    if main_seed in extra:
        raise IntermediateError(f"{train_path}: the main model's seed {main_seed} is also in "
                                f"baseline_seeds.extra {extra}: it would be counted twice")
    seeds = {main_seed: (record, path)}
    for seed in extra:
        seed_path = seed_record_path(folder, model, horizon, seed)
        seed_record = read_json_index(seed_path)
        found = index_value(seed_record, "training_seed", int, seed_path)
        if found != seed:
            raise IntermediateError(f"{seed_path}: model trained with seed {found}, expected {seed}")
        seeds[seed] = (seed_record, seed_path)
    return seeds, main_seed


def seed_spread(folder: Path, horizons: list[int], extra: list[int]) -> dict[str, Any]:
    """The record of `metrics/baseline_seed_spread.json`: {"models", "horizons", "extra_seeds",
    "std": how the spreads are computed, "entries": [`spread_entry` per model and horizon]}."""
    entries = []
    for model in MODELS:
        for horizon in horizons:
            seeds, main_seed = read_seeds(folder, model, horizon, extra)
            entries.append(spread_entry(model, horizon, seeds, main_seed))
    return {"models": list(MODELS), "horizons": list(horizons), "extra_seeds": list(extra),
            "std": "population std (ddof 0), over training seeds and over evaluation rounds alike",
            "entries": entries}
