"""The report's metrics lookups (`pipeline.report.lookups`) on hand-made records: every value, reason,
kind and source they return, so a lookup that reads the wrong key, drops a reason or invents a
spread fails here (and under `mutmut run`), not only somewhere in a rendered page."""

import json
import math

import pytest

from pipeline.report.lookups import (Absent, Measured, MetricsStore, as_measured, horizon_mismatch,
                                     is_number, load_metrics, lookup, lookup_grid, settings_mismatch)


def store(**files) -> MetricsStore:
    return MetricsStore("m", {name.replace("__", "/") + ".json": record for name, record in files.items()})


def test_a_missing_file_or_a_status_record_becomes_its_reason():
    files = store(a={"status": "skipped", "reason": "inD not provided"}, b={"status": "failed"},
                  c={"status": "ok", "ade": 1.0}, d={"status": "done"})
    assert files.where("x.json") == "m/x.json"
    assert files.record("x.json") == Absent("stage not yet run: m/x.json missing", "missing")
    assert files.record("a.json") == Absent("inD not provided (m/a.json)", "status")
    assert files.record("b.json") == Absent("failed (m/b.json)", "status")
    assert files.record("c.json") == {"status": "ok", "ade": 1.0}
    assert files.record("d.json") == {"status": "done"}


def test_load_metrics_parses_every_json_and_names_an_unreadable_one(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "a.json").write_text(json.dumps({"ade": 1.5}))
    (tmp_path / "b.json").write_text("{not json")
    (tmp_path / "c.txt").write_text("{}")
    loaded = load_metrics(tmp_path, "metrics")
    assert loaded.root == "metrics" and set(loaded.files) == {"sub/a.json", "b.json"}
    assert loaded.files["sub/a.json"] == {"ade": 1.5}
    broken = loaded.files["b.json"]
    assert broken.kind == "invalid" and broken.reason.startswith("metrics/b.json unreadable: ")
    assert load_metrics(tmp_path).root == tmp_path.as_posix()
    assert load_metrics(tmp_path / "none").files == {}


@pytest.mark.parametrize("value, expected", [(1, True), (2.5, True), (0, True), (True, False),
                                             (math.nan, False), (math.inf, False), ("1", False),
                                             (None, False)])
def test_is_number(value, expected):
    assert is_number(value) is expected


def test_as_measured():
    assert as_measured(2.5, 3, "s", "n") == Measured(2.5, None, 3, "s", "n")
    assert as_measured({"mean": 2.5, "std": 0.5}, 3, "s") == Measured(2.5, 0.5, 3, "s")
    assert as_measured({"mean": 2.5, "std": 0.5, "rounds": 4}, 3, "s") == Measured(2.5, 0.5, 4, "s")
    assert as_measured({"mean": 2.5, "std": 0.0}, 1, "s") == Measured(2.5, None, 1, "s")  # one round
    assert as_measured({"mean": 2.5, "std": "?"}, "?", "s") == Measured(2.5, None, None, "s")
    assert as_measured({"mean": 7}, None, "s").mean == 7.0
    assert as_measured({"std": 1.0}, 3, "f: a") == Absent("f: a is not a finite number (None)", "invalid")
    assert as_measured(math.nan, 3, "f: a") == Absent("f: a is not a finite number (nan)", "invalid")


def test_horizon_and_settings_mismatch():
    files = store()
    assert horizon_mismatch(files, "f.json", {"t_f": 30}, None) is None
    assert horizon_mismatch(files, "f.json", [{"t_f": 20}], 30) is None
    assert horizon_mismatch(files, "f.json", {"t_f": 30}, 30) is None
    assert horizon_mismatch(files, "f.json", {"ade": 1.0}, 30) is None
    assert horizon_mismatch(files, "f.json", {"horizon": 20}, 30) == Absent(
        "m/f.json is for t_f = 20 s, not 30 s", "invalid")
    assert horizon_mismatch(files, "f.json", {"t_f": 20, "horizon": 30}, 30).reason.endswith("20 s, not 30 s")
    assert settings_mismatch({"k": 3}, {}) == settings_mismatch({}, {"k": 20}) == ""
    assert settings_mismatch({"k": 20, "profile": "cpu"}, {"k": 20, "profile": "cpu"}) == ""
    assert settings_mismatch({"k": 3, "profile": "cpu", "k_e": 5}, {"k": 20, "profile": "cpu", "k_e": 5}) == (
        "measured with k = 3; this cell is for k = 20")
    assert settings_mismatch({"profile": "paper", "k_e": 10}, {"profile": "cpu", "k_e": 20}) == (
        "measured with profile = paper, k_e = 10; this cell is for profile = cpu, k_e = 20")


def test_lookup_follows_the_path_and_says_why_not():
    files = store(e={"t_f": 30, "rounds": 3, "k": 5, "main": {"ade": {"mean": 4.0, "std": 0.5}},
                     "ablation": {"none": {"rounds": 1, "ade": {"mean": 6.0, "std": 0.0}}},
                     "models": {"sgan": {"not_run_reason": "not trained here"}}},
                  s={"status": "skipped", "reason": "no data"})
    assert lookup(files, "e.json", ("main", "ade")) == Measured(4.0, 0.5, 3, "m/e.json: main.ade")
    assert lookup(files, "e.json", ("ablation", "none", "ade")) == Measured(
        6.0, None, 1, "m/e.json: ablation.none.ade")  # the innermost round count applies
    assert lookup(files, "e.json", ("main", "ade"), t_f=30, expect={"k": 20}).mismatch == (
        "measured with k = 5; this cell is for k = 20")
    assert lookup(files, "e.json", ("main", "ade"), expect={"k": 5, "profile": "cpu"}).mismatch == ""
    inner = store(f={"profile": "cpu", "k_e": 20, "main": {"k_e": 10, "ade": 1.0}})
    assert lookup(inner, "f.json", ("main", "ade"), expect={"k_e": 20, "profile": "cpu"}).mismatch == (
        "measured with k_e = 10; this cell is for k_e = 20")  # the innermost setting counts
    assert lookup(inner, "f.json", ("main", "ade"), expect={"profile": "paper"}).mismatch.startswith(
        "measured with profile = cpu")
    assert lookup(files, "e.json", ("main", "ade"), t_f=10) == Absent(
        "m/e.json is for t_f = 30 s, not 10 s", "invalid")
    assert lookup(files, "e.json", ("main", "fde")) == Absent("m/e.json has no main.fde", "invalid")
    assert lookup(files, "e.json", ("main", "ade", "x")) == Absent("m/e.json has no main.ade.x", "invalid")
    assert lookup(files, "e.json", ("models", "sgan", "ade")) == Absent("not trained here", "status")
    assert lookup(files, "s.json", ("ade",)) == Absent("no data (m/s.json)", "status")
    assert lookup(files, "x.json", ("ade",)).kind == "missing"


def test_lookup_grid_finds_the_matching_entry():
    files = store(g={"t_f": 30, "rounds": 3, "ka_grid": [
        {"k_e": 20, "k_a": 1, "ade": {"mean": 5.0, "std": 0.25}},
        {"k_e": 20, "k_a": 2, "rounds": 1, "ade": {"mean": 4.0, "std": 0.0}},
        "not a row"]},
                  baselines__pecnet_ka=[{"k_a": 2, "k": 40, "rounds": 2, "ade": {"mean": 9.0, "std": 1.0}}],
                  n={"t_f": 30, "ka_grid": {"k_e": 20}})
    assert lookup_grid(files, "g.json", "ka_grid", {"k_e": 20, "k_a": 1}, "ade", t_f=30) == Measured(
        5.0, 0.25, 3, "m/g.json: ka_grid[k_e = 20, k_a = 1].ade")
    assert lookup_grid(files, "g.json", "ka_grid", {"k_e": 20, "k_a": 2}, "ade") == Measured(
        4.0, None, 1, "m/g.json: ka_grid[k_e = 20, k_a = 2].ade")
    assert lookup_grid(files, "baselines/pecnet_ka.json", "rows", {"k_a": 2}, "ade") == Measured(
        9.0, 1.0, 2, "m/baselines/pecnet_ka.json: rows[k_a = 2].ade")
    assert lookup_grid(files, "g.json", "ka_grid", {"k_e": 10, "k_a": 1}, "ade") == Absent(
        "m/g.json has no ka_grid entry with k_e = 10, k_a = 1", "invalid")
    assert lookup_grid(files, "g.json", "ka_grid", {"k_e": 20, "k_a": 1}, "fde") == Absent(
        "m/g.json: ka_grid[k_e = 20, k_a = 1].fde is not a finite number (None)", "invalid")
    assert lookup_grid(files, "n.json", "ka_grid", {"k_e": 20}, "ade") == Absent(
        "m/n.json has no list ka_grid", "invalid")
    assert lookup_grid(files, "g.json", "ka_grid", {"k_e": 20}, "ade", t_f=60) == Absent(
        "m/g.json is for t_f = 30 s, not 60 s", "invalid")
    assert lookup_grid(files, "x.json", "ka_grid", {"k_e": 20}, "ade").kind == "missing"
    profiled = store(p={"profile": "paper", "ka_grid": [{"k_e": 20, "k_a": 2, "ade": 3.0}]})
    assert lookup_grid(profiled, "p.json", "ka_grid", {"k_a": 2}, "ade", expect={"profile": "cpu"}).mismatch == (
        "measured with profile = paper; this cell is for profile = cpu")
    assert lookup_grid(profiled, "p.json", "ka_grid", {"k_a": 2}, "ade", expect={"profile": "paper"}).mismatch == ""


def test_ynets_main_setting_is_one_number_everywhere():
    """K_e = 20, K_a = 1 is the `main` entry (all its rounds), never the grid's one-round re-score."""
    from pipeline.report.lookups import lookup_ynet_setting
    record = {"rounds": 3, "main": {"ade": {"mean": 50.48, "std": 0.06}},
              "ka_grid": [{"k_e": 20, "k_a": 1, "rounds": 1, "ade": {"mean": 50.53, "std": 0.0}},
                          {"k_e": 20, "k_a": 2, "rounds": 1, "ade": {"mean": 46.59, "std": 0.0}},
                          {"k_e": 10, "k_a": 1, "rounds": 1, "ade": {"mean": 58.98, "std": 0.0}}]}
    store = MetricsStore("metrics", {"ynet_eval.json": record})
    assert lookup_ynet_setting(store, "ynet_eval.json", 20, 1, "ade").mean == 50.48
    assert lookup_ynet_setting(store, "ynet_eval.json", 20, 2, "ade").mean == 46.59
    assert lookup_ynet_setting(store, "ynet_eval.json", 10, 1, "ade").mean == 58.98
