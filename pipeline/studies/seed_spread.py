"""How far training alone moves the long-term models (stage `baseline_seed_spread`).

Every other "±" of the report is a spread over seeded *evaluation* rounds of one trained model. Here
each trained baseline (S-GAN and PECNet per horizon; R-PECNet through the t_f = 5 PECNet it rolls
out) was trained once per seed: `train_baseline.seed` (the main model) and `baseline_seeds.extra`,
and every model scored with the same split, K, rounds and round seeds. Likewise the main Y-net
(t_f = 30, the release windows): `ynet.<profile>.seed` and `ynet_seeds.<profile>.seeds`, each
scored in `evaluate_ynet`'s main setting; a profile that trains no extra Y-net seed gives a row
that says why (`ynet_entry`). A seed's value is its mean over the evaluation rounds; the spread
over seeds is `pipeline.harness.metrics.summarize_rounds` applied to the seeds (population std, the
definition of the round spread, so the two compare directly).

Files read, under the metrics folder:
- main seed: `baselines/<model>_tf<H>.json` (`evaluate_baseline` / `evaluate_rpecnet`) and its
  training seed from `baselines/train_<trained model>_tf<trained H>.json` (`train_baseline`);
- extra seed s: `baselines/seeds/<model>_tf<H>_seed<s>.json` (`evaluate_baseline_seed` /
  `evaluate_rpecnet_seed`, with `training_seed`).
Each holds the kept epoch (`best_epoch`) and its validation ADE (`best_val_ade`, the minimum of the
validation curve); the extra seeds' full curves are in `baselines/seeds/train_*.json`. Y-net:
- main seed: `ynet_eval.json` (`evaluate_ynet`: "main") and `ynet_train.json` (`train_ynet`: kept
  epoch, its validation ADE, epochs);
- extra seed s: `ynet_seeds/seed<s>.json` (`evaluate_ynet_seed`: "main" in the same layout, the
  training facts and `training_seed`), for every slot of `ynet_seeds.slots`: a slot the profile does
  not train holds the not-run record, one it trains a scored model.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TYPE_CHECKING

from pipeline.harness.metrics import METRIC_KEYS, summarize_rounds
from pipeline.io import IntermediateError, index_value, read_json_index
from pipeline.model_list import BY_NAME, SEEDED_BASELINES, YNET

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.ynet_seeds import YnetSeedsParams

MODELS = SEEDED_BASELINES  # every trained long-term baseline (S-GAN, PECNet, R-PECNet)
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


def evaluation_of(record: Mapping[str, Any], path: Path,
                  keys: tuple[tuple[str, Any], ...] = EVALUATION_KEYS) -> dict[str, Any]:
    return {key: index_value(record, key, kind, path) for key, kind in keys}


def spread_entry(model: str, horizon: int, seeds: Mapping[int, tuple[Mapping[str, Any], Path]],
                 main_seed: int, evaluation_keys: tuple[tuple[str, Any], ...] = EVALUATION_KEYS
                 ) -> dict[str, Any]:
    """The spread over training seeds of one model at one horizon.

    seeds: training seed -> (its metrics record, the file it came from), the main seed included.
    Fails (naming both files) unless every record was scored alike (`evaluation_keys`)."""
    main_record, main_path = seeds[main_seed]
    evaluation = evaluation_of(main_record, main_path, evaluation_keys)
    for seed, (record, path) in seeds.items():
        found = evaluation_of(record, path, evaluation_keys)
        if found != evaluation:
            raise IntermediateError(f"{path}: scored with {found}, but {main_path} "
                                    f"with {evaluation}: the seeds must differ only in training")
    per_seed = [{"seed": seed, **seed_entry(record, path)} for seed, (record, path) in sorted(seeds.items())]
    main = next(entry for entry in per_seed if entry["seed"] == main_seed)
    return {"model": model, "horizon": horizon, "seeds": [e["seed"] for e in per_seed],
            "main_seed": main_seed, "evaluation": evaluation,
            "over_training_seeds": summarize_rounds([{k: e[k] for k in METRIC_KEYS} for e in per_seed]),
            "main_round_std": main["round_std"], "per_seed": per_seed}


def main_seed_of(folder: Path, model: str, record: Mapping[str, Any], path: Path) -> tuple[int, Path]:
    """The training seed of a main model, from its `train_baseline` facts (R-PECNet: its PECNet's)."""
    trained = BY_NAME[model].trained_as or model  # R-PECNet: the t_f = 5 PECNet
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


# ---------------------------------------------------------------------------------------------
# Y-net: the main model (t_f = 30, release windows) and ynet_seeds.<profile>.seeds


YNET_HORIZON = 30
"""The main Y-net's t_f (the release's windows)."""
YNET_EVALUATION_KEYS = (("t_f", int), ("n_windows", int), ("rounds", int), ("k_e", int), ("k_a", int))
"""What must be equal between Y-net's seeds' records (TTST / CWS settings: stage params `ttst`, `cws`)."""


@dataclass(frozen=True)
class YnetSeeds:
    """What the Y-net row reads from params.yaml: the active profile, the main model's training
    seed (`ynet.<profile>.seed`), the stages' slots (`ynet_seeds.slots`) and the profile's extra
    seeds (`ynet_seeds.<profile>`)."""
    profile: str
    main_seed: int
    slots: list[int]
    params: YnetSeedsParams


def ynet_main_paths(folder: Path) -> tuple[Path, Path]:
    """(`evaluate_ynet`'s metrics, `train_ynet`'s training facts) of the main Y-net."""
    return Path(folder) / "ynet_eval.json", Path(folder) / "ynet_train.json"


def ynet_seed_path(folder: Path, seed: int) -> Path:
    return Path(folder) / "ynet_seeds" / f"seed{seed}.json"


def ynet_flat(record: Mapping[str, Any], path: Path, training: Mapping[str, Any],
              training_path: Path) -> dict[str, Any]:
    """A Y-net record in the layout `spread_entry` reads: the main setting's summaries at the top,
    its evaluation (`YNET_EVALUATION_KEYS`) and the training facts (`TRAINING_KEYS`), each value
    checked in the file it comes from."""
    main = index_value(record, "main", dict, path)
    flat = {key: index_value(main, key, dict, path, "main.") for key in METRIC_KEYS}
    t_f = index_value(record, "t_f", int, path)
    flat.update(t_f=t_f, n_windows=index_value(record, "n_windows", int, path),
                rounds=index_value(record, "rounds", int, path),
                k_e=index_value(main, "k_e", int, path, "main."),
                k_a=index_value(main, "k_a", int, path, "main."),
                best_epoch=index_value(training, "best_epoch", int, training_path),
                best_val_ade=index_value(training, "best_val_ade", float, training_path),
                trained_epochs=index_value(training, "epochs", int, training_path),
                trained_horizon=t_f)
    return flat


def read_ynet_seeds(folder: Path, spec: YnetSeeds) -> dict[int, tuple[dict, Path]]:
    """The main Y-net's record and each trained extra seed's (seed -> (flat record, its file)).
    Fails naming the file that is missing or malformed, of another training seed, trained though the
    profile does not list its slot or not trained though it does; or naming the params when the
    profile lists a seed that has no slot or is the main model's."""
    where = f"params.yaml:ynet_seeds.{spec.profile}.seeds {spec.params.seeds}"
    if spec.main_seed in spec.params.seeds:
        raise IntermediateError(f"{where}: holds ynet.{spec.profile}.seed {spec.main_seed}, the main "
                                f"model's: it would be counted twice")
    unslotted = [seed for seed in spec.params.seeds if seed not in spec.slots]
    if unslotted:
        raise IntermediateError(f"{where}: seeds {unslotted} are not in ynet_seeds.slots "
                                f"{spec.slots}, so no stage trains them")
    eval_path, train_path = ynet_main_paths(folder)
    seeds = {spec.main_seed: (ynet_flat(read_json_index(eval_path), eval_path,
                                        read_json_index(train_path), train_path), eval_path)}
    for slot in spec.slots:
        path = ynet_seed_path(folder, slot)
        record = read_json_index(path)
        trained = index_value(record, "trained", bool, path)
        if trained != (slot in spec.params.seeds):
            state = "trained" if trained else "not trained"
            raise IntermediateError(f"{path}: {state}, but {where} "
                                    f"{'does not list' if trained else 'lists'} seed {slot}")
        if not trained:
            continue
        found = index_value(record, "training_seed", int, path)
        if found != slot:
            raise IntermediateError(f"{path}: model trained with seed {found}, expected {slot}")
        seeds[slot] = (ynet_flat(record, path, record, path), path)
    return seeds


def ynet_entry(folder: Path, spec: YnetSeeds) -> dict[str, Any]:
    """Y-net's row: `spread_entry` over the main seed and the profile's extra seeds. When the
    profile trains none (its slots' records checked to say "not trained"), the main model's part of
    it (seeds, evaluation, main_round_std, per_seed) with "not_run_reason" in place of
    "over_training_seeds"."""
    seeds = read_ynet_seeds(folder, spec)
    entry = spread_entry(YNET, YNET_HORIZON, seeds, spec.main_seed, YNET_EVALUATION_KEYS)
    if spec.params.seeds:
        return entry
    del entry["over_training_seeds"]  # one seed: no spread over training seeds
    return {**entry, "not_run_reason": spec.params.not_run_reason(spec.profile)}


def seed_spread(folder: Path, horizons: list[int], extra: list[int],
                ynet: YnetSeeds | None = None) -> dict[str, Any]:
    """The record of `metrics/baseline_seed_spread.json`: {"models", "horizons", "extra_seeds",
    "std": how the spreads are computed, "entries": [Y-net's entry (`ynet_entry`, when `ynet` is
    given) first, then `spread_entry` per baseline and horizon]}, and with `ynet` also
    "ynet_extra_seeds" (the profile's) and "profile"."""
    entries = [] if ynet is None else [ynet_entry(folder, ynet)]
    for model in MODELS:
        for horizon in horizons:
            seeds, main_seed = read_seeds(folder, model, horizon, extra)
            entries.append(spread_entry(model, horizon, seeds, main_seed))
    record = {"models": ([YNET] if ynet is not None else []) + list(MODELS),
              "horizons": list(horizons), "extra_seeds": list(extra)}
    if ynet is not None:
        record.update(profile=ynet.profile, ynet_extra_seeds=list(ynet.params.seeds))
    return {**record, "std": "population std (ddof 0), over training seeds and over evaluation rounds alike",
            "entries": entries}
