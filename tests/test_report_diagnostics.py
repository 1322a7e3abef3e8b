"""The report's "Table 3 bracketed: diagnostics" rows (`pipeline.report.diagnostics`) from
hand-made records of stages score_predictions and rpecnet_rollouts, and with either missing."""

from __future__ import annotations

import pytest

from pipeline.report.diagnostics import (DIAGNOSTIC, HEADLINE, MODELS, ONE_SAMPLE, diagnostics_from_store,
                                         table3_diagnostics)
from pipeline.report.lookups import Absent, Measured, MetricsStore

# the paper's models, then the registered constant velocity (the page's `table_models`)
WITH_REFERENCE = (*MODELS, ("constant_velocity", "Constant velocity"))


def scored(ade, fde, one_ade, one_fde, rounds=3, std=1.0) -> dict:
    """A `score_file` record with the four metrics the section reads (std on every one)."""
    values = {"ade": ade, "fde": fde, "ade_one_sample": one_ade, "fde_one_sample": one_fde}
    return {"rounds": rounds, "k": 20,
            "metrics": {k: {"mean": v, "std": std, "per_round": [v] * rounds}
                        for k, v in values.items()}}


LONG_TERM = {"unit": "px", "tables": {
    "tf5": {"t_f": 5, "models": {"pecnet": scored(1.0, 2.0, 3.0, 4.0)}},
    "tf30": {"t_f": 30, "models": {
        "constant_velocity": scored(100.0, 250.0, 100.0, 250.0, std=0.0),
        "pecnet": scored(80.0, 160.0, 200.0, 500.0),
        "rpecnet": scored(90.0, 180.0, 250.0, 600.0),
        "sgan": {"file": "x", "model": "sgan", "not_run_reason": "S-GAN not trained here"}}},
    "release_tf30": {"t_f": 30, "models": {"ynet": scored(50.0, 75.0, 260.0, 575.0)}}}}

ROLLOUTS = {"model": "rpecnet", "target_fde_over_ade": 2.872, "horizons": {"tf30": {
    "t_f": 30,
    "choice": {"split": "val", "n_windows": 156, "variants": {
        "independent": {"ade": 95.0, "fde": 172.0, "fde_over_ade": 1.81},
        "original_frame": {"ade": 260.0, "fde": 604.5, "fde_over_ade": 2.325}}},
    "chosen": "original_frame", "distance_to_target": 0.547,
    "test": {"variant": "original_frame", "n_windows": 382, "ade": 275.0, "fde": 605.0,
             "fde_over_ade": 2.2}}}}


def shown(rows):
    return [(r.label, r.setting) for r in rows]


def test_rows_per_model_with_the_diagnostic_after_rpecnets_own():
    rows = table3_diagnostics(LONG_TERM, ROLLOUTS, models=WITH_REFERENCE)
    assert shown(rows) == [
        ("S-GAN", HEADLINE), ("S-GAN", ONE_SAMPLE),
        ("PECNet", HEADLINE), ("PECNet", ONE_SAMPLE),
        ("R-PECNet", HEADLINE), ("R-PECNet", ONE_SAMPLE),
        ("R-PECNet, roll-out original_frame", DIAGNOSTIC),
        ("Constant velocity", HEADLINE), ("Constant velocity", ONE_SAMPLE),
        ("Y-net, release_tf30 windows", HEADLINE), ("Y-net, release_tf30 windows", ONE_SAMPLE)]
    pecnet_one = rows[3]
    assert (pecnet_one.ade.mean, pecnet_one.fde.mean, pecnet_one.ade.std) == (200.0, 500.0, 1.0)
    assert pecnet_one.fde_over_ade == 2.5 and pecnet_one.table == "tf30"
    assert rows[4].fde_over_ade == 2.0  # R-PECNet's headline 180 / 90
    assert rows[9].table == "release_tf30" and rows[10].ade.mean == 260.0
    # Constant velocity (K identical samples): K = 1 is K = 20, an std of 0 over its 3 rounds.
    assert [(r.ade.mean, r.ade.std, r.fde.mean) for r in rows[7:9]] == [(100.0, 0.0, 250.0)] * 2


def test_the_diagnostic_row_is_the_chosen_variant_on_test_with_its_validation_ratio():
    row = table3_diagnostics(LONG_TERM, ROLLOUTS, models=WITH_REFERENCE)[6]
    assert row.model == "rpecnet" and row.table == "tf30" and row.setting == DIAGNOSTIC
    assert row.setting == "diagnostic, not the headline"
    assert isinstance(row.ade, Measured) and (row.ade.mean, row.fde.mean) == (275.0, 605.0)
    assert row.ade.std is None and row.ade.rounds == 1  # one round: no spread
    assert row.fde_over_ade == pytest.approx(605 / 275)  # 2.2 on test
    assert row.note == "chosen on val: FDE / ADE 2.33 (the variant nearest 2.87)"  # 2.325 up
    assert "rpecnet_rollouts.json: horizons.tf30.test.ade" in row.ade.source


def test_a_model_not_run_says_why_in_both_rows():
    sgan = [r for r in table3_diagnostics(LONG_TERM, ROLLOUTS, models=WITH_REFERENCE) if r.model == "sgan"]
    assert [r.setting for r in sgan] == [HEADLINE, ONE_SAMPLE]
    for r in sgan:
        assert r.ade == r.fde == Absent("S-GAN not trained here", "status")
        assert r.fde_over_ade is None


def test_a_record_from_before_the_one_sample_keys_asks_for_a_rerun():
    old = {"tables": {"tf30": {"t_f": 30, "models": {"pecnet": scored(80.0, 160.0, 0, 0)}}}}
    for key in ("ade_one_sample", "fde_one_sample"):
        del old["tables"]["tf30"]["models"]["pecnet"]["metrics"][key]
    head, one = table3_diagnostics(old, ROLLOUTS, models=(("pecnet", "PECNet"),))[:2]
    assert head.ade.mean == 80.0
    assert isinstance(one.ade, Absent) and one.ade.kind == "invalid"
    assert "has no metrics.ade_one_sample (re-run its stage)" in one.ade.reason


def test_missing_rollouts_leave_the_long_term_rows_and_say_why():
    for missing, reason in ((None, "stage not yet run: metrics/rpecnet_rollouts.json missing"),
                            (Absent("unreadable", "invalid"), "unreadable"),
                            ({"horizons": {}}, "metrics/rpecnet_rollouts.json has no "
                                               "horizons.tf30"),
                            ([], "metrics/rpecnet_rollouts.json has no horizons")):
        rows = table3_diagnostics(LONG_TERM, missing, models=WITH_REFERENCE)
        assert len(rows) == 11 and rows[2].ade.mean == 80.0
        row = rows[6]
        assert row.setting == DIAGNOSTIC and row.label == "R-PECNet, compounding roll-out"
        assert isinstance(row.ade, Absent) and row.ade.reason == reason and row.note == ""


def test_missing_long_term_record_keeps_one_row_per_model_and_the_diagnostic():
    models = (("pecnet", "PECNet"), ("rpecnet", "R-PECNet"))
    rows = table3_diagnostics(None, ROLLOUTS, models=models)
    assert shown(rows) == [("PECNet", HEADLINE), ("PECNet", ONE_SAMPLE), ("R-PECNet", HEADLINE),
                           ("R-PECNet", ONE_SAMPLE),
                           ("R-PECNet, roll-out original_frame", DIAGNOSTIC)]
    assert rows[0].ade == Absent("stage not yet run: metrics/beyond/long_term.json missing")
    assert rows[4].ade.mean == 275.0
    assert table3_diagnostics({"tables": 3}, None, models=models)[0].ade.kind == "invalid"


def test_from_the_page_store():
    store = MetricsStore("m", {"beyond/long_term.json": LONG_TERM})
    rows = diagnostics_from_store(store, models=WITH_REFERENCE)
    assert rows[0].ade == Absent("S-GAN not trained here", "status")
    assert rows[2].ade.source == "m/beyond/long_term.json: tables.tf30.models.pecnet.metrics.ade"
    assert rows[6].ade.reason == "stage not yet run: m/rpecnet_rollouts.json missing"
