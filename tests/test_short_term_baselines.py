"""S-GAN and PECNet on the short-term benchmarks train in the unit each benchmark is scored in (SDD
pixels, ETH/UCY metres) with their per-benchmark settings (`pipeline.runners.short_term_baselines`).

The stage runs themselves are in tests/test_short_term_models.py's module fixture (`project`),
reused here.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from pipeline.benchmarks.registry import short_term
from pipeline.config.loading import active_profile, load_profile, profile_entry, read_params
from pipeline.config.pecnet import PecnetConfig
from pipeline.config.sgan import SganConfig
from pipeline.data.window_table import select_split, to_arrays
from pipeline.runners.baselines import config_class
from pipeline.runners.short_term_baselines import SECTION, BaselineOverrides
from pipeline.runners.short_term_baselines import baseline_config as config_from
from pipeline.runners.short_term_baselines import overrides as overrides_of
from tests.test_short_term_models import N_FUTURE, N_PAST, project  # noqa: F401 (fixture)


def overrides_section(params: dict) -> BaselineOverrides:
    """Section `short_term_baselines` as the short-term baseline stages read it from `params`."""
    return BaselineOverrides(active_profile(params), profile_entry(params, SECTION))


def overrides(params: dict, model: str, dataset: str) -> dict:
    return overrides_of(overrides_section(params), model, dataset)


def baseline_config(model: str, dataset: str, params: dict, epochs: int):
    """`model`'s config for `dataset` as stage `train_short_term_baseline` builds it from `params`."""
    return config_from(model, dataset, load_profile(config_class(model), model, params),
                       overrides_section(params), epochs)


REPO = Path(__file__).resolve().parents[1]


def test_ethucy_windows_are_the_tables_metres_in_every_split(project):  # noqa: F811
    windows = project / "data" / "short_term"
    table = pd.read_parquet(windows / "ethucy_eth.parquet")
    bench = short_term("eth").load_in_unit(windows, N_PAST, N_FUTURE)
    metres = to_arrays(table.assign(x=table["x_m"], y=table["y_m"]), N_PAST)
    pixels = to_arrays(table, N_PAST)
    assert bench.unit == "m"
    for name in ("train", "val", "test"):
        split = getattr(bench, name)
        expected = select_split(metres, name)
        np.testing.assert_array_equal(split.window_id, expected.window_id)
        np.testing.assert_array_equal(split.past, expected.past)
        np.testing.assert_array_equal(split.future, expected.future)
        assert not np.allclose(split.past, select_split(pixels, name).past)  # not the pixels
    np.testing.assert_array_equal(bench.truth, select_split(metres, "test").future)
    points = np.arange(6.0).reshape(3, 2)
    assert bench.to_unit(points) is points  # scored as predicted: already in metres


def test_sdd_windows_stay_in_pixels(project):  # noqa: F811
    windows = project / "data" / "short_term"
    table = pd.read_parquet(windows / "sdd_trajnet.parquet")
    bench = short_term("sdd").load_in_unit(windows, N_PAST, N_FUTURE)
    assert bench.unit == "px"
    np.testing.assert_array_equal(bench.train.past, select_split(to_arrays(table, N_PAST), "train").past)


def test_a_table_without_metres_is_refused():
    table = pd.DataFrame({"window_id": [0], "x": [1.0], "y": [2.0]})
    with pytest.raises(ValueError, match="eth: the window table has no metre columns"):
        short_term("eth").splits_in_unit(table, N_PAST, N_FUTURE)


@pytest.mark.parametrize("dataset, model, unit", [("eth", "pecnet", "m"), ("eth", "sgan", "m"),
                                                  ("sdd", "pecnet", "px")])
def test_a_trained_baseline_records_its_unit_and_benchmark_settings(project, dataset, model, unit):  # noqa: F811
    trained = json.loads((project / "metrics" / "short_term" / "train" / f"{dataset}_{model}.json")
                         .read_text())
    assert trained["train"]["unit"] == unit
    state = torch.load(project / "checkpoints" / f"{dataset}_{model}" / "best.pt", weights_only=True)
    params = read_params(project / "params.yaml")
    expected = overrides(params, model, dataset)
    assert {key: state["config"][key] for key in expected} == expected
    record = json.loads((project / "metrics" / "short_term" / "runs" / f"{dataset}_{model}.json")
                        .read_text())
    assert record["unit"] == unit


def test_ethucy_pecnet_keeps_upstreams_likelihood_width_in_metres():
    """sigma = sqrt(batch_size * kl_weight) / data_scale (pecnet.py, "Loss balance"): upstream's ETH
    code (metres x 170, batches of 512, kl 1) gives 0.133 m; both profiles keep it."""
    params = read_params(REPO / "params.yaml")
    for profile in ("cpu", "paper"):
        config = baseline_config("pecnet", "zara1", {**params, "profile": profile}, 1)
        sigma = np.sqrt(config.batch_size * config.kl_weight) / config.data_scale
        assert sigma == pytest.approx(np.sqrt(512) / 170, rel=0.01), profile
        assert config.neighbour_radius == 4.0  # metres, in every scene


@pytest.mark.parametrize("profile", ["cpu", "paper"])
@pytest.mark.parametrize("model, config_class", [("sgan", SganConfig), ("pecnet", PecnetConfig)])
def test_params_give_a_valid_config_for_every_benchmark(profile, model, config_class):
    params = {**read_params(REPO / "params.yaml"), "profile": profile}
    for dataset in ("sdd", "eth"):
        config = baseline_config(model, dataset, params, 7)
        assert isinstance(config, config_class) and config.epochs == 7
    sdd = baseline_config(model, "sdd", params, 7)
    assert sdd == config_class(**{**params[model][profile], "epochs": 7})  # SDD: the section as is


def test_an_unknown_setting_names_its_params_key():
    params = {**read_params(REPO / "params.yaml"), "profile": "cpu"}
    params["short_term_baselines"] = {"cpu": {"pecnet": {"ethucy": {"radius": 4.0}}}}
    with pytest.raises(ValueError, match=r"short_term_baselines\.cpu\.pecnet\.ethucy: pecnet has "
                                         r"no setting\(s\) \['radius'\]"):
        baseline_config("pecnet", "eth", params, 1)


def test_a_missing_benchmark_entry_names_its_params_key():
    params = {**read_params(REPO / "params.yaml"), "profile": "cpu"}
    params["short_term_baselines"] = {"cpu": {"pecnet": {"sdd": {}}}}
    with pytest.raises(ValueError, match=r"short_term_baselines\.cpu\.pecnet\.ethucy is missing"):
        baseline_config("pecnet", "eth", params, 1)


def test_a_bad_value_is_refused_by_the_models_config():
    params = {**read_params(REPO / "params.yaml"), "profile": "cpu"}
    params["short_term_baselines"] = {"cpu": {"sgan": {"ethucy": {"coord_scale": -1.0}}}}
    with pytest.raises(ValueError, match="coord_scale must be > 0"):
        baseline_config("sgan", "eth", params, 1)


def test_test_selection_retrains_the_headline_pecnet_and_scores_its_first_round(project):  # noqa: F811
    """Stage `short_term_pecnet_test_selection`: PECNet retrained on eth (metres) as the headline
    trained it, its kept epoch's test numbers the headline's first round to the bit, upstream's
    selection on test the lowest per-epoch test value; the stage's checkpoints untouched."""
    from pipeline.stages import short_term_pecnet_test_selection

    folder = project / "checkpoints" / "eth_pecnet"
    before = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    train = project / "metrics" / "short_term" / "train" / "eth_pecnet.json"
    run = project / "metrics" / "short_term" / "runs" / "eth_pecnet.json"
    out = project / "compat" / "eth.json"
    cwd = Path.cwd()
    try:
        os.chdir(project)  # the stage reads ./params.yaml
        short_term_pecnet_test_selection.main([
            "--dataset", "eth", "--windows", str(project / "data" / "short_term"),
            "--training-facts", str(train), "--run-metrics", str(run), "--out", str(out)])
    finally:
        os.chdir(cwd)
    record = json.loads(out.read_text())
    assert "never a headline" in record["diagnostic"] and record["unit"] == "m"
    assert record["training_reproduced"]["same"] is True
    kept = record["validation_selected"]
    scored = json.loads(run.read_text())
    assert kept["test"]["headline"] == {m: scored["k20"]["per_round"][0][m] for m in ("ade", "fde")}
    assert [e["epoch"] for e in record["per_epoch"]] == list(range(record["epochs"]))
    for protocol in ("headline", "pecnet"):
        for metric in ("ade", "fde"):
            best = record["compat"][protocol][f"best_{metric}"]
            assert best["value"] == min(e["test"][protocol][metric] for e in record["per_epoch"])
            assert best["value"] <= kept["test"][protocol][metric]
    assert {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == before


def test_test_selection_on_a_fold_the_switch_leaves_off_records_why(project):  # noqa: F811
    from pipeline.stages import short_term_pecnet_test_selection

    out = project / "compat" / "hotel.json"
    cwd = Path.cwd()
    try:
        os.chdir(project)  # the switch (params.yaml) lists eth only
        short_term_pecnet_test_selection.main([
            "--dataset", "hotel", "--windows", str(project / "data" / "short_term"),
            "--training-facts", "no_such_file.json", "--run-metrics", "no_such_file.json",
            "--out", str(out)])
    finally:
        os.chdir(cwd)
    record = json.loads(out.read_text())
    assert record["not_run_reason"] == ("compat switch off for hotel "
                                        "(short_term_pecnet_test_selection.folds in params.yaml)")
    assert "compat" not in record


@pytest.mark.parametrize("folds, message", [(["eth", "sdd"], "not ETH/UCY folds"),
                                            (["eth", "eth"], "folds repeat")])
def test_the_switch_takes_only_ethucy_folds_once(folds, message):
    from pipeline.config.loading import from_dict
    from pipeline.config.short_term_pecnet_test_selection import ShortTermPecnetTestSelectionParams

    with pytest.raises(ValueError, match=message):
        from_dict(ShortTermPecnetTestSelectionParams, {"folds": folds}, "params.yaml:x")


def test_test_selection_refuses_headline_files_it_cannot_read(tmp_path):
    from pipeline.studies.short_term_test_selection import headline_facts

    (tmp_path / "train.json").write_text(json.dumps({"train": {"best_epoch": 3}}))
    (tmp_path / "run.json").write_text(json.dumps({"ks": [20], "k20": {"per_round": []}}))
    with pytest.raises(ValueError, match="train.json: no train.best_epoch / best_val_ade_px"):
        headline_facts(tmp_path / "train.json", tmp_path / "run.json")
    (tmp_path / "train.json").write_text(json.dumps({"train": {"best_epoch": 3, "best_val_ade_px": 0.2}}))
    with pytest.raises(ValueError, match="run.json: no first round's test ADE / FDE"):
        headline_facts(tmp_path / "train.json", tmp_path / "run.json")
