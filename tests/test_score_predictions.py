"""Stage `score_predictions` on a fixture small enough to check by hand: three windows of two
videos, two models (one with Y-net-like goals), a model that was not run, a release-style table,
and predictions files that do not fit their table.

The fixture (t_f = 2 s, n_past = 2, every position in pixels):
- gates_2 (0.1 m per pixel: miss 2 m = 20 px, collision 0.2 m = 2 px), mask 10 x 10 with the
  columns x >= 6 structure (forbidden), the rest pavement;
  window 10, track 1: future (1, 1), (3, 1) at frames 60, 90;
  window 11, track 2: future (4, 1), (8, 1) at the same frames (3 and 5 px from window 10);
- hyang_0 (0.05 m per pixel: miss 40 px, collision 4 px), mask 40 x 10 all pavement;
  window 20, track 1: future (2, 2), (2, 4), alone in its video.
Ground truth: off-limits shares (0, 1/2, 0): window 11's (8, 1) lies on structure; mean 1/6. No
truth collides (3 px = 0.3 m apart at the closest); windows 10 and 11 are co-present: 2/3.
"""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import yaml

from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.data.window_table import conform
from pipeline.harness.predictions import predictions_table, write_no_predictions, write_predictions
from pipeline.io import write_parquet
from pipeline.stages import score_predictions
from ynet.segmentation import CLASS_NAMES

PAVEMENT, STRUCTURE = CLASS_NAMES.index("pavement"), CLASS_NAMES.index("structure")
FUTURE = {10: [[1.0, 1.0], [3.0, 1.0]], 11: [[4.0, 1.0], [8.0, 1.0]], 20: [[2.0, 2.0], [2.0, 4.0]]}
SCENE = {10: "gates_2", 11: "gates_2", 20: "hyang_0"}
TRACK = {10: 1, 11: 2, 20: 1}
IDS = np.array([10, 11, 20])

# Samples around the truth at every step: the triangle of tests/test_scoring.py, whose KDE gives
# the truth log-density -log(2 pi) - log(3) / 6 - 2 * 3^(-2/3) wherever it is shifted to (window
# 11 holds the same three samples in another order: the same KDE).
TRIANGLE = np.array([[-1.0, -1.0], [1.0, -1.0], [0.0, 2.0]])  # (K=3, 2)
TRIANGLE_NLL = math.log(2 * math.pi) + math.log(3) / 6 + 2 * 3 ** (-2 / 3)  # 2.98248
ORDER = {10: [0, 1, 2], 11: [1, 0, 2], 20: [0, 1, 2]}


def window_table(ids_offset: int = 0) -> pd.DataFrame:
    """The three windows: 2 observed steps (frames 0, 30) and the 2 future ones (60, 90)."""
    rows = []
    for w, future in FUTURE.items():
        past = [[future[0][0] - 2, future[0][1]], [future[0][0] - 1, future[0][1]]]
        for step, (x, y) in enumerate(past + future):
            rows.append({"window_id": w + ids_offset, "scene_id": SCENE[w], "track_id": TRACK[w],
                         "step": step, "frame": 30 * step, "x": x, "y": y, "split": "test",
                         "t_f": 2, "source": "raw"})
    return conform(pd.DataFrame(rows))


def write_labels(folder: Path) -> None:
    gates = np.full((10, 10), PAVEMENT, np.uint8)
    gates[:, 6:] = STRUCTURE
    hyang = np.full((40, 10), PAVEMENT, np.uint8)
    (folder / "maps").mkdir(parents=True)
    videos = {}
    for name, mask in (("gates_2", gates), ("hyang_0", hyang)):
        cv2.imwrite(str(folder / "maps" / f"{name}.png"), mask)
        videos[name] = {"split": "test", "height": mask.shape[0], "width": mask.shape[1]}
    (folder / "index.json").write_text(json.dumps(
        {"classes": list(CLASS_NAMES), "pad_class": 0, "videos": videos}))


def triangle_round(shifts: dict[int, tuple[float, float]]) -> np.ndarray:
    """(3, K=3, T=2, 2): each window's truth + the triangle (in its order) + its shift."""
    return np.stack([np.array(FUTURE[w])[None] + TRIANGLE[ORDER[w]][:, None]
                     + np.array(shifts.get(w, (0.0, 0.0))) for w in IDS])


def triangle_model() -> pd.DataFrame:
    """Round 0: the triangles. Round 1: window 10 shifted (25, 0) (off the 10-px mask, a miss at
    24.02 px > 20), window 20 (0, 30) (29.02 px: a hit at hyang's 40 px)."""
    rounds = [triangle_round({}), triangle_round({10: (25.0, 0.0), 20: (0.0, 30.0)})]
    return pd.concat([predictions_table(IDS, samples, round=r) for r, samples in enumerate(rounds)],
                     ignore_index=True)


def goal_model(ids: np.ndarray = IDS) -> pd.DataFrame:
    """One round, K = 3 paths on the truth (ADE 0, a degenerate KDE), goals away from the true
    endpoint by 5, 10, 30 px (windows 10, 11) and all 50 px (window 20)."""
    samples = np.stack([np.repeat(np.array(FUTURE[w])[None], 3, axis=0) for w in IDS])
    end = samples[:, :, -1]  # (3, K, 2)
    goals = end + np.array([[[3.0, 4.0], [6.0, 8.0], [0.0, 30.0]]] * 2 + [[[0.0, 50.0]] * 3])
    return predictions_table(ids, samples, goals=goals)


def metadata(model: str, table: Path, seeds: list[int]) -> dict:
    return {"model": model, "benchmark": SDD_LONG_TERM.prediction_benchmark(table), "unit": "px",
            "seeds": seeds}


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """Window tables, masks, scales, params and predictions files as the real stages lay them out."""
    write_parquet(window_table(), tmp_path / "horizon_windows" / "tf2.parquet")
    release = tmp_path / "windows" / "release_tf2.parquet"
    write_parquet(window_table(ids_offset=100), release)  # the same windows under other ids
    write_labels(tmp_path / "labels")
    (tmp_path / "estimated_scales.yaml").write_text(yaml.safe_dump({
        "gates": {"video2": {"scale": 0.1, "certainty": 1.0}},
        "hyang": {"video0": {"scale": 0.05, "certainty": 0.9}}}))
    params = {"windows": {"n_past": 2, "horizons": [2]},
              "score_predictions": {"miss_threshold_m": 2.0, "collision_threshold_m": 0.2,
                                    "log_pdf_floor": -20.0,
                                    "forbidden_classes": ["structure", "tree"]}}
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    horizon, folder = tmp_path / "horizon_windows" / "tf2.parquet", tmp_path / "predictions"
    write_predictions(triangle_model(), folder / "tf2" / "triangle.parquet",
                      metadata("triangle", horizon, [0, 1]))
    write_predictions(goal_model(), folder / "tf2" / "ynet.parquet",
                      metadata("ynet", horizon, [7]))
    write_no_predictions(folder / "tf2" / "sgan.parquet", metadata("sgan", horizon, []),
                         "S-GAN is not trained at t_f = 2 s here")
    write_predictions(goal_model(IDS + 100), folder / "release_tf2" / "ynet.parquet",
                      metadata("ynet", release, [7]))
    write_ind_not_provided(tmp_path)
    return tmp_path


IND_REASON = "inD is licence-restricted and not redistributed"


def write_ind_not_provided(root: Path) -> None:
    """What `ind_windows` and `evaluate_ind` write without inD: an index giving the reason, empty
    tables, and one empty predictions file per model giving it too."""
    (root / "ind").mkdir()
    (root / "ind" / "index.json").write_text(json.dumps({
        "horizon": 30, "n_past": 5, "provided": False, "reason": IND_REASON, "scenes": {},
        "tables": {"30": "tf30.parquet", "5": "tf5.parquet"}}))
    for model in ("ynet", "sgan"):
        write_no_predictions(root / "ind_predictions" / f"{model}.parquet",
                             {"model": model, "benchmark": "ind_long_term", "unit": "px",
                              "split": "test"}, IND_REASON)


def run(root: Path, record: str = "long_term") -> dict:
    out = root / "metrics" / "beyond"
    score_predictions.main([
        "--predictions", str(root / "predictions"), "--horizon-windows",
        str(root / "horizon_windows"), "--release-windows", str(root / "windows/release_tf2.parquet"),
        "--labels", str(root / "labels"), "--scales", str(root / "estimated_scales.yaml"),
        "--ind", str(root / "ind"), "--ind-predictions", str(root / "ind_predictions"),
        "--out", str(out / "long_term.json"), "--ind-out", str(out / "ind.json"),
        "--params", str(root / "params.yaml")])
    return json.loads((out / f"{record}.json").read_text())


def test_triangle_model_by_hand(project):
    record = run(project)
    assert record["unit"] == "px" and record["thresholds"]["miss_threshold_m"] == 2.0
    table = record["tables"]["tf2"]
    assert table["t_f"] == 2 and sorted(table["models"]) == ["sgan", "triangle", "ynet"]
    got = table["models"]["triangle"]
    assert (got["rounds"], got["seeds"], got["k"], got["t"], got["n_windows"], got["n_scenes"]) \
        == (2, [0, 1], 3, 2, 3, 2)
    m = got["metrics"]
    r2, r577, r842 = math.sqrt(2), math.sqrt(577), math.sqrt(842)

    def check(name, per_round):
        assert m[name]["per_round"] == pytest.approx(per_round, abs=1e-12), name
        assert m[name]["mean"] == pytest.approx(np.mean(per_round), abs=1e-12), name
        assert m[name]["std"] == pytest.approx(np.std(per_round), abs=1e-12), name

    # Round 0: every sample 2^0.5 (samples 0, 1) or 2 (sample 2) from the truth at both steps.
    # Round 1: window 10's best sample (24, -1) away: 577^0.5; window 20's (+-1, 29): 842^0.5.
    for name in ("ade", "fde", "ade_joint", "fde_joint", "ade_best_endpoint"):
        check(name, [r2, (r577 + r2 + r842) / 3])
    # Miss: 24.02 px > 20 px (gates) is one; 29.02 px < 40 px (hyang, 0.05 m/px) is not.
    check("miss_rate", [0.0, 1 / 3])
    # NLL: the triangle's at every step; shifted 25 or 30 px the log-density is below the floor.
    check("kde_nll", [TRIANGLE_NLL, (20 + TRIANGLE_NLL + 20) / 3])
    check("kde_degenerate_share", [0.0, 0.0])
    assert got["kde_nll_per_step"]["mean"] == pytest.approx(
        [(TRIANGLE_NLL + (40 + TRIANGLE_NLL) / 3) / 2] * 2, abs=1e-12)
    # Off limits: window 11's second step (9, 0), (7, 0), (8, 3) all on structure: 3 of 6, the
    # others on pavement. Round 1: window 10 lies off its mask entirely (left out): (1/2 + 0) / 2.
    check("off_limits_share", [1 / 6, 1 / 4])
    # Collisions: at frame 60 sample 1 of window 10 (2, 0) and of window 11 (3, 0) are 1 px
    # = 0.1 m apart: 1 of 3 samples in both; in round 1 window 10 is 25 px away: none.
    check("collision_rate", [(1 / 3 + 1 / 3 + 0) / 3, 0.0])
    assert got["ground_truth"] == pytest.approx({"off_limits_share": 1 / 6, "collision_rate": 0.0,
                                                 "copresent_share": 2 / 3}, abs=1e-12)


def test_per_scene_means(project):
    scenes = run(project)["tables"]["tf2"]["models"]["triangle"]["per_scene"]
    assert sorted(scenes) == ["gates_2", "hyang_0"]
    gates, hyang = scenes["gates_2"], scenes["hyang_0"]
    assert (gates["n_windows"], hyang["n_windows"]) == (2, 1)
    r2, r577, r842 = math.sqrt(2), math.sqrt(577), math.sqrt(842)
    assert gates["metrics"]["ade"]["mean"] == pytest.approx((r2 + (r577 + r2) / 2) / 2)
    assert hyang["metrics"]["ade"]["mean"] == pytest.approx((r2 + r842) / 2)
    assert hyang["metrics"]["ade"]["std"] == pytest.approx((r842 - r2) / 2)
    assert gates["metrics"]["miss_rate"]["mean"] == pytest.approx(0.25)  # (0 + 1/2) / 2
    assert gates["ground_truth"] == pytest.approx({"off_limits_share": 0.25, "collision_rate": 0.0,
                                                   "copresent_share": 1.0})
    assert hyang["ground_truth"]["copresent_share"] == 0.0


def test_sgan_sequence_metrics_over_windows_that_start_together(project):
    """Windows 10 and 11 (gates_2) start at frame 0: one sequence; window 20 (hyang_0) is its own.
    The triangle's samples are as far from the truth at both steps (2^0.5, 2^0.5, 2), so ADE and
    FDE agree. Round 0: gates min(2 2^0.5, 2 2^0.5, 4) / 2, hyang 2^0.5. Round 1: window 10's
    samples 577^0.5, 677^0.5, 629^0.5 with window 11's 2^0.5, 2^0.5, 2: (577^0.5 + 2^0.5) / 2;
    hyang 842^0.5. Over all: sum of the sequence minima / 3 windows."""
    record = run(project)
    got = record["tables"]["tf2"]["models"]["triangle"]
    r2, r577, r842 = math.sqrt(2), math.sqrt(577), math.sqrt(842)
    gates, hyang = [r2, (r577 + r2) / 2], [r2, r842]
    for name in ("ade_sgan_sequence", "fde_sgan_sequence"):
        assert got["metrics"][name]["per_round"] == pytest.approx([r2, (r577 + r2 + r842) / 3])
        for scene, per_round in (("gates_2", gates), ("hyang_0", hyang)):
            assert got["per_scene"][scene]["metrics"][name] == pytest.approx(
                {"mean": np.mean(per_round), "std": np.std(per_round)}), (name, scene)
    # Y-net: FDE on the goals (5, 10, 30 px for both gates windows, 50 for hyang's): gates
    # min(10, 20, 60) + 50 = 60 over 3 windows; per scene 10 / 2 and 50. Paths on the truth: ADE 0.
    ynet = record["tables"]["tf2"]["models"]["ynet"]
    assert ynet["metrics"]["fde_sgan_sequence"]["per_round"] == pytest.approx([20.0])
    assert ynet["per_scene"]["gates_2"]["metrics"]["fde_sgan_sequence"]["mean"] == 5.0
    assert ynet["metrics"]["ade_sgan_sequence"]["per_round"] == [0.0]


def test_one_sample_metrics_average_each_windows_samples(project):
    """The triangle's samples are 2^0.5, 2^0.5, 2 from the truth at both steps: one sample
    a = (2 2^0.5 + 2) / 3 for ADE and FDE alike. Round 1: window 10's 577^0.5, 677^0.5,
    629^0.5 and window 20's 842^0.5, 842^0.5, 32 (window 11 still a)."""
    record = run(project)
    got = record["tables"]["tf2"]["models"]["triangle"]
    a = (2 * math.sqrt(2) + 2) / 3
    w10 = (math.sqrt(577) + math.sqrt(677) + math.sqrt(629)) / 3
    w20 = (2 * math.sqrt(842) + 32) / 3
    for name in ("ade_one_sample", "fde_one_sample"):
        assert got["metrics"][name]["per_round"] == pytest.approx([a, (w10 + a + w20) / 3])
        for scene, per_round in (("gates_2", [a, (w10 + a) / 2]), ("hyang_0", [a, w20])):
            assert got["per_scene"][scene]["metrics"][name] == pytest.approx(
                {"mean": np.mean(per_round), "std": np.std(per_round)}), (name, scene)
    # Every sample is worse than the best: above min-ADE in both rounds.
    assert all(one > best for one, best in zip(got["metrics"]["ade_one_sample"]["per_round"],
                                               got["metrics"]["ade"]["per_round"]))
    assert list(got["metrics"])[-4:] == ["ade_sgan_sequence", "fde_sgan_sequence",
                                         "ade_one_sample", "fde_one_sample"]
    # Y-net: paths on the truth (ADE 0), FDE on the goals: (5 + 10 + 30) / 3 twice, 50: 80 / 3.
    ynet = record["tables"]["tf2"]["models"]["ynet"]["metrics"]
    assert ynet["ade_one_sample"]["per_round"] == [0.0]
    assert ynet["fde_one_sample"]["per_round"] == pytest.approx([80 / 3])


def test_goals_are_the_endpoints_of_fde_best_endpoint_and_miss(project):
    record = run(project)
    for name in ("tf2", "release_tf2"):  # the release-style table: the same windows, other ids
        m = record["tables"][name]["models"]["ynet"]["metrics"]
        assert m["ade"]["per_round"] == [0.0] and m["ade_best_endpoint"]["mean"] == 0.0
        assert m["fde"]["mean"] == pytest.approx((5 + 5 + 50) / 3)  # on the goals, not the paths
        assert m["fde_joint"]["mean"] == pytest.approx(20.0)  # sample 0, the first best ADE
        assert m["miss_rate"]["mean"] == pytest.approx(1 / 3)  # window 20: 50 px > 40 px
        assert m["kde_nll"]["mean"] == 20.0 and m["kde_degenerate_share"]["mean"] == 1.0
        assert m["off_limits_share"]["mean"] == pytest.approx(1 / 6)  # paths on the truth
        assert m["ade"]["std"] == 0.0  # one round: no spread
    assert record["tables"]["release_tf2"]["window_table"].endswith("windows/release_tf2.parquet")


def test_a_model_not_run_is_listed_with_its_reason(project):
    sgan = run(project)["tables"]["tf2"]["models"]["sgan"]
    assert sgan["not_run_reason"] == "S-GAN is not trained at t_f = 2 s here"
    assert "metrics" not in sgan and sgan["model"] == "sgan"


BAD_FILES = {  # predictions file (ids, samples, the table it says it is for) -> what is wrong
    "ids not in the table": (np.array([10, 11, 99]), None, "horizon_windows/tf2.parquet",
                             r"1 of 3 window id\(s\) are not in .*tf2\.parquet, e\.g\. \[99\]"),
    "another table's file": (IDS + 100, None, "windows/release_tf2.parquet",
                             r"benchmark 'sdd_long_term_release_tf2', but it is scored against "
                             r".*horizon_windows/tf2\.parquet"),
    "another length": (IDS, np.zeros((3, 3, 3, 2)), "horizon_windows/tf2.parquet",
                       r"3 predicted steps, but the windows of .* have 2 future steps"),
}


@pytest.mark.parametrize("case", BAD_FILES)
def test_a_predictions_file_that_does_not_fit_its_table_is_named(project, case):
    ids, samples, table, message = BAD_FILES[case]
    path = project / "predictions" / "tf2" / "pecnet.parquet"
    predicted = goal_model(ids) if samples is None else predictions_table(ids, samples)
    write_predictions(predicted, path, metadata("pecnet", project / table, [0]))
    with pytest.raises(SystemExit, match=rf"score_predictions: {re.escape(str(path))}: {message}"):
        run(project)


def test_a_broken_predictions_file_is_named(project):
    path = project / "predictions" / "tf2" / "pecnet.parquet"
    path.write_bytes(b"not parquet")
    with pytest.raises(SystemExit, match=rf"score_predictions: {re.escape(str(path))}: "):
        run(project)


# ---------------------------------------------------------------------------------------------
# inD (`--ind-out`): not provided, and a tiny stand-in of a provided copy (no inD data: the
# fixture's windows again, in two made-up recordings)


def test_ind_not_provided_lists_every_file_with_its_reason(project):
    record = run(project, "ind")
    assert record["thresholds"]["miss_threshold_m"] == 2.0
    ind = record["benchmarks"]["ind"]
    assert (ind["benchmark"], ind["unit"], ind["split"]) == ("ind_long_term", "px", "test")
    assert ind["metres_per_unit"] == f"inD not provided: {IND_REASON}"
    assert "n_windows" not in ind and "scene_masks" not in ind  # the empty table is never read
    assert {m: e["not_run_reason"] for m, e in ind["models"].items()} \
        == {"ynet": IND_REASON, "sgan": IND_REASON}


IND_SCENE = {"gates_2": "ind_loc4_rec00", "hyang_0": "ind_loc4_rec01"}


def write_ind_provided(root: Path) -> None:
    """Windows 10, 11 in recording 00 (0.1 m per pixel, the gates_2 mask as its hand labels),
    window 20 in recording 01 (0.05 m per pixel, no labels), and a train window 30."""
    shutil.rmtree(root / "ind")
    (root / "ind" / "labels").mkdir(parents=True)
    table = window_table().replace({"scene_id": IND_SCENE})
    train = table.loc[table["window_id"] == 20].assign(window_id=30, split="train")
    write_parquet(conform(pd.concat([table, train])), root / "ind" / "tf2.parquet")
    mask = np.full((10, 10), PAVEMENT, np.uint8)
    mask[:, 6:] = STRUCTURE
    cv2.imwrite(str(root / "ind" / "labels" / "ind_loc4_rec00.png"), mask)
    scenes = {"ind_loc4_rec00": {"ortho_px_to_meter": 0.1 / 12, "height": 10, "width": 10,
                                 "labels": "labels/ind_loc4_rec00.png"},
              "ind_loc4_rec01": {"ortho_px_to_meter": 0.05 / 12, "height": 40, "width": 10,
                                 "labels": None}}
    (root / "ind" / "index.json").write_text(json.dumps({
        "provided": True, "n_past": 2, "horizon": 2, "tables": {"2": "tf2.parquet"},
        "background_scale": 12, "scenes": scenes}))
    for path in (root / "ind_predictions").glob("*.parquet"):
        path.unlink()
    write_predictions(triangle_model(), root / "ind_predictions" / "triangle.parquet",
                      {"model": "triangle", "benchmark": "ind_long_term", "unit": "px",
                       "split": "test", "seeds": [0, 1]})


def test_ind_provided_scores_with_its_scales_and_the_masks_it_has(project):
    write_ind_provided(project)
    ind = run(project, "ind")["benchmarks"]["ind"]
    assert (ind["n_windows"], ind["n_future"]) == (3, 2)  # the test windows only
    assert ind["scene_masks"]["scenes_with_mask"] == ["ind_loc4_rec00"]
    assert ind["scene_masks"]["scenes_without_mask"] == ["ind_loc4_rec01"]
    assert ind["scene_masks"]["windows_with_mask"] == 2
    m = ind["models"]["triangle"]["metrics"]
    # The same scales as gates_2 / hyang_0 (orthoPxToMeter x 12): the same misses.
    assert m["miss_rate"]["per_round"] == pytest.approx([0.0, 1 / 3])
    # Off limits only where a mask exists: round 0 windows 10, 11 (0, 1/2); round 1 window 11.
    assert m["off_limits_share"]["per_round"] == pytest.approx([1 / 4, 1 / 2])
    assert ind["models"]["triangle"]["ground_truth"]["off_limits_share"] == pytest.approx(1 / 4)
    # Windows 10 and 11 start together in recording 00, as in gates_2: the same sequences.
    assert m["ade_sgan_sequence"]["per_round"] == pytest.approx(
        [math.sqrt(2), (math.sqrt(577) + math.sqrt(2) + math.sqrt(842)) / 3])


def test_ind_train_window_ids_are_not_in_the_test_split(project):
    write_ind_provided(project)
    path = project / "ind_predictions" / "sgan.parquet"
    write_predictions(goal_model(np.array([10, 11, 30])), path,
                      {"model": "sgan", "benchmark": "ind_long_term", "unit": "px",
                       "split": "test", "seeds": [0]})
    with pytest.raises(SystemExit, match=rf"{re.escape(str(path))}: 1 of 3 window id\(s\) are "
                                         rf"not in .*tf2\.parquet, e\.g\. \[30\]"):
        run(project, "ind")
