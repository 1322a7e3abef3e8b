"""Stage `horizon_analysis`: the pure functions on hand-computed cases, the leak check on fixtures
with a planted leak, the report's rows, and the stage end to end on small window tables."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.config.loading import read_params
from pipeline.data.window_table import conform, to_arrays
from pipeline.studies import horizon_analysis as ha
from pipeline.harness.predictions import (PredictionArrays, predictions_table,
                                          write_no_predictions, write_predictions)
from pipeline.io import write_parquet
from pipeline.report import horizons as report
from pipeline.stages import horizon_analysis as stage

N_PAST = 2


# ---------------------------------------------------------------------------------------------
# The windows' futures


def test_speed_path_length_and_net_displacement_by_hand():
    past = np.array([[[-1.0, 0.0], [0.0, 0.0]]])  # (1, 2, 2): last observed at the origin
    future = np.array([[[3.0, 4.0], [3.0, 4.0], [6.0, 8.0]]])  # 5 px, a stop, 5 px more
    assert ha.path_lengths(past, future) == pytest.approx([10.0])
    assert ha.net_displacements(past, future) == pytest.approx([10.0])
    assert ha.speeds(past, future, 3.0) == pytest.approx([10.0 / 3.0])
    back = np.array([[[3.0, 4.0], [0.0, 0.0]]])  # there and back: 10 px walked, 0 net
    assert ha.path_lengths(past, back) == pytest.approx([10.0])
    assert ha.net_displacements(past, back) == pytest.approx([0.0])


def test_standing_share_counts_net_displacements_strictly_below_the_threshold():
    net = np.array([10.0, 60.0, 49.9, 50.0])
    assert ha.standing_share(net, threshold=50.0) == pytest.approx(0.5)
    assert ha.standing_share(np.array([])) is None
    assert ha.quartiles(np.array([1.0, 2.0, 3.0, 4.0, 5.0])) == {"q25": 2.0, "median": 3.0, "q75": 4.0}


def test_straight_line_to_the_true_goal_by_hand():
    past = np.array([[[0.0, -1.0], [0.0, 0.0]]])
    future = np.array([[[0.0, 5.0], [10.0, 0.0]]])  # a detour, then the goal at (10, 0)
    line = ha.straight_to_goal(past, future)
    np.testing.assert_allclose(line, [[[5.0, 0.0], [10.0, 0.0]]])
    errors = ha.deterministic_errors(line, future)
    assert errors.summary()["ade"] == pytest.approx(np.hypot(5.0, 5.0) / 2)  # 7.07 then 0
    assert errors.summary()["fde"] == 0.0


def test_endpoint_spread_is_the_rms_distance_from_the_samples_mean():
    ends = np.array([[[0.0, 0.0], [2.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]]])  # (2, 2, 2)
    np.testing.assert_allclose(ha.endpoint_spread(ends), [1.0, 0.0])
    three = np.array([[[3.0, 4.0], [-3.0, -4.0], [0.0, 0.0]]])  # 5, 5, 0 from the mean
    np.testing.assert_allclose(ha.endpoint_spread(three), [np.sqrt(50.0 / 3.0)])


def test_truncate_keeps_the_first_steps_of_truth_and_predictions():
    truth = np.arange(2 * 4 * 2, dtype=float).reshape(2, 4, 2)
    pred = np.arange(2 * 3 * 4 * 2, dtype=float).reshape(2, 3, 4, 2)
    np.testing.assert_array_equal(ha.truncate(truth, 2), truth[:, :2])
    np.testing.assert_array_equal(ha.truncate(pred, 2), pred[:, :, :2])
    with pytest.raises(ValueError, match="cannot keep 5 of 4"):
        ha.truncate(truth, 5)
    with pytest.raises(ValueError, match="cannot keep 0"):
        ha.truncate(truth, 0)


def test_truncated_scoring_takes_min_over_k_on_the_first_steps_and_ignores_goals():
    """Two samples: sample 0 is exact for two steps then wrong, sample 1 off by 1 px throughout.
    Over 4 steps sample 1 is best (ADE 1 vs 5); over the first 2 steps sample 0 is (ADE 0)."""
    windows = to_arrays(table_of([walker(0, "a_0", 1, 0, speed=1.0, steps=N_PAST + 4)],
                                 split="test", t_f=4), N_PAST)
    truth = windows.future[0]  # (4, 2)
    wrong = truth + np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 10.0], [0.0, 10.0]])
    samples = np.stack([wrong, truth + [0.0, 1.0]])[None]  # (1, 2, 4, 2)
    goals = np.array([[[99.0, 99.0], [99.0, 99.0]]])  # far from everything: used at full length only
    rounds = {0: PredictionArrays(windows.window_id, samples, np.full((1, 2), np.nan), goals)}
    full = ha.score_rounds(rounds, windows).summary()
    assert full["ade"] == pytest.approx(1.0)
    assert full["fde"] == pytest.approx(np.hypot(99 - truth[-1, 0], 99 - truth[-1, 1]))
    cut = ha.score_rounds(rounds, windows, steps=2).summary()
    assert cut["ade"] == pytest.approx(0.0)
    assert cut["fde"] == pytest.approx(0.0)  # step 2 of sample 0's path, not its goal


def test_scores_join_predictions_by_window_id_not_position():
    windows = to_arrays(table_of([walker(3, "a_0", 1, 0, 1.0, N_PAST + 2),
                                  walker(7, "a_0", 2, 0, 2.0, N_PAST + 2)], "test", 2), N_PAST)
    exact = np.stack([windows.future[1], windows.future[0]])[:, None]  # rows in reverse id order
    rounds = {0: PredictionArrays(np.array([7, 3]), exact, np.full((2, 1), np.nan), None)}
    assert ha.score_rounds(rounds, windows).summary()["ade"] == 0.0
    other = {0: PredictionArrays(np.array([7, 4]), exact, np.full((2, 1), np.nan), None)}
    with pytest.raises(ValueError, match="not among the test windows"):
        ha.score_rounds(other, windows, source="tf2/x")


# ---------------------------------------------------------------------------------------------
# Leak check


def walker(window_id: int, scene: str, track: int, first_frame: int, speed: float, steps: int,
           split: str | None = None) -> pd.DataFrame:
    """One window of `steps` 1 FPS steps walking along x at `speed` px/s."""
    step = np.arange(steps)
    frame = {"window_id": window_id, "scene_id": scene, "track_id": track, "step": step,
             "frame": first_frame + 30 * step, "x": 100.0 + speed * step, "y": 50.0}
    return pd.DataFrame(frame if split is None else {**frame, "split": split})


def table_of(windows: list[pd.DataFrame], split: str, t_f: int, source: str = "raw") -> pd.DataFrame:
    table = pd.concat(windows, ignore_index=True)
    if "split" not in table:
        table["split"] = split
    return conform(table.assign(t_f=t_f, source=source))


def leak_free_tables() -> dict[str, pd.DataFrame]:
    """Two horizons cut from the same videos: test videos t_0, t_1; train / val a_0, v_0."""
    return {
        "tf2": table_of([walker(0, "t_0", 1, 0, 1.0, 4, "test"), walker(1, "t_1", 1, 0, 1.0, 4, "test"),
                         walker(2, "a_0", 1, 0, 1.0, 4, "train"), walker(3, "v_0", 1, 0, 1.0, 4, "val")],
                        "test", 2),
        "tf4": table_of([walker(0, "t_0", 1, 0, 1.0, 6, "test"), walker(1, "a_0", 1, 0, 1.0, 6, "train")],
                        "test", 4),
    }


def test_no_leak_counts_zero():
    result = ha.leak_check(leak_free_tables())
    assert result["total"] == 0
    assert result["tables"]["tf2"]["test_windows"] == 2
    assert result["test_videos"] == 2 and result["train_val_videos"] == 2


def test_a_planted_leak_across_horizons_is_counted():
    """A train window of the 4-s table on the test track t_0 / 1, frames 60-210, overlaps the test
    window of the 2-s table (frames 0-90) and the 4-s one (0-150): the leak shows in both tables."""
    tables = leak_free_tables()
    tables["tf4"] = table_of([tables["tf4"], walker(9, "t_0", 1, 60, 1.0, 6, "train")], "test", 4)
    result = ha.leak_check(tables)
    assert result["tables"]["tf2"]["same_table"] == {"videos": 0, "track_windows": 0,
                                                      "time_span_windows": 0}
    assert result["tables"]["tf2"]["any_table"] == {"videos": 1, "track_windows": 1,
                                                     "time_span_windows": 1}
    assert result["tables"]["tf4"]["same_table"]["track_windows"] == 1
    assert result["total"] == 6
    with pytest.raises(AssertionError):
        assert result["total"] == 0, "leak"


def test_another_track_at_the_same_time_is_a_time_span_leak_not_a_track_leak():
    tables = leak_free_tables()
    tables["tf2"] = table_of([tables["tf2"], walker(9, "t_1", 2, 30, 1.0, 4, "val")], "test", 2)
    counts = ha.leak_check(tables)["tables"]["tf2"]["any_table"]
    assert counts == {"videos": 1, "track_windows": 0, "time_span_windows": 1}


def test_frames_that_only_touch_count_and_disjoint_frames_do_not():
    test = ha.window_spans(table_of([walker(0, "t_0", 1, 0, 1.0, 4)], "test", 2))  # frames 0-90
    touching = ha.window_spans(table_of([walker(1, "t_0", 1, 90, 1.0, 4)], "train", 2))
    after = ha.window_spans(table_of([walker(1, "t_0", 1, 120, 1.0, 4)], "train", 2))
    assert ha.overlapping_windows(test, touching, same_track=True) == 1
    assert ha.overlapping_windows(test, after, same_track=True) == 0


# ---------------------------------------------------------------------------------------------
# Training curves and the subject's runs


def test_training_curves_from_a_history_and_without_one(tmp_path):
    history = tmp_path / "history.csv"
    pd.DataFrame({"epoch": [1, 2, 3], "train_loss": [3.0, 2.0, 1.0], "val_ade": [30.0, 10.0, 20.0],
                  "val_fde": [60.0, 25.0, 40.0], "seconds": [1.0, 2.0, 3.0]}).to_csv(history, index=False)
    curves = ha.training_curves(history)
    assert curves == {"trained": True, "epochs": 3, "best_epoch": 2, "train_loss": [3.0, 2.0, 1.0],
                      "val_ade": [30.0, 10.0, 20.0], "val_fde": [60.0, 25.0, 40.0]}
    assert ha.training_curves(None, "not trained in the cpu profile") == {
        "trained": False, "reason": "not trained in the cpu profile"}
    assert not ha.training_curves(tmp_path / "missing.csv")["trained"]


def test_subject_runs_follow_the_stored_predictions(tmp_path):
    metadata = {5: {"ynet": {"seeds": [0], "sampling": {}}}, 10: {"ynet": {"not_run_reason": "why"}},
                20: {}, 40: {"ynet": {"seeds": [0]}}}
    (tmp_path / "best.pt").write_bytes(b"weights")
    runs = ha.subject_runs([5, 10, 20, 40], metadata,
                           models={5: tmp_path / "best.pt", 40: tmp_path / "gone.pt"},
                           histories={5: tmp_path / "history.csv"})
    assert runs.models[5] == (tmp_path / "best.pt", {"seeds": [0], "sampling": {}})
    assert runs.models[10] == "why" and runs.curves[10] == {"trained": False, "reason": "why"}
    assert "no stored ynet predictions" in runs.models[20]
    assert "gone.pt" in runs.models[40] and not runs.curves[40]["trained"]


# ---------------------------------------------------------------------------------------------
# The record, the report's rows and the stage end to end


def project(root: Path, ynet_at_2: str = "stored") -> dict[str, Path]:
    """Window tables of 2 and 4 s (test: three walkers, one standing), the release table of 2 s,
    and stored predictions: constant velocity (exact on straight walkers) at both horizons, a
    predictions file of the subject at 4 s and on the release windows, and at 2 s `ynet_at_2`
    ("stored" or a not-run file)."""
    walkers = [(0, "t_0", 1, 2.0), (1, "t_0", 2, 0.0), (2, "t_1", 1, 30.0)]
    for t_f in (2, 4):
        test = [walker(i, s, k, 0, v, N_PAST + t_f, "test") for i, s, k, v in walkers]
        fitted = [walker(10, "a_0", 1, 0, 5.0, N_PAST + t_f, "train"),
                  walker(11, "v_0", 1, 0, 5.0, N_PAST + t_f, "val")]
        write_parquet(table_of(test + fitted, "test", t_f, "release_chain"),
                      root / "horizon_windows" / f"tf{t_f}.parquet")
    release = table_of([walker(i + 100, s, k, 0, v, N_PAST + 2, "test") for i, s, k, v in walkers],
                       "test", 2, "release")
    write_parquet(release, root / "release_tf2.parquet")
    metadata = SDD_LONG_TERM.prediction_metadata  # (model, table): what the scoring stages write
    for t_f in (2, 4):
        table = root / "horizon_windows" / f"tf{t_f}.parquet"
        arrays = to_arrays(pd.read_parquet(table).query("split == 'test'"), N_PAST)
        exact = arrays.future[:, None]
        write_predictions(predictions_table(arrays.window_id, exact),
                          root / "predictions" / f"tf{t_f}" / "constant_velocity.parquet",
                          {**metadata("constant_velocity", table), "seeds": [0]})
        if t_f == 4:
            off = exact + [0.0, 3.0]  # 3 px off at every step, goal exact
            write_predictions(predictions_table(arrays.window_id, off, goals=arrays.future[:, None, -1]),
                              root / "predictions" / "tf4" / "ynet.parquet",
                              {**metadata("ynet", table), "seeds": [0]})
        elif ynet_at_2 == "stored":
            write_predictions(predictions_table(arrays.window_id, exact),
                              root / "predictions" / "tf2" / "ynet.parquet",
                              {**metadata("ynet", table), "seeds": [0]})
        else:
            write_no_predictions(root / "predictions" / "tf2" / "ynet.parquet",
                                 metadata("ynet", table), "not trained at 2 s")
    arrays = to_arrays(release.query("split == 'test'"), N_PAST)
    write_predictions(predictions_table(arrays.window_id, arrays.future[:, None] + [4.0, 0.0]),
                      root / "predictions" / "release_tf2" / "ynet.parquet",
                      {**metadata("ynet", root / "release_tf2.parquet"), "seeds": [0]})
    return {"release": root / "release_tf2.parquet"}


def run_stage(root: Path, monkeypatch) -> dict:
    params = {**read_params(),
              "windows": {"n_past": N_PAST, "horizons": [4, 2], "release_horizon": 2}}
    monkeypatch.setattr(stage, "read_params", lambda: params)
    (root / "ckpt_tf4").mkdir()
    stage.main(["--horizon-windows", str(root / "horizon_windows"),
                "--release-windows", str(root / "release_tf2.parquet"),
                "--predictions", str(root / "predictions"),
                "--ynet-checkpoints", str(root / "ckpt_tf4"),
                "--main-model", str(root / "main.pt"), "--main-history", str(root / "main.csv"),
                "--semantic-maps", str(root / "maps"), "--sdd", str(root / "sdd"),
                "--out", str(root / "out.json"), "--figures", str(root / "figures")])
    return json.loads((root / "out.json").read_text())


def test_the_stage_on_two_horizons_without_a_model_to_rerun(tmp_path, monkeypatch):
    """The subject is 'stored' at 4 s and on the release windows, but neither its 4-s checkpoint nor
    the main model exists: the own-horizon rows say why; everything else is scored."""
    project(tmp_path, ynet_at_2="not run")
    record = run_stage(tmp_path, monkeypatch)
    assert record["horizons"] == [2, 4]
    data = record["per_horizon"]["tf4"]["data"]
    assert data["windows"] == 3 and data["sources"] == {"release_chain": 3}
    assert data["tracks"] == 3 and data["videos"] == 2
    assert data["speed_px_s"]["median"] == pytest.approx(2.0)
    assert data["standing_share"] == pytest.approx(2 / 3)  # 0 and 8 px net, 120 px
    models = record["per_horizon"]["tf4"]["models"]
    assert models["constant_velocity"]["ade"] == 0.0
    assert models["ynet"]["ade"] == pytest.approx(3.0) and models["ynet"]["fde"] == 0.0
    assert models["ynet"]["per_window"] == {"ade": [3.0, 3.0, 3.0], "fde": [0.0, 0.0, 0.0]}
    assert models["ynet"]["endpoints"]["spread_px"]["median"] == 0.0  # K = 1
    assert models["ynet"]["endpoints"]["reach_px"]["median"] == pytest.approx(8.0)  # its goal: truth
    assert record["per_horizon"]["tf2"]["models"]["ynet"]["ade"] == pytest.approx(4.0)  # release
    assert record["per_horizon"]["tf4"]["straight_to_goal"]["ade"] == pytest.approx(0.0)
    one = record["one_population"]
    assert one["horizon"] == 4 and one["windows"] == 3
    truncated = one["per_horizon"]["tf2"]["longest_predictions_truncated"]
    assert truncated["ynet"]["ade"] == pytest.approx(3.0) and truncated["ynet"]["fde"] == pytest.approx(3.0)
    own = one["per_horizon"]["tf4"]["own_horizon_models"]["ynet"]
    assert "not_run" in own  # the stored 4-s file exists, its checkpoint does not
    assert record["ynet_training"]["tf4"] == {"trained": False, "reason": own["not_run"]}
    assert record["leak_check"]["total"] == 0
    assert all((tmp_path / "figures" / name).stat().st_size > 0 for name in report.FIGURES.values())

    section = report.section(record)
    assert [r["t_f"] for r in section["rows"]] == [2, 4]
    row = section["rows"][1]
    assert row["test_windows"] == 3 and row["release_chain"] == 3 and row["raw"] == 0
    assert row["cv_ade"] == 0.0 and row["ynet_ade"] == pytest.approx(3.0)
    assert row["ynet_fde_over_ade"] == 0.0
    assert section["rows"][0]["ynet_ade"] == pytest.approx(4.0)
    rows = section["one_population"]["rows"]
    assert rows[0]["ynet_ade"] == pytest.approx(3.0) and rows[0]["own_ynet_ade"] is None
    assert section["leak_total"] == 0
    assert section["figures"] == list(report.FIGURES.values())  # names in the stage's folder


def test_own_horizon_rows_say_why_a_horizon_was_not_trained(tmp_path, monkeypatch):
    project(tmp_path, ynet_at_2="not run")
    (tmp_path / "predictions" / "release_tf2" / "ynet.parquet").unlink()
    record = run_stage(tmp_path, monkeypatch)
    assert record["per_horizon"]["tf2"]["models"]["ynet"] == {"not_run": "not trained at 2 s"}
    assert record["ynet_training"]["tf2"] == {"trained": False, "reason": "not trained at 2 s"}
    own = record["one_population"]["per_horizon"]["tf2"]["own_horizon_models"]["ynet"]
    assert own == {"not_run": "not trained at 2 s"}


def test_report_rows_of_an_empty_record():
    assert report.section({}) == {
        "rows": [], "one_population": {"horizon": None, "windows": None, "rows": []},
        "findings": {"per_horizon_grows": None, "one_population_grows": None,
                     "own_models_grow": None, "fastest": None, "slowest": None, "leak_total": None,
                     "goal_spread_px": None},
        "leak_total": None, "figures": []}


def test_grows_needs_a_rise_at_every_step_and_skips_absent_values():
    assert report.grows([1.0, 2.0, None, 3.0]) is True
    assert report.grows([1.0, 3.0, 2.0]) is False
    assert report.grows([2.0, 2.0]) is False
    assert report.grows([None, 5.0]) is None


def test_findings_read_the_plateau_off_the_record():
    def horizon(ade, speed):
        return {"data": {"windows": 3, "speed_px_s": {"median": speed}}, "models": {"ynet": {"ade": ade}}}
    record = {"per_horizon": {"tf30": horizon(50.0, 22.7), "tf40": horizon(48.0, 4.1)},
              "one_population": {"horizon": 40, "windows": 3, "per_horizon": {
                  "tf30": {"longest_predictions_truncated": {"ynet": {"ade": 39.0, "fde": 70.0}},
                           "own_horizon_models": {"ynet": {"ade": 41.0, "fde": 72.0}}},
                  "tf40": {"longest_predictions_truncated": {"ynet": {"ade": 48.0, "fde": 80.0}},
                           "own_horizon_models": {"ynet": {"ade": 48.0, "fde": 80.0}}}}},
              "leak_check": {"total": 0},
              "figures": {"curves": "reports/figures/horizons/curves.png"}}
    found = report.findings(record)
    assert found["per_horizon_grows"] is False        # the plateau, per horizon ...
    assert found["one_population_grows"] is True      # ... gone on one population
    assert found["own_models_grow"] is True
    assert found["fastest"] == (22.7, 30) and found["slowest"] == (4.1, 40)
    assert found["leak_total"] == 0
    assert found["goal_spread_px"] is None  # no goal spreads in this record
    assert report.section(record)["figures"] == ["curves.png"]


def test_goal_spread_span_counts_only_the_release_horizon_and_beyond():
    def horizon(spread):
        return {"data": {"windows": 1}, "models": {"ynet": {"ade": 1.0, "endpoints": {"spread_px": {"median": spread}}}}}
    record = {"per_horizon": {"tf20": horizon(400.0), "tf30": horizon(537.0), "tf60": horizon(602.0)}}
    assert report.findings(record)["goal_spread_px"] == (537.0, 602.0)
