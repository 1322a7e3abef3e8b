"""S-GAN and PECNet on the short-term benchmarks train in the unit each benchmark is scored in (SDD
pixels, ETH/UCY metres) with their per-benchmark settings (`pipeline.runners.short_term_baselines`).

The stage runs themselves are in tests/test_short_term_models.py's module fixture (`project`),
reused here.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from pipeline.config import read_params
from pipeline.data.window_table import to_arrays
from pipeline.harness.baselines.pecnet import PecnetConfig
from pipeline.harness.baselines.sgan import SganConfig
from pipeline.runners.short_term import select_split
from pipeline.runners.short_term_baselines import (baseline_config, benchmark_in_unit, load_in_unit,
                                                   overrides)
from tests.test_short_term_models import N_FUTURE, N_PAST, project  # noqa: F401 (fixture)

REPO = Path(__file__).resolve().parents[1]


def test_ethucy_windows_are_the_tables_metres_in_every_split(project):  # noqa: F811
    windows = project / "data" / "short_term"
    table = pd.read_parquet(windows / "ethucy_eth.parquet")
    bench = load_in_unit(windows, "eth", N_PAST, N_FUTURE)
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
    bench = load_in_unit(windows, "sdd", N_PAST, N_FUTURE)
    assert bench.unit == "px"
    np.testing.assert_array_equal(bench.train.past, select_split(to_arrays(table, N_PAST), "train").past)


def test_a_table_without_metres_is_refused():
    table = pd.DataFrame({"window_id": [0], "x": [1.0], "y": [2.0]})
    with pytest.raises(ValueError, match="eth: the window table has no metre columns"):
        benchmark_in_unit(table, "eth", N_PAST, N_FUTURE)


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
