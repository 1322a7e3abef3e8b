"""`bench/cluster_projection.py`: the list scheduler and critical path behind the projected wall time
of the `paper` workload on G GPUs, the tasks it builds from the stage plan, the ETH/UCY rate it
estimates from map pixels, and its smoke run."""

import sys
from pathlib import Path

import pandas as pd
import pytest

from bench import cluster_projection as cp
from bench.projection import YNET_ETHUCY, YNET_SDD, Count, Run, StagePlan, count_keys, paper_stages
from pipeline.config.loading import read_params

ROOT = Path(__file__).resolve().parents[1]
Task = cp.Task


def test_independent_equal_tasks_fill_four_gpus_evenly():
    tasks = [Task(f"t{i}", 2.0) for i in range(8)]
    schedule = cp.list_schedule(tasks, 4)
    assert schedule.makespan == 4.0 and schedule.utilisation == 1.0
    assert sorted(gpu for gpu, _ in schedule.placed.values()) == [0, 0, 1, 1, 2, 2, 3, 3]
    assert cp.list_schedule(tasks, 1).makespan == 16.0


def test_a_chain_bounds_the_makespan_whatever_the_gpus():
    chain = [Task("a", 1.0), Task("b", 2.0, ("a",)), Task("c", 3.0, ("b",))]
    for gpus in (1, 4, 8):
        schedule = cp.list_schedule([*chain, Task("x", 1.0)], gpus)
        assert schedule.placed["b"][1] == 1.0 and schedule.placed["c"][1] == 3.0
        assert schedule.makespan == (7.0 if gpus == 1 else 6.0)  # 1 GPU: x after the chain
    assert cp.critical_path([*chain, Task("x", 1.0)]) == (6.0, ["a", "b", "c"])
    assert cp.list_schedule(chain, 4).utilisation == pytest.approx(6 / 24)


def test_longest_ready_task_goes_first():
    # LPT on 2 GPUs: 3 and 3 first, then 2 and 2: 5 h (in the listed order 2, 2, 3, 3 it would be 6)
    tasks = [Task("short1", 2.0), Task("short2", 2.0), Task("long1", 3.0), Task("long2", 3.0)]
    schedule = cp.list_schedule(tasks, 2)
    assert {schedule.placed["long1"][1], schedule.placed["long2"][1]} == {0.0}
    assert schedule.makespan == 5.0


def test_a_gpu_waits_for_a_need_and_does_not_take_an_unready_task():
    tasks = [Task("seg", 1.0), Task("ynet", 5.0, ("seg",)), Task("gan", 0.5)]
    schedule = cp.list_schedule(tasks, 2)
    assert schedule.placed["seg"][1] == 0.0 and schedule.placed["gan"][1] == 0.0
    assert schedule.placed["ynet"][1] == 1.0 and schedule.makespan == 6.0


def test_a_cycle_or_an_unknown_need_is_an_error():
    with pytest.raises(ValueError, match="cycle"):
        cp.list_schedule([Task("a", 1.0, ("b",)), Task("b", 1.0, ("a",))], 2)
    with pytest.raises(ValueError, match="cycle"):
        cp.critical_path([Task("a", 1.0, ("b",)), Task("b", 1.0, ("a",))])
    with pytest.raises(ValueError, match="unknown"):
        cp.list_schedule([Task("a", 1.0, ("nope",))], 1)
    with pytest.raises(ValueError):
        cp.list_schedule([Task("a", 1.0)], 0)


def test_plan_tasks_makes_one_task_per_run_with_the_dvc_needs():
    stages = [StagePlan("segmentation", "crops", "seg", [Run("U-Net", 10, 360, "x")]),
              StagePlan("train_ynet", "samples", "y", [Run("t_f 30", 1, 3600, "x")]),
              StagePlan("train_ynet_horizon", "samples", "y",
                        [Run("t_f 5", 2, 3600, "x"), Run("t_f 10", 1, None, "needs data/h/tf10.parquet")]),
              StagePlan("train_baseline (sgan)", "train windows", "gan", [Run("t_f 5", 1, 10, "x")])]
    tasks, left_out = cp.plan_tasks(stages, {"seg": 1.0, "y": 1.0}, {cp.SEMANTIC_MAPS: 36})
    by_name = {task.name: task for task in tasks}
    assert by_name["segmentation [U-Net]"].hours == 1.0
    assert by_name["semantic_maps"] == Task("semantic_maps", 0.01, ("segmentation [U-Net]",))
    assert by_name["train_ynet [t_f 30]"].needs == ("semantic_maps",)
    assert by_name["train_ynet_horizon [t_f 5]"] == Task(
        "train_ynet_horizon [t_f 5]", 2.0, ("semantic_maps", "train_ynet [t_f 30]"))
    assert left_out == ["train_ynet_horizon [t_f 10]: needs data/h/tf10.parquet",
                        "train_baseline (sgan) [t_f 5]: no rate 'gan'"]


def test_the_paper_plan_schedules_and_its_horizon_ynets_follow_the_main_one():
    params = read_params()
    counts = {key: Count(100, "x") for key in count_keys(params)}
    rates = {YNET_SDD: 50.0, YNET_ETHUCY: 25.0, "segmentation": 20.0, "sgan": 300.0, "pecnet": 1000.0}
    tasks, left_out = cp.plan_tasks(paper_stages(params, counts), rates, {})
    assert left_out == []
    first = cp.list_schedule(tasks, 1)
    assert first.makespan == pytest.approx(sum(task.hours for task in tasks))
    many = cp.list_schedule(tasks, 8)
    end = many.placed["train_ynet [t_f 30]"][1] + {t.name: t for t in tasks}["train_ynet [t_f 30]"].hours
    horizons = [name for name in many.placed if name.startswith("train_ynet_horizon")]
    assert len(horizons) == len(params["ynet_horizons"]["paper"]["epochs"])
    assert all(many.placed[name][1] >= end for name in horizons)
    assert cp.critical_path(tasks)[0] <= many.makespan <= first.makespan


def test_padded_pixels_and_the_window_weighted_mean():
    assert cp.padded_pixels(1088, 1424, 0.25) == 288 * 384  # 272 x 356 -> 288 x 384
    assert cp.padded_pixels(480, 640, 2 / 3) == 320 * 448  # 320 x 427
    sizes = {"a": (128, 128), "b": (256, 128)}
    assert cp.mean_sample_pixels({"a": 3, "b": 1}, sizes, 0.25) == (3 * 32 * 32 + 64 * 32) / 4
    with pytest.raises(ValueError):
        cp.mean_sample_pixels({}, sizes, 0.25)


def test_the_ethucy_rate_is_the_sdd_rate_scaled_by_pixels_and_labelled_estimated():
    measured = {"rates": {YNET_SDD: 50.0}, "sources": {YNET_SDD: "measured"}}
    estimated = cp.with_ethucy_estimate(measured, (100_000, 200_000))
    assert estimated["rates"][YNET_ETHUCY] == 25.0
    assert estimated["sources"][YNET_ETHUCY].startswith(cp.ESTIMATED_FROM_FLOPS)
    assert measured["rates"] == {YNET_SDD: 50.0}  # not changed in place
    given = {"rates": {YNET_SDD: 50.0, YNET_ETHUCY: 30.0}}
    assert cp.with_ethucy_estimate(given, (1, 2)) is given  # a measured one wins
    missing = cp.with_ethucy_estimate(measured, "needs data/short_term/ethucy_eth.parquet")
    assert YNET_ETHUCY not in missing["rates"]
    assert missing["sources"][YNET_ETHUCY] == "not estimated: needs data/short_term/ethucy_eth.parquet"


def test_train_windows_per_scene_counts_distinct_train_windows(tmp_path):
    rows = [(0, "a", "train"), (0, "a", "train"), (1, "a", "train"), (2, "b", "train"), (3, "b", "val")]
    pd.DataFrame(rows, columns=["window_id", "scene_id", "split"]).to_parquet(tmp_path / "t.parquet")
    assert cp.train_windows_per_scene([tmp_path / "t.parquet"] * 2) == {"a": 4, "b": 2}


def test_the_table_gives_speed_up_and_utilisation():
    lines = cp.projection_table([cp.Schedule(1, 48.0, {}, 48.0), cp.Schedule(4, 16.0, {}, 48.0)])
    assert lines[1].split() == ["1", "48.0", "2.00", "1.00x", "100%"]
    assert lines[2].split() == ["4", "16.0", "0.67", "3.00x", "75%"]


def test_the_smoke_run_prints_the_table_and_the_critical_path(monkeypatch, capsys):
    """`python -m bench.cluster_projection --smoke`'s `main`, in this process (a subprocess spent
    its CPU importing torch again)."""
    monkeypatch.chdir(ROOT)
    monkeypatch.setattr(sys, "argv", ["cluster_projection", "--smoke"])
    cp.main()
    stdout = capsys.readouterr().out
    assert "critical path:" in stdout and "utilisation" in stdout
    assert cp.ESTIMATED_FROM_FLOPS in stdout
