"""The arithmetic of `bench/projection.py`: TFLOP/s, the paper stages' work from params.yaml and
the window tables' counts (never a guessed count), and their projected hours."""

import json

import pandas as pd
import pytest

from bench import projection
from pipeline.config.loading import read_params
from pipeline.config.ynet import YnetSettings


def test_tflops_per_s_is_flops_over_seconds_in_units_of_1e12():
    assert projection.tflops_per_s(3e12, 2.0) == 1.5
    assert projection.tflops_per_s(5e9, 0.5) == pytest.approx(0.01)
    with pytest.raises(ValueError):
        projection.tflops_per_s(1e12, 0.0)


def test_stage_hours_is_work_over_rate_in_hours():
    assert projection.stage_hours(7200, 1.0) == 2.0
    assert projection.stage_hours(300 * 964 * 8, 33.8) == pytest.approx(19.01, abs=0.01)
    with pytest.raises(ValueError):
        projection.stage_hours(10, 0.0)


def plan(runs, rate="r"):
    return projection.StagePlan("stage", "samples", rate, [projection.Run(*run) for run in runs])


def test_project_sums_the_runs_and_divides_by_the_rate():
    (row,) = projection.project([plan([("a", 2, 100, "x"), ("b", 3, 10, "y")])], {"r": 10.0})
    assert row["work"] == 230 and row["runs"] == 2
    assert row["hours"] == pytest.approx(230 / 10 / 3600)
    assert row["unknown"] == "" and row["epochs"] == [2, 3]


def test_project_leaves_a_stage_unknown_and_says_why():
    missing = plan([("a", 2, 100, "x"), ("b", 3, None, "needs data/t/b.parquet"),
                    ("c", 3, None, "needs data/t/c.parquet")])
    row, unmeasured = projection.project([missing, plan([("a", 1, 5, "x")], "other")], {"r": 1.0})
    assert row["hours"] is None and row["work"] is None
    assert row["unknown"] == "needs data/t/b.parquet, c.parquet"
    assert unmeasured["hours"] is None and "'other' not measured" in unmeasured["unknown"]
    assert projection.total_hours([row, unmeasured]) == (0.0, 2)


def test_total_hours_adds_the_known_rows_only():
    rows = [{"hours": 1.5}, {"hours": None}, {"hours": 2.0}]
    assert projection.total_hours(rows) == (3.5, 1)


def release_table(path, train: int, val: int, steps: int = 35):
    rows = [(w, "train" if w < train else "val") for w in range(train + val) for _ in range(steps)]
    path.parent.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows, columns=["window_id", "split"]).to_parquet(path)


def test_window_counts_reads_the_tables_and_names_the_missing_ones(tmp_path):
    params = read_params()
    release_table(tmp_path / "windows/release_tf30.parquet", train=3, val=2)
    (tmp_path / "labels").mkdir()
    (tmp_path / "labels/index.json").write_text(json.dumps({"videos": {
        "a_0": {"split": "train"}, "a_1": {"split": "train"}, "b_0": {"split": "test"}}}))
    counts = projection.window_counts(tmp_path, params)
    assert counts["release_tf30"] == projection.Count(3, str(tmp_path / "windows/release_tf30.parquet"))
    assert counts["segmentation_videos"].value == 2
    assert counts["horizon_tf60"] == projection.Count(
        None, f"needs {tmp_path / 'horizon_windows/tf60.parquet'}")
    assert counts["short_term_zara2"].value is None


def test_paper_stages_follow_the_paper_sections_of_params():
    params = read_params()
    paper = {k: v["paper"] for k, v in params.items() if isinstance(v, dict) and "paper" in v}
    counts = {key: projection.Count(100, "x") for key in projection.count_keys(params)}
    stages = {s.stage: s for s in projection.paper_stages(params, counts)}
    ynet = YnetSettings(**paper["ynet"])
    main = stages["train_ynet"]
    assert [(r.epochs, r.per_epoch) for r in main.runs] == [(ynet.epochs, 100 * ynet.augmentations)]
    assert len(stages["train_ynet_horizon"].runs) == len(paper["ynet_horizons"]["epochs"])
    assert len(stages["train_ynet_seed"].runs) == len(paper["ynet_seeds"]["seeds"])
    assert {r.label for r in stages["train_short_term_ynet (ETH/UCY)"].runs} == set(
        params["short_term"]["ethucy_folds"])
    assert stages["train_short_term_ynet (ETH/UCY)"].rate == projection.YNET_ETHUCY
    (unet,) = stages["segmentation"].runs
    assert (unet.epochs, unet.per_epoch) == (paper["segmentation"]["epochs"],
                                            100 * paper["segmentation"]["crops_per_image"])
    seeds = stages["train_baseline_seed (pecnet)"].runs
    assert len(seeds) == len(params["windows"]["horizons"]) * len(params["baseline_seeds"]["extra"])
    assert {r.epochs for r in seeds} == {paper["pecnet"]["epochs"]}
    rows = projection.project(list(stages.values()), {projection.YNET_SDD: 10.0})
    known = {row["stage"]: row for row in rows if row["hours"] is not None}
    assert set(known) == {"train_ynet", "train_ynet_horizon", "train_ynet_seed",
                          "train_short_term_ynet (sdd)"}
    assert known["train_ynet_seed"]["hours"] == pytest.approx(
        len(paper["ynet_seeds"]["seeds"]) * known["train_ynet"]["hours"])
    lines = projection.projection_lines(rows, "test device")
    assert len(lines) == len(rows) + 2 and "8 row(s) unknown" in lines[-1]
