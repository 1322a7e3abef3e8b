"""How each Y-net horizon and extra-seed slot is scored (`pipeline.runners.slot_scoring`, stage
`ynet_slot_scoring`): one file a slot, unchanged by a sampling param for a slot the profile does not
train, so that `dvc exp run -S ttst.temperature=...` re-runs only the slots it trains."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
import yaml
from dvc.repo import Repo

from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile
from pipeline.config.ynet_horizons import HorizonParams
from pipeline.io import IntermediateError
from pipeline.runners.slot_scoring import (EVAL_KEYS, check_agrees, horizon_slot, read_slot_scoring, seed_slot,
                                   slot_payloads)
from pipeline.stages import evaluate_ynet_horizon, evaluate_ynet_seed, ynet_slot_scoring

REPO = Path(__file__).resolve().parents[1]
PARAMS = yaml.safe_load((REPO / "params.yaml").read_text())
SAMPLING_PARAMS = {"ttst", "cws"}


def with_profile(profile: str, horizons: dict | None = None) -> dict:
    """params.yaml with `profile` active (and, given `horizons`, its horizon epochs replaced)."""
    params = copy.deepcopy(PARAMS)
    params["profile"] = profile
    if horizons is not None:
        params["ynet_horizons"][profile]["epochs"] = horizons
    return params


SOME = {10: 3, 60: 10}
"""A profile that trains only some horizons (and, in cpu, no extra seed)."""


def payloads_of(params: dict) -> dict[str, dict]:
    """`slot_payloads` of the settings stage `ynet_slot_scoring` reads from `params`."""
    return slot_payloads(ynet_slot_scoring.slot_settings(params))


def scored(payloads: dict) -> list[str]:
    return sorted(slot for slot, payload in payloads.items() if payload["scored"])


def test_every_slot_gets_a_file_and_the_profile_decides_which_are_scored():
    horizons = [h for h in PARAMS["windows"]["horizons"] if h != PARAMS["windows"]["release_horizon"]]
    slots = {horizon_slot(h) for h in horizons} | {seed_slot(s) for s in PARAMS["ynet_seeds"]["slots"]}
    for profile in ("cpu", "paper"):
        params = with_profile(profile)
        payloads = payloads_of(params)
        assert set(payloads) == slots
        trained = ({horizon_slot(h) for h in load_profile(HorizonParams, "ynet_horizons", params).horizons}
                   | {seed_slot(s) for s in params["ynet_seeds"][profile]["seeds"]})
        assert scored(payloads) == sorted(trained)
        assert all(payload["slot"] == slot for slot, payload in payloads.items())
    assert scored(payloads_of(with_profile("cpu", SOME))) == ["tf10", "tf60"]
    assert scored(payloads_of(with_profile("paper"))) == sorted(slots)


@pytest.mark.parametrize("key, value", [(("ttst", "temperature"), 1.5), (("cws", "ratio"), 3.0),
                                        (("eval", "cpu", "k_e"), 10), (("eval", "cpu", "bf16"), False)])
def test_a_sampling_change_rewrites_only_the_scored_slots(key, value):
    before = payloads_of(with_profile("cpu", SOME))
    params = with_profile("cpu", SOME)
    section = params
    for name in key[:-1]:
        section = section[name]
    section[key[-1]] = value
    after = payloads_of(params)
    changed = sorted(slot for slot in before if before[slot] != after[slot])
    assert changed == scored(before) == ["tf10", "tf60"]


def test_a_change_of_what_evaluate_ynet_alone_reads_rewrites_no_slot():
    params = with_profile("cpu", SOME)
    params["eval"]["cpu"].update(ablation_rounds=3, ka_grid_k_a=[1, 2, 5], qualitative_scenes=["gates_3"])
    assert payloads_of(params) == payloads_of(with_profile("cpu", SOME))


def test_the_stage_writes_what_the_stages_read_back(tmp_path, monkeypatch):
    params = with_profile("paper")
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    monkeypatch.chdir(tmp_path)
    ynet_slot_scoring.main(["--out", "slots"])
    main_eval = load_profile(EvalParams, "eval", params)
    rounds = params["ynet_horizons"]["paper"]["rounds"]

    horizon = read_slot_scoring(Path("slots/tf10.json"), "tf10")
    assert horizon.profile == "paper" and horizon.ttst.temperature == params["ttst"]["temperature"]
    assert horizon.cws.ratio == params["cws"]["ratio"]
    assert {k: getattr(horizon.eval, k) for k in EVAL_KEYS} == {
        **{k: getattr(main_eval, k) for k in EVAL_KEYS}, "k_a": 1, "rounds": rounds}
    seed = read_slot_scoring(Path("slots/seed1.json"), "seed1")
    assert {k: getattr(seed.eval, k) for k in EVAL_KEYS} == {k: getattr(main_eval, k) for k in EVAL_KEYS}
    assert sorted(p.name for p in Path("slots").iterdir()) == sorted(
        f"{slot}.json" for slot in payloads_of(params))

    params = with_profile("cpu", SOME)
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    ynet_slot_scoring.main(["--out", "slots"])
    assert read_slot_scoring(Path("slots/tf5.json"), "tf5") is None
    assert json.loads(Path("slots/tf5.json").read_text()) == {"scored": False, "slot": "tf5"}


@pytest.mark.parametrize("content, message", [
    ("not json", "not readable as JSON"),
    (json.dumps({"slot": "tf60", "scored": False}), "holds the settings of slot 'tf60', not 'tf10'"),
    (json.dumps({"slot": "tf10"}), "scored: missing"),
    (json.dumps({"slot": "tf10", "scored": True, "profile": "cpu", "eval": {"k_e": 20}, "ttst": {},
                 "cws": {}}), "not slot settings as ynet_slot_scoring writes them"),
])
def test_a_bad_slot_file_is_named(tmp_path, content, message):
    path = tmp_path / "tf10.json"
    path.write_text(content)
    with pytest.raises(IntermediateError, match=message) as error:
        read_slot_scoring(path, "tf10")
    assert str(path) in str(error.value)


def test_a_slot_file_that_disagrees_with_the_training_record_stops_the_stage(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("tf5.json").write_text(json.dumps({"slot": "tf5", "scored": False}))
    Path("train.json").write_text(json.dumps({"trained": True}))
    argv = ["--horizon", "5", "--table", "tf5.parquet", "--semantic-maps", "maps", "--sdd", "sdd",
            "--checkpoint-dir", "ck", "--scoring", "tf5.json", "--train-metrics", "train.json",
            "--metrics", "out/m.json", "--predictions", "out/p.parquet"]
    with pytest.raises(SystemExit, match=r"^evaluate_ynet_horizon: tf5.json says the slot is not "
                                         r"scored but train.json says it was trained"):
        evaluate_ynet_horizon.main(argv)
    assert not Path("out").exists()
    Path("tf10.json").write_text(json.dumps(payloads_of(with_profile("cpu"))["tf10"]))
    with pytest.raises(IntermediateError, match="tf10.json says the slot is scored but t.json says it "
                                                "was not trained"):
        check_agrees(read_slot_scoring(Path("tf10.json"), "tf10"), False, Path("tf10.json"),
                     Path("t.json"))


def test_the_seed_stage_reads_its_slot_from_the_training_record(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("seed2.json").write_text(json.dumps({"slot": "seed2", "scored": False}))
    Path("train.json").write_text(json.dumps({"seed": 1, "trained": False, "not_run_reason": "x"}))
    with pytest.raises(SystemExit, match="seed2.json: holds the settings of slot 'seed2', not 'seed1'"):
        evaluate_ynet_seed.main(["--windows", "w.parquet", "--semantic-maps", "maps", "--sdd", "sdd",
                                 "--checkpoint-dir", "ck", "--scoring", "seed2.json", "--train-metrics",
                                 "train.json", "--metrics", "out/m.json"])
    assert not Path("out").exists()


def test_dvc_yaml_gives_every_slot_stage_its_own_file_and_no_sampling_param():
    stages = {stage.addressing: stage for stage in Repo(str(REPO)).index.stages}
    slot_stages = {name: stage for name, stage in stages.items()
                   if name.startswith(("evaluate_ynet_horizon@", "evaluate_ynet_seed@"))}
    slots = {(horizon_slot if "horizon" in name else seed_slot)(int(name.split("@")[1])): name
             for name in slot_stages}
    assert set(slots) == set(payloads_of(PARAMS))  # a file for every slot stage, a stage for every file
    for slot, name in slots.items():
        stage = slot_stages[name]
        deps = {str(dep.def_path) for dep in stage.deps}
        assert f"data/ynet_slot_scoring/{slot}.json" in deps
        assert f"--scoring data/ynet_slot_scoring/{slot}.json" in stage.cmd
        params = {key for dep in stage.deps if hasattr(dep, "params") for key in dep.params}
        assert not any(key.split(".")[0] in SAMPLING_PARAMS | {"eval", "profile"} for key in params), params
    writer = stages["ynet_slot_scoring"]
    assert [str(out.def_path) for out in writer.outs] == ["data/ynet_slot_scoring"]
