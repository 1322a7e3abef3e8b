"""The table "Training-seed spread": the baselines' and the main Y-net's ADE / FDE over training
seeds beside the main model's spread over evaluation rounds (stage `baseline_seed_spread`), or why
there is none.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pipeline.model_list import YNET, label
from pipeline.report.lookups import Absent, Measured, MetricsStore, as_measured, is_number
from pipeline.report.provenance import SEED_SPREAD_FILE


@dataclass(frozen=True)
class SeedSpreadRow:
    """One model at one horizon: ADE / FDE over training seeds (mean and std, `Measured` with
    the seed count as its rounds), the main model's std over evaluation rounds, and each seed's
    (seed, ADE, FDE, kept epoch, its validation ADE); or, with `not_run`, why no extra seed was
    trained (Y-net in the `cpu` profile), the main seed's values still listed."""
    model: str
    horizon: int
    ade: Measured | Absent
    fde: Measured | Absent
    ade_round_std: float | None
    fde_round_std: float | None
    per_seed: tuple[tuple[Any, Any, Any, Any, Any], ...]
    not_run: str | None = None


def seed_spread_row(entry: Any, source: str) -> SeedSpreadRow | Absent:
    """A row from one entry of `baseline_seed_spread.json`, or why it cannot be one."""
    if not isinstance(entry, dict) or not all(key in entry for key in ("model", "horizon", "per_seed")):
        return Absent(f"{source}: an entry without model, horizon or per_seed", "invalid")
    over, main = entry.get("over_training_seeds") or {}, entry.get("main_round_std") or {}
    seeds = entry["per_seed"] if isinstance(entry["per_seed"], list) else []
    where = f"{source}: {entry['model']} t_f = {entry['horizon']}"
    per_seed = tuple((s.get("seed"), s.get("ade"), s.get("fde"), s.get("best_epoch"), s.get("best_val_ade"))
                     for s in seeds if isinstance(s, dict))
    if entry.get("not_run_reason"):
        why = str(entry["not_run_reason"])
        return SeedSpreadRow(
            model=label(str(entry["model"])), horizon=entry["horizon"],
            ade=Absent(why, "status"), fde=Absent(why, "status"), ade_round_std=None,
            fde_round_std=None, per_seed=per_seed, not_run=why)
    return SeedSpreadRow(
        model=label(str(entry["model"])), horizon=entry["horizon"],
        ade=as_measured(over.get("ade"), len(per_seed), f"{where}: ade over training seeds"),
        fde=as_measured(over.get("fde"), len(per_seed), f"{where}: fde over training seeds"),
        ade_round_std=main.get("ade") if is_number(main.get("ade")) else None,
        fde_round_std=main.get("fde") if is_number(main.get("fde")) else None,
        per_seed=per_seed)


def seed_spread_section(store: MetricsStore) -> dict[str, Any]:
    """The table "Training-seed spread" (stage `baseline_seed_spread`), or why there is none."""
    record = store.record(SEED_SPREAD_FILE)
    none = {"absent": None, "rows": [], "problems": [], "extra_seeds": None, "evaluation": {},
            "ynet_extra_seeds": None, "ynet_evaluation": {}}
    if isinstance(record, Absent):
        return {**none, "absent": record}
    if not isinstance(record, dict) or not isinstance(record.get("entries"), list):
        return {**none, "absent": Absent(f"{store.where(SEED_SPREAD_FILE)} has no list entries", "invalid")}
    found = [seed_spread_row(entry, store.where(SEED_SPREAD_FILE)) for entry in record["entries"]]
    evaluation = next((e["evaluation"] for e in record["entries"] if isinstance(e, dict)
                       and isinstance(e.get("evaluation"), dict)
                       and {"split", "k", "rounds", "seed"} <= set(e["evaluation"])), {})
    ynet_evaluation = next((e["evaluation"] for e in record["entries"] if isinstance(e, dict)
                            and e.get("model") == YNET and isinstance(e.get("evaluation"), dict)
                            and {"k_e", "k_a", "rounds"} <= set(e["evaluation"])), {})
    return {**none, "rows": [row for row in found if isinstance(row, SeedSpreadRow)],
            "problems": [row.reason for row in found if isinstance(row, Absent)],
            "extra_seeds": record.get("extra_seeds"), "evaluation": evaluation,
            "ynet_extra_seeds": record.get("ynet_extra_seeds"), "ynet_evaluation": ynet_evaluation}
