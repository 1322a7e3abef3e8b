"""Budget curves (`pipeline.report.budget`): the study's records read into curves, the point a
table cell's cause reads, the figure, and the cause on a real table."""

from __future__ import annotations

import pytest

from pipeline.report.budget import (budget_point, budget_runs, budget_section, budget_ticks,
                                    kept_epoch, plot_budget)
from pipeline.report.common import FigureSlot
from pipeline.report.lookups import MetricsStore, load_metrics
from pipeline.report.tables import build_tables
from tests.test_report import BANDS, PAPER, data_metrics, model_metrics, write_metrics  # noqa: F401
from tests.test_report_provenance import RAW, column_cells


def long_term(factor: int, ade: float, fde: float) -> dict:
    return {"ade": {"mean": ade}, "fde": {"mean": fde}, "factor": factor, "epochs": 40 * factor,
            "best_epoch": 10 * factor, "machine": {"cpu": "test CPU"}}


def short_term(factor: int, ade: float, fde: float) -> dict:
    return {"ks": [20], "k20": {"ade": {"mean": ade}, "fde": {"mean": fde}}, "factor": factor,
            "epochs": 10 * factor, "train": {"best_epoch": 3 * factor},
            "machine": {"cpu": "test CPU"}}


STUDY = {"sdd_long_pecnet_x1.json": long_term(1, 90.0, 180.0),
         "sdd_long_pecnet_x4.json": long_term(4, 81.0, 150.0),
         "sdd_long_pecnet_x2.json": long_term(2, 85.0, 170.0),
         "zara2_pecnet_x2.json": short_term(2, 0.20, 0.35),
         "notes.json": {"not": "a run"}}


def test_records_become_curves_by_benchmark_and_model_in_budget_order():
    curves = budget_runs(MetricsStore("studies/budget", STUDY))
    assert sorted(curves) == [("sdd_long", "pecnet"), ("zara2", "pecnet")]
    runs = curves[("sdd_long", "pecnet")]
    assert [(r.factor, r.epochs, r.values["ade"], r.best_epoch) for r in runs] == [
        (1, 40, 90.0, 11), (2, 80, 85.0, 21), (4, 160, 81.0, 41)]  # recorded from 0, shown from 1
    assert runs[0].source == "studies/budget/sdd_long_pecnet_x1.json" and runs[0].cpu == "test CPU"
    assert curves[("zara2", "pecnet")][0].values == {"ade": 0.20, "fde": 0.35}
    assert curves[("zara2", "pecnet")][0].best_epoch == 7  # a short-term record keeps it in "train"


@pytest.mark.parametrize("record, model, kept", [
    ({"best_epoch": 8, "val_ade_per_epoch": [3.0, 2.0, 2.5, 2.0]}, "pecnet", 2),  # the curve:
    ({"best_epoch": 9, "val_ade_per_epoch": [3.0, 2.0, 2.5, 2.0]}, "ynet", 2),  # its first minimum
    ({"val_ade_per_epoch": [251.3, 112.3, 118.0]}, "ynet", 2),  # long-term Y-net: only the curve
    ({"best_epoch": 8}, "pecnet", 9),  # no curve: the baselines record epochs from 0
    ({"train": {"best_epoch": 30}}, "ynet", 30),  # Y-net from 1
    ({"val_ade_per_epoch": []}, "ynet", None),
])
def test_the_kept_epoch_is_counted_from_one_for_every_model(record, model, kept):
    assert kept_epoch(record, model) == kept


def test_the_longest_run_is_set_against_the_studys_own_1x_else_the_headline():
    curves = budget_runs(MetricsStore("studies/budget", STUDY))
    point = budget_point(curves[("sdd_long", "pecnet")], "ade", headline=82.0)
    assert (point.factor, point.ours, point.ours_1x) == (4, 81.0, 90.0)  # the study's 1x, not 82
    assert point.closes(72.0) == pytest.approx(0.5)  # (90 - 81) / (90 - 72)
    zara2 = budget_point(curves[("zara2", "pecnet")], "fde", headline=0.40)
    assert (zara2.factor, zara2.ours_1x) == (2, 0.40)  # no 1x in the study: the headline
    assert budget_point(curves[("zara2", "pecnet")], "fde", headline=None) is None
    only_1x = budget_runs(MetricsStore("s", {"hotel_pecnet_x1.json": short_term(1, 0.3, 0.5)}))
    assert budget_point(only_1x[("hotel", "pecnet")], "ade", headline=0.3) is None


def test_the_axis_names_1x_where_only_the_headline_stands_there():
    curves = budget_runs(MetricsStore("studies/budget", STUDY))
    assert budget_ticks(curves[("zara2", "pecnet")], with_headline=True) == [1, 2]
    assert budget_ticks(curves[("zara2", "pecnet")], with_headline=False) == [2]
    assert budget_ticks(curves[("sdd_long", "pecnet")], with_headline=True) == [1, 2, 4]


def test_a_curve_is_drawn_with_its_gap_shares(tmp_path):
    curves = budget_runs(MetricsStore("studies/budget", STUDY))
    store = MetricsStore("metrics", {"baselines/pecnet_tf30.json": {"ade": {"mean": 82.0},
                                                                    "fde": {"mean": 175.0}}})
    section = budget_section({("sdd_long", "pecnet"): curves[("sdd_long", "pecnet")]}, RAW, store,
                             lambda name: FigureSlot(tmp_path / name, f"figures/{name}"))
    (entry,) = section
    assert entry["paper"] == {"ade": 72.22, "fde": 118.13} and entry["headline"]["ade"] == 82.0
    assert entry["closes"]["ade"][0] == 4
    assert entry["closes"]["ade"][1] == pytest.approx((90.0 - 81.0) / (90.0 - 72.22))
    assert entry["src"] == "figures/budget_sdd_long_pecnet.png"
    assert entry["title"] == "PECNet, Table 3, SDD long term (t_f = 30 s)"
    assert (tmp_path / "budget_sdd_long_pecnet.png").stat().st_size > 1000
    assert not plot_budget([], {}, {}, "t", "px", tmp_path / "none.png")


def test_table_3_names_budget_where_4x_closes_half_the_gap(tmp_path):
    write_metrics(tmp_path / "metrics", data_metrics() | model_metrics())
    store = load_metrics(tmp_path / "metrics", "metrics")
    ours = store.files["baselines/pecnet_tf30.json"]["ade"]["mean"]
    paper = 72.22
    closing = {"sdd_long_pecnet_x1.json": long_term(1, ours, 300.0),  # 1x = the fixture's headline
               "sdd_long_pecnet_x4.json": long_term(4, ours - 0.6 * (ours - paper), 299.0)}
    curves = budget_runs(MetricsStore("studies/budget", closing))
    table = {t.key: t for t in build_tables(RAW, store, BANDS, budgets=curves)}["sdd_long"]
    cells = column_cells(table, "SDD", "PECNet")
    assert cells["ADE"].why.verdict == "budget"
    assert "4x the epochs closes 60% of the gap" in cells["ADE"].why.detail
    assert cells["FDE"].why.verdict == "unexplained" and "4x the epochs closes" in cells["FDE"].why.detail


def test_the_long_term_ynets_curve_reads_its_main_setting_and_its_headline(tmp_path):
    ynet_run = {"main": {"ade": {"mean": 55.0}, "fde": {"mean": 100.0}, "k_e": 20, "k_a": 1},
                "ka_grid": [{"ade": {"mean": 1.0}, "fde": {"mean": 2.0}, "k_e": 10, "k_a": 1}],
                "factor": 2, "epochs": 76, "machine": {"cpu": "test CPU"}}
    curves = budget_runs(MetricsStore("studies/budget", {"sdd_long_ynet_x2.json": ynet_run}))
    assert curves[("sdd_long", "ynet")][0].values == {"ade": 55.0, "fde": 100.0}
    store = MetricsStore("metrics", {"ynet_eval.json": {
        "main": {"ade": {"mean": 50.48, "std": 0.1}, "fde": {"mean": 96.0, "std": 0.2}},
        "ka_grid": [{"ade": {"mean": 9.0}, "fde": {"mean": 9.0}, "k_e": 20, "k_a": 1}]}})
    (entry,) = budget_section(curves, RAW, store,
                              lambda name: FigureSlot(tmp_path / name, f"figures/{name}"))
    assert entry["headline"] == {"ade": 50.48, "fde": 96.0}  # main, as every Y-net cell reads it
    assert entry["paper"] == {"ade": 47.94, "fde": 66.71}  # Table 3's Y-net at K_a = 1
    assert entry["closes"]["ade"] == (2, pytest.approx((50.48 - 55.0) / (50.48 - 47.94)))
