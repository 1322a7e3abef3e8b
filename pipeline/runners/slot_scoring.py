"""How each Y-net slot is scored, resolved for the active profile: one small JSON file per slot.

The slots are the stages `evaluate_ynet_horizon@<t_f>` (the horizons besides the release's) and
`evaluate_ynet_seed@<seed>` (extra training seeds). A profile may train only some of them (`cpu`:
every horizon, no extra seed), yet DVC builds a stage for every slot, and a stage that
declared `ttst` would re-run on every `dvc exp run -S ttst.temperature=...` just to write "not
trained" again (about 3 s each, nine of them). So stage `ynet_slot_scoring` reads the params once
and writes `<slot>.json` per slot: the sampling settings for a slot the profile trains, and only
`{slot, scored: false}` for the others. Each evaluation stage declares its own file as a dep instead
of the params: a sampling change rewrites the trained slots' files and leaves the others
byte-identical, so DVC skips them.

A horizon slot is scored as the authors' Figure 4 (K_a = 1) over `ynet_horizons.<profile>.rounds`
rounds; a seed slot in `evaluate_ynet`'s main setting (`eval.<profile>`'s K_e, K_a and rounds).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.loading import ParamsError, from_dict
from pipeline.config.ttst import TtstParams
from pipeline.io import IntermediateError, index_value, read_json_index

if TYPE_CHECKING:  # annotations only: a stage's code holds the sections it reads (code_graph)
    from pipeline.config.ynet_horizons import HorizonParams

EVAL_KEYS = ("k_e", "k_a", "rounds", "seed", "batch_size", "chunk_size", "bf16", "threads")
"""The `eval.<profile>` keys a slot is scored with (the rest concern `evaluate_ynet` alone)."""


@dataclass(frozen=True)
class SlotScoring:
    """The settings a trained slot is scored with."""

    profile: str
    eval: EvalParams
    """Only `EVAL_KEYS` are set; the ablation, K_a grid and qualitative keys keep their defaults
    and are not used (a slot scores the main setting only)."""
    ttst: TtstParams
    cws: CwsParams


@dataclass(frozen=True)
class SlotSettings:
    """What the slots are resolved from, as stage `ynet_slot_scoring` read it from params.yaml."""

    profile: str
    horizons: Any  # windows.horizons, as written: checked to hold release_horizon
    release_horizon: Any  # windows.release_horizon, as written
    eval: EvalParams  # eval.<profile>
    ttst: TtstParams
    cws: CwsParams
    ynet_horizons: HorizonParams  # ynet_horizons.<profile>: the horizons trained, their rounds
    seeds: list[int]  # ynet_seeds.<profile>.seeds: the extra seeds trained
    seed_slots: list[int]  # ynet_seeds.slots: the seeds a stage exists for


def horizon_slot(horizon: int) -> str:
    return f"tf{horizon}"


def seed_slot(seed: int) -> str:
    return f"seed{seed}"


def slot_payloads(settings: SlotSettings) -> dict[str, dict]:
    """Slot name -> the JSON its evaluation stage reads, for every horizon slot (the horizons of
    `windows.horizons` but `windows.release_horizon`) and every seed slot (`ynet_seeds.slots`)."""
    horizons, release = settings.horizons, settings.release_horizon
    if not isinstance(horizons, list) or release not in horizons:
        raise ParamsError("params.yaml:windows: horizons must be a list holding release_horizon, "
                          f"got {horizons!r} and {release!r}")
    scored = {"profile": settings.profile, "scored": True,
              "ttst": dataclasses.asdict(settings.ttst), "cws": dataclasses.asdict(settings.cws)}
    main_eval = {key: getattr(settings.eval, key) for key in EVAL_KEYS}

    horizon_params = settings.ynet_horizons
    payloads = {}
    for horizon in horizons:
        if horizon == release:
            continue
        slot = horizon_slot(horizon)
        payloads[slot] = ({"slot": slot, **scored,
                           "eval": {**main_eval, "k_a": 1, "rounds": horizon_params.rounds}}
                          if horizon in horizon_params.horizons else {"slot": slot, "scored": False})
    for seed in settings.seed_slots:
        slot = seed_slot(seed)
        payloads[slot] = ({"slot": slot, **scored, "eval": main_eval} if seed in settings.seeds
                          else {"slot": slot, "scored": False})
    return payloads


def read_slot_scoring(path: Path, slot: str) -> SlotScoring | None:
    """The settings `ynet_slot_scoring` wrote for `slot`, or None for a slot the profile does not
    score; an IntermediateError naming `path` if it is not such a file."""
    payload = read_json_index(path)
    if index_value(payload, "slot", str, path) != slot:
        raise IntermediateError(f"{path}: holds the settings of slot {payload['slot']!r}, not {slot!r}")
    if not index_value(payload, "scored", bool, path):
        return None
    try:
        return SlotScoring(
            profile=index_value(payload, "profile", str, path),
            eval=from_dict(EvalParams, {key: payload.get("eval", {}).get(key) for key in EVAL_KEYS},
                           f"{path}:eval"),
            ttst=from_dict(TtstParams, payload.get("ttst"), f"{path}:ttst"),
            cws=from_dict(CwsParams, payload.get("cws"), f"{path}:cws"))
    except (ParamsError, AttributeError) as e:
        raise IntermediateError(f"{path}: not slot settings as ynet_slot_scoring writes them ({e})") from e


def check_agrees(scoring: SlotScoring | None, trained: bool, path: Path, train_metrics: Path) -> None:
    """Both files derive from the same params, so they agree unless one is stale or hand-edited."""
    if (scoring is not None) != trained:
        raise IntermediateError(
            f"{path} says the slot is {'' if scoring else 'not '}scored but {train_metrics} says it "
            f"was {'' if trained else 'not '}trained (re-run ynet_slot_scoring and the training stage)")
