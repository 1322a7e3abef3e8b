"""Stage `score_short_term_predictions` on a fixture small enough to check by hand, written with the
writers the real stages use: window tables numbered by
`pipeline.benchmarks.short_term.number_windows`, ETH/UCY maps by `write_ethucy_maps`, predictions
scored and kept by `pipeline.runners.short_term.score` (what evaluate_short_term_* run) and
written with their benchmark's `prediction_metadata`. n_past = n_future = 2.

TrajNet SDD: the windows of tests/test_score_predictions.py (gates_2 at 0.1 m per pixel, hyang_0 at
0.05, the same hand labels), test split, plus a train and a val window.

ETH/UCY, fold zara1 (homography: metres = pixels / 2, no swap; oracle 12 x 12 pixels, road except
the columns x >= 6 px, i.e. x >= 3 m; maps at resize 1/2), future steps at frames 20, 30:
- window 0 (track 1): (1, 1), (2, 1) m;
- window 1 (track 2): (1.1, 1), (4, 1) m: 0.1 m from window 0 at frame 20 (a collision at 0.2 m),
  its last step off the road;
- windows 2 (train) and 3 (val), which no predictions file may name.
Ground truth: off-limits (not-road) shares (0, 1/2), collision in both windows.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import yaml

from pipeline.benchmarks.base import WindowTruth
from pipeline.benchmarks.ethucy import MAPS, SCENES, road_masks, write_ethucy_maps
from pipeline.benchmarks.ind import IND
from pipeline.benchmarks.registry import short_term
from pipeline.benchmarks.short_term import ScoringSources, number_windows
from pipeline.dataset_list import SHORT_TERM_DATASETS
from pipeline.harness import stored_scores
from pipeline.harness.predictions import PredictionRounds, write_no_predictions
from pipeline.harness.stored_scores import forbidden_shares
from pipeline.runners import short_term as runner
from pipeline.stages import score_short_term_predictions
from tests.test_score_predictions import (FUTURE, ORDER, SCENE, TRACK, TRIANGLE, TRIANGLE_NLL,
                                          write_labels)

N_PAST = 2
H = np.diag([0.5, 0.5, 1.0])  # pixels -> metres
SHIFT = 10.0  # m: round 1 moves window 0 this far north (off the 12-px map, a miss at 2 m)
ZARA = {0: ([[1.0, 1.0], [2.0, 1.0]], 1, "test"), 1: ([[1.1, 1.0], [4.0, 1.0]], 2, "test"),
        2: ([[5.0, 5.0], [5.0, 6.0]], 3, "train"), 3: ([[6.0, 5.0], [6.0, 6.0]], 4, "val")}


def rows(scene: str, track: int, future: list, split: str, to_pixels: float, key: int) -> list:
    """One window's rows as `number_windows` takes them (two past steps before `future`)."""
    (x0, y0), first = future[0], 10 * key  # distinct first frames: keys stay apart
    past = [[x0 - 0.5, y0], [x0 - 0.25, y0]]
    out = []
    for step, (x, y) in enumerate(past + future):
        out.append({"scene_id": scene, "track_id": track, "frame": 10 * step + (0 if split == "test"
                                                                              else 1000 + first),
                    "x": x * to_pixels, "y": y * to_pixels, "x_m": x, "y_m": y, "step": step,
                    "window_key": key, "split": split})
    return out


def zara_table() -> pd.DataFrame:
    parts = [r for w, (future, track, split) in ZARA.items()
             for r in rows("zara1", track, future, split, 2.0, w)]
    return number_windows(pd.DataFrame(parts), 2, "sgan")


def sdd_table() -> pd.DataFrame:
    """The long-term fixture's windows (x, y in pixels, 30 frames a step), metres per video."""
    scale = {"gates_2": 0.1, "hyang_0": 0.05}
    parts = []
    for key, (w, future) in enumerate(FUTURE.items()):
        first = np.array(future[0])
        past = [first - [2, 0], first - [1, 0]]
        for step, (x, y) in enumerate([*past, *future]):
            parts.append({"scene_id": SCENE[w], "track_id": TRACK[w], "frame": 30 * step, "x": x,
                          "y": y, "x_m": x * scale[SCENE[w]], "y_m": y * scale[SCENE[w]],
                          "step": step, "window_key": key, "split": "test"})
    for key, (track, split) in enumerate(((8, "train"), (9, "val")), start=10):
        for step in range(4):
            parts.append({"scene_id": "gates_2", "track_id": track, "frame": 5000 + 30 * step,
                          "x": 1.0 + step, "y": 8.0, "x_m": 0.1 + 0.1 * step, "y_m": 0.8,
                          "step": step, "window_key": key, "split": split})
    return number_windows(pd.DataFrame(parts), 2, "trajnet")


def write_maps(windows: Path, root: Path) -> None:
    """Road / not-road maps of eth (swap) and zara1 through the writer of short_term_windows."""
    release, scenes = root / "release", root / "scenes"
    oracle = np.ones((12, 12), np.uint8)  # 1 = road
    oracle[:, 6:] = 0
    for name in ("eth", "zara1"):
        (release / "data/eth_ucy" / name).mkdir(parents=True)
        cv2.imwrite(str(release / "data/eth_ucy" / name / "oracle.png"), oracle)
        (scenes / SCENES[name].image).mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(scenes / SCENES[name].image / "reference.png"),
                    np.zeros((12, 12, 3), np.uint8))
    (windows / "ethucy_semantic").mkdir(parents=True)
    write_ethucy_maps(windows / "ethucy_semantic", release, scenes, ["eth", "zara1"],
                      {"eth": H, "zara1": H}, 0.5)


def sdd_sampler(ids: np.ndarray):
    """The triangle model of tests/test_score_predictions.py (pixels): round 1 shifts window
    gates_2 / track 1 by (25, 0) px and hyang_0's by (0, 30) px."""
    futures = [np.array(f) for f in FUTURE.values()]
    shifts = [(25.0, 0.0), (0.0, 0.0), (0.0, 30.0)]

    def sample(seed: int):
        return np.stack([f[None] + TRIANGLE[ORDER[w]][:, None] + (np.array(s) if seed else 0.0)
                         for f, w, s in zip(futures, FUTURE, shifts)]), None, None
    assert len(ids) == 3
    return sample


def zara_sampler(seed: int):
    """Windows 0 and 1: the truth + the triangle scaled to 0.1 m; round 1 moves window 0 SHIFT m
    north. Returned in pixels (2 per metre), as a model samples them."""
    truth = np.array([ZARA[0][0], ZARA[1][0]])  # (2, T, 2) m
    paths = truth[:, None] + 0.1 * TRIANGLE[None, :, None]  # (2, K, T, 2)
    if seed:
        paths[0] += [0.0, SHIFT]
    return paths * 2.0, None, None


@pytest.fixture
def project(tmp_path: Path) -> tuple[Path, dict]:
    """Tables, maps, labels, scales, params and predictions files; returns the runs' per-round
    scores {dataset: {model: record}} as `runner.score` gave them."""
    windows, predictions = tmp_path / "short_term", tmp_path / "predictions"
    windows.mkdir()
    sdd_table().to_parquet(windows / "sdd_trajnet.parquet", index=False)
    zara_table().to_parquet(windows / "ethucy_zara1.parquet", index=False)
    write_maps(windows, tmp_path)
    write_labels(tmp_path / "labels")
    (tmp_path / "estimated_scales.yaml").write_text(yaml.safe_dump({
        "gates": {"video2": {"scale": 0.1, "certainty": 1.0}},
        "hyang": {"video0": {"scale": 0.05, "certainty": 0.9}}}))
    (tmp_path / "params.yaml").write_text(yaml.safe_dump({
        "short_term": {"n_past": N_PAST, "n_future": 2},
        "score_predictions": {"miss_threshold_m": 2.0, "collision_threshold_m": 0.2,
                              "log_pdf_floor": -20.0, "forbidden_classes": ["structure", "tree"]}}))
    runs: dict = {}
    for dataset, model in (("sdd", "sgan"), ("zara1", "sgan")):
        bench = short_term(dataset).load(windows, N_PAST, 2)
        kept = PredictionRounds(bench.test.window_id)
        sample = sdd_sampler(bench.test.window_id) if dataset == "sdd" else zara_sampler
        runs.setdefault(dataset, {})[model] = runner.score(sample, bench, 2, 0, kept)
        kept.write(predictions / dataset / f"{model}.parquet",
                   short_term(dataset).prediction_metadata(windows, model, [3]))
    for dataset in SHORT_TERM_DATASETS:
        for model in ("ynet", "sgan", "pecnet"):
            path = predictions / dataset / f"{model}.parquet"
            if not path.exists():
                write_no_predictions(path, short_term(dataset).prediction_metadata(windows, model),
                                     f"{model} is not run on {dataset} here")
    return tmp_path, runs


def run(root: Path) -> dict:
    out = root / "metrics" / "beyond" / "short_term.json"
    score_short_term_predictions.main([
        "--predictions", str(root / "predictions"), "--windows", str(root / "short_term"),
        "--labels", str(root / "labels"), "--scales", str(root / "estimated_scales.yaml"),
        "--out", str(out), "--params", str(root / "params.yaml")])
    return json.loads(out.read_text())


def check(metrics: dict, name: str, per_round: list[float]) -> None:
    assert metrics[name]["per_round"] == pytest.approx(per_round, abs=1e-9), name
    assert metrics[name]["mean"] == pytest.approx(np.mean(per_round), abs=1e-9), name
    assert metrics[name]["std"] == pytest.approx(np.std(per_round), abs=1e-9), name


def test_ethucy_fold_by_hand_in_metres(project):
    root, _ = project
    zara = run(root)["benchmarks"]["zara1"]
    assert (zara["benchmark"], zara["unit"], zara["truth_columns"], zara["split"]) \
        == ("short_term_ethucy_zara1", "m", ["x_m", "y_m"], "test")
    assert (zara["n_windows"], zara["n_future"]) == (2, 2)  # the test windows only
    assert zara["scene_masks"]["forbidden_classes"] == ["not_road"]
    assert zara["scene_masks"]["scenes_with_mask"] == ["zara1"]
    assert zara["scene_masks"]["windows_with_mask"] == 2
    assert zara["collision_partners"] == "windows of another track starting at the same frame"
    got = zara["models"]["sgan"]
    assert (got["rounds"], got["seeds"], got["k"], got["t"], got["n_windows"]) == (2, [0, 1], 3, 2, 2)
    m, far = got["metrics"], math.sqrt(0.1 ** 2 + (SHIFT - 0.1) ** 2)  # round 1's best sample
    near = 0.1 * math.sqrt(2)  # samples 0 and 1 of the 0.1-m triangle
    for name in ("ade", "fde", "ade_joint", "fde_joint", "ade_best_endpoint"):
        check(m, name, [near, (far + near) / 2])
    check(m, "miss_rate", [0.0, 0.5])  # 9.9 m > 2 m; metres need no scale
    # The triangle scaled by 0.1: its density per m^2 is 100 times larger, NLL - 2 ln 10.
    scaled = TRIANGLE_NLL + 2 * math.log(0.1)
    check(m, "kde_nll", [scaled, (20.0 + scaled) / 2])
    # Not road: window 1's last step (3.9 .. 4.1 m) in all 3 samples: 3 of 6; window 0 on the road,
    # in round 1 off the map (left out).
    check(m, "off_limits_share", [0.25, 0.5])
    # Frame 20: window 0's sample k and window 1's are 0.1 m apart; round 1: 10 m.
    check(m, "collision_rate", [1.0, 0.0])
    assert got["ground_truth"] == pytest.approx({"off_limits_share": 0.25, "collision_rate": 1.0,
                                                 "copresent_share": 1.0})
    assert got["per_scene"]["zara1"]["n_windows"] == 2
    assert got["kde_nll_per_step"]["mean"] == pytest.approx([(scaled + (20 + scaled) / 2) / 2] * 2)


def test_trajnet_sdd_by_hand_in_pixels(project):
    root, _ = project
    sdd = run(root)["benchmarks"]["sdd"]
    assert (sdd["benchmark"], sdd["unit"], sdd["split"], sdd["n_windows"]) \
        == ("short_term_sdd_trajnet", "px", "test", 3)
    assert sdd["scene_masks"]["scenes_with_mask"] == ["gates_2", "hyang_0"]
    assert sdd["scene_masks"]["windows_with_mask"] == 3
    m = sdd["models"]["sgan"]["metrics"]
    r2, r577, r842 = math.sqrt(2), math.sqrt(577), math.sqrt(842)  # as the long-term fixture
    check(m, "ade", [r2, (r577 + r2 + r842) / 3])
    check(m, "miss_rate", [0.0, 1 / 3])  # 24.02 px > 20 px at gates_2's 0.1 m per pixel
    check(m, "off_limits_share", [1 / 6, 1 / 4])
    check(m, "collision_rate", [(1 / 3 + 1 / 3 + 0) / 3, 0.0])


def test_min_ade_fde_equal_the_runs_per_round_numbers(project):
    root, runs = project
    record = run(root)["benchmarks"]
    for dataset, models in runs.items():
        for model, scores in models.items():
            m = record[dataset]["models"][model]["metrics"]
            for key in ("ade", "fde", "ade_joint", "fde_joint"):
                assert m[key]["per_round"] == pytest.approx(
                    [r[key] for r in scores["per_round"]], rel=1e-12, abs=1e-12), (dataset, key)


def test_sgan_sequence_metrics_take_one_sample_per_sequence(project):
    """Windows 0 and 1 start at the same frame of zara1: one S-GAN sequence. K = 2, offsets (m)
    from the truth at every step: round 0 window 0 (0, 1), window 1 (1, 0): min-ADE 0 per window,
    but a sample for both sums to 1: 1 / 2 windows. Round 1 window 0 (1, 3), window 1 (2, 0):
    min-ADE (1 + 0) / 2, sequence min(3, 3) / 2. FDE alike (the offsets are the same each step)."""
    root, _ = project
    truth = np.array([ZARA[0][0], ZARA[1][0]])  # (2, T, 2) m
    kept = PredictionRounds(np.array([0, 1]))
    for seed, offsets in ((3, [[0.0, 1.0], [1.0, 0.0]]), (4, [[1.0, 3.0], [2.0, 0.0]])):
        north = np.array(offsets)[:, :, None, None] * [0.0, 1.0]  # (N, K, 1, 2)
        kept.add(seed, truth[:, None] + north)
    kept.write(root / "predictions" / "zara1" / "pecnet.parquet",
               short_term("zara1").prediction_metadata(root / "short_term", "pecnet", [2]))
    zara = run(root)["benchmarks"]["zara1"]["models"]
    got = zara["pecnet"]
    for name in ("ade", "fde"):
        check(got["metrics"], name, [0.0, 0.5])
    for name in ("ade_sgan_sequence", "fde_sgan_sequence"):
        check(got["metrics"], name, [0.5, 1.5])
        assert got["per_scene"]["zara1"]["metrics"][name] == pytest.approx({"mean": 1.0,
                                                                            "std": 0.5})
    # The keys come after every other metric but the one-sample pair (added later); S-GAN's
    # symmetric triangles give min-ADE again.
    assert list(got["metrics"])[-4:] == ["ade_sgan_sequence", "fde_sgan_sequence",
                                         "ade_one_sample", "fde_one_sample"]
    m, far = zara["sgan"]["metrics"], math.sqrt(0.1 ** 2 + (SHIFT - 0.1) ** 2)
    for name in ("ade_sgan_sequence", "fde_sgan_sequence"):
        check(m, name, [0.1 * math.sqrt(2), (far + 0.1 * math.sqrt(2)) / 2])


def test_models_not_run_are_listed_with_their_reason(project):
    root, _ = project
    record = run(root)["benchmarks"]
    assert list(record) == list(SHORT_TERM_DATASETS)
    assert record["zara1"]["models"]["ynet"]["not_run_reason"] == "ynet is not run on zara1 here"
    eth = record["eth"]
    assert all("not_run_reason" in entry for entry in eth["models"].values())
    assert "n_windows" not in eth  # no file to score: the table is never read


def test_road_masks_follow_the_homography_and_its_swap(project):
    root, _ = project
    masks = road_masks(root / "short_term" / "ethucy_semantic")
    metres = np.array([[[1.0, 4.0]], [[4.0, 1.0]]])  # (2 windows, 1 position, 2)
    # zara1: metres (x, y) -> pixels (2x, 2y): (2, 8) road, (8, 2) not road.
    assert forbidden_shares(masks, metres, np.array(["zara1", "zara1"])).tolist() == [0.0, 1.0]
    # eth swaps: H takes (row, column), so metres (x, y) -> pixels (2y, 2x): the other way round.
    assert forbidden_shares(masks, metres, np.array(["eth", "eth"])).tolist() == [1.0, 0.0]
    # A scene without a map has no share.
    assert np.isnan(forbidden_shares(masks, metres[:1], np.array(["hotel"]))).all()


BAD = {  # what is wrong -> (window ids in metres, metadata changes, message)
    "a train window": ([0, 2], {}, r"1 of 2 window id\(s\) are not in .*ethucy_zara1\.parquet, "
                                   r"e\.g\. \[2\]"),
    "pixels for metres": ([0, 1], {"truth_columns": ["x", "y"]},
                          r"truth columns \['x', 'y'\], but short_term_ethucy_zara1 is scored on "
                          r"\['x_m', 'y_m'\]"),
    "another fold's file": ([0, 1], {"benchmark": "short_term_ethucy_eth"},
                            r"benchmark 'short_term_ethucy_eth', but it is scored against "
                            r".*ethucy_zara1\.parquet"),
    "another unit": ([0, 1], {"unit": "px"}, r"unit 'px', expected 'm'"),
}


@pytest.mark.parametrize("case", BAD)
def test_a_file_that_does_not_fit_its_benchmark_is_named(project, case):
    root, _ = project
    ids, changes, message = BAD[case]
    kept = PredictionRounds(np.array(ids))
    kept.add(0, np.zeros((2, 3, 2, 2)))
    path = root / "predictions" / "zara1" / "pecnet.parquet"
    metadata = short_term("zara1").prediction_metadata(root / "short_term", "pecnet", [3])
    kept.write(path, {**metadata, **changes})
    with pytest.raises(SystemExit, match=rf"score_short_term_predictions: "
                                         rf"{re.escape(str(path))}: {message}"):
        run(root)


def test_names_and_tables_agree_with_the_writers(tmp_path):
    for dataset in SHORT_TERM_DATASETS:
        benchmark = short_term(dataset)
        stem = "sdd_trajnet" if dataset == "sdd" else f"ethucy_{dataset}"
        table = benchmark.table(tmp_path)
        assert table == tmp_path / f"{stem}.parquet"
        assert benchmark.prediction_benchmark() == f"short_term_{stem}"
        metadata = benchmark.prediction_metadata(tmp_path, "sgan")
        assert (metadata["benchmark"], metadata["window_table"]) \
            == (f"short_term_{stem}", str(table))
        no_maps = {tmp_path / MAPS: None}  # the road maps, as if read: none are written here
        scored = benchmark.scored_table(ScoringSources(tmp_path, N_PAST, scales_path=tmp_path
                                                       / "scales.yaml", read_masks=no_maps))
        assert (scored.name, scored.table, scored.unit, list(scored.truth_columns)) \
            == (metadata["benchmark"], table, metadata["unit"], metadata["truth_columns"])
    assert short_term("zara1").table(tmp_path).name == "ethucy_zara1.parquet"
    assert short_term("zara1").prediction_benchmark() == "short_term_ethucy_zara1"
    assert IND.prediction_benchmark() == "ind_long_term"
    assert IND.prediction_metadata("ynet")["benchmark"] == "ind_long_term"


def test_ethucy_collisions_pair_only_windows_that_start_together():
    """Windows 0 (track 1) and 1 (track 2, 5 m away) start together; window 2, track 2 again one
    step later, is 0.1 m from window 0 at frame 30. Any shared frame: 0 and 2 collide; one
    sequence (ETH/UCY): window 2 has no partner, 0 and 1 stay apart."""
    future = np.array([[[0.0, 0.0], [1.0, 0.0]], [[5.0, 0.0], [5.0, 0.0]],
                       [[1.1, 0.0], [2.0, 0.0]]])
    truth = WindowTruth(Path("t.parquet"), np.arange(3), future,
                        np.array([[20, 30], [20, 30], [30, 40]]), np.array([0, 0, 10]),
                        np.array(["zara1"] * 3), np.array([1, 2, 2]), 2)
    samples = future[:, None]  # K = 1: the truth itself
    for same_start, hits, copresent in ((False, [1.0, 0.0, 1.0], [True, True, True]),
                                        (True, [0.0, 0.0, 0.0], [True, True, False])):
        inputs = stored_scores.SceneInputs(truth, np.ones(3), None, same_start)
        got = stored_scores.collisions(samples, inputs, 0.2)
        assert got.pred_share.tolist() == hits and got.truth.tolist() == [h > 0 for h in hits]
        assert got.copresent.tolist() == copresent
