"""Which horizons a profile trains Y-net at, and the record an untrained horizon leaves."""

import pytest

from pipeline.config.loading import ParamsError, load_profile, read_params
from pipeline.config.ynet_horizons import HorizonParams
from pipeline.runners.ynet_horizon import not_run_record

HORIZONS = [5, 10, 15, 20, 40, 50, 60]  # dvc.yaml's ynet_horizon foreach (30 is the main Y-net)


def test_cpu_profile_trains_at_least_10_and_60_s_and_paper_all():
    params = read_params()
    cpu = load_profile(HorizonParams, "ynet_horizons", {**params, "profile": "cpu"})
    paper = load_profile(HorizonParams, "ynet_horizons", {**params, "profile": "paper"})
    assert {10, 60} <= set(cpu.horizons)
    assert paper.horizons == HORIZONS and set(paper.epochs.values()) == {300}
    assert set(cpu.horizons) <= set(HORIZONS)


def test_not_run_record_names_profile_horizons_and_reason():
    params = HorizonParams(epochs={60: 10, 10: 3}, rounds=1, why_subset="2 cores")
    record = not_run_record(40, "cpu", params)
    assert record["t_f"] == 40 and record["trained"] is False
    assert record["not_run_reason"] == ("Y-net is not trained at t_f = 40 s in the cpu profile "
                                        "(it trains 10, 60 s here): 2 cores")


def test_bad_epochs_fail():
    with pytest.raises(ParamsError):
        load_profile(HorizonParams, "ynet_horizons",
                     {"profile": "cpu", "ynet_horizons": {"cpu": {"epochs": {10: 0}, "rounds": 1}}})
