"""tools/rerun_plan.py: which stages a params change re-runs, and on the real dvc.yaml the three
changes issue 20 names: a sampling change re-trains nothing, a short-term S-GAN change touches no
Y-net (only the one run it configures), a `paper` change touches nothing while `profile: cpu`."""

from pathlib import Path

import pytest
import yaml

from tools.rerun_plan import (MISSING, changed_keys, declares, downstream, parse_override, pipeline_graph,
                              plan, trains, value_at)

REPO = Path(__file__).resolve().parents[1]


def test_a_stage_sees_its_key_the_sections_above_and_the_keys_below():
    assert declares(["ttst"], "ttst.temperature")
    assert declares(["ttst.temperature"], "ttst.temperature")
    assert declares(["eval.cpu.k_e"], "eval.cpu")
    assert declares([], "anything")  # the whole file
    assert not declares(["ttst"], "ttst_extra")
    assert not declares(["eval.cpu"], "eval.paper.k_e")
    assert not declares(["short_term_models.cpu.epochs.sgan"], "short_term_models.cpu.epochs.ynet")


def test_downstream_follows_outputs_transitively_and_not_upstream():
    upstream_of = {"a": set(), "b": {"a"}, "c": {"b"}, "d": set(), "e": {"c", "d"}}
    assert downstream(upstream_of, {"b"}) == {"c", "e"}
    assert downstream(upstream_of, {"d"}) == {"e"}
    assert downstream(upstream_of, {"e"}) == set()


def test_an_override_equal_to_the_current_value_changes_nothing_and_a_missing_key_is_an_error():
    params = {"ttst": {"temperature": 1.8}, "eval": {"cpu": {"k_e": 20}}}
    assert parse_override("ttst.temperature=1.8") == ("ttst.temperature", 1.8)
    assert parse_override("eval.cpu.k_e=[1, 2]") == ("eval.cpu.k_e", [1, 2])
    assert changed_keys(params, [("ttst.temperature", 1.8), ("eval.cpu.k_e", 5)]) == ["eval.cpu.k_e"]
    with pytest.raises(KeyError, match="ttst.temprature"):
        changed_keys(params, [("ttst.temprature", 2.0)])
    with pytest.raises(ValueError, match="key.path=value"):
        parse_override("ttst.temperature")
    assert value_at(params, "eval.cpu.k_e.x") is MISSING and value_at(params, "eval.cpu.k_e") == 20


@pytest.fixture(scope="module")
def real_pipeline():
    """(params.yaml, declared keys per stage, upstream stages per stage) of this repository."""
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    assert params["profile"] == "cpu", "these checks are about the default profile"
    return params, *pipeline_graph(REPO)


def bumped(params: dict, key: str) -> list[str]:
    """The changed keys of an override of a numeric key to another value than params.yaml's."""
    return changed_keys(params, [(key, value_at(params, key) + 1)])


def test_a_sampling_change_rescores_y_net_and_trains_nothing(real_pipeline):
    params, declared, upstream_of = real_pipeline
    changed, after = plan(bumped(params, "ttst.temperature"), declared, upstream_of)
    assert {"evaluate_ynet", "ynet_slot_scoring"} <= changed
    assert "report" in after and "evaluate_ynet_horizon@10" in after
    assert not set(filter(trains, changed | after))


def test_a_short_term_sgan_change_touches_no_y_net(real_pipeline):
    params, declared, upstream_of = real_pipeline
    changed, after = plan(bumped(params, "short_term_models.cpu.epochs.sgan.sdd"),
                          declared, upstream_of)
    assert changed == {"train_short_term_baseline@sdd-sgan"}  # not PECNet, not ETH/UCY's S-GAN
    assert not {s for s in changed | after if "ynet" in s}


def test_a_benchmark_s_settings_touch_only_that_benchmark_s_runs(real_pipeline):
    params, declared, upstream_of = real_pipeline
    for key in ("short_term_models.cpu.epochs.ynet.ethucy", "short_term_models.cpu.ynet_ethucy.crop"):
        changed, _ = plan(bumped(params, key), declared, upstream_of)
        assert changed == {f"train_short_term_ynet@{fold}" for fold in params["short_term"]["ethucy_folds"]}
    k_sdd = [k + 1 for k in params["short_term_models"]["cpu"]["k_sdd"]]
    changed, _ = plan(changed_keys(params, [("short_term_models.cpu.k_sdd", k_sdd)]), declared,
                      upstream_of)
    assert changed == {"evaluate_short_term_ynet@sdd", "evaluate_short_term_baseline@sdd-sgan",
                       "evaluate_short_term_baseline@sdd-pecnet"}


def test_a_paper_change_touches_nothing_while_the_profile_is_cpu(real_pipeline):
    params, declared, upstream_of = real_pipeline
    for key in ("ynet.paper.epochs", "eval.paper.k_e", "short_term_models.paper.epochs.ynet.sdd"):
        assert plan(bumped(params, key), declared, upstream_of) == (set(), set())
