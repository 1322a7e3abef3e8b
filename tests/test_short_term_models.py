"""Short-term stages on tiny synthetic benchmarks: Y-net / S-GAN / PECNet train, score and write the
run layout; ETH/UCY errors come back in metres; the merged files fill the report's Tables 1 and 2.

Fixtures are written here in the stages' formats: window tables (`pipeline.data.window_table`
schema plus x_m, y_m), the ETH/UCY scene folder (`maps.npz` + `index.json`, as
`pipeline.benchmarks.ethucy` writes it), SDD maps and reference images, and a params.yaml with tiny
settings.
"""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import torch
import yaml

from pipeline.benchmarks.ethucy import (MAP_CLASSES, EthUcySceneInfo, ethucy_scene_image,
                                        load_ethucy_scenes, splits_in_metres, to_metres)
from pipeline.benchmarks.registry import short_term
from pipeline.report.figures import load_qualitative
from pipeline.report.lookups import load_metrics
from pipeline.report.tables import table_eth_ucy, table_sdd_short
from pipeline.report.provenance import load_paper_values
from pipeline.data.homography import metres_to_pixels
from pipeline.harness.metrics import window_errors
from pipeline.harness.predictions import prediction_arrays, read_predictions
from pipeline.harness.scoring import min_ade_fde
from pipeline.io import IntermediateError
from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile, read_params
from pipeline.config.report import ReportParams
from pipeline.config.short_term_models import (ShortTermModelsParams, YnetTraining,
                                               YnetTrainingByBenchmark)
from pipeline.config.ynet import YnetSettings
from pipeline.dataset_list import SHORT_TERM_DATASETS
from pipeline.data.semantic_maps import quantise
from pipeline.data.window_table import to_arrays
from pipeline.data.ynet_data import window_inputs
from pipeline.data.window_table import subset
from pipeline.runners.short_term import qualitative_rows, ynet_maps, ynet_options
from pipeline.runners.ynet_scoring import (in_scene_frame, load_for_scoring, predict_scenes,
                                           qualitative, sampling_options)
from pipeline.stages import (evaluate_short_term_baseline, evaluate_short_term_ynet,
                             train_short_term_baseline, train_short_term_ynet)
from pipeline.stages.short_term_tables import main as tables_main
from pipeline.runners.ynet_training import train
from pipeline.data.window_table import WindowArrays
from tests.fixtures import write_maps_folder
from tests.test_train_ynet import TTST
from ynet.segmentation import CLASS_NAMES, PAD_CLASS

REPO = Path(__file__).resolve().parents[1]
N_PAST, N_FUTURE = 8, 12
# Pixels -> metres: 0.05 m per pixel along x, 0.1 m per pixel along y (as (row, column) when swapped).
H_PLAIN = np.diag([0.05, 0.1, 1.0])
ETH_SCENES = {"zara1": (H_PLAIN, False), "eth": (H_PLAIN, True)}  # fold "eth": test scene eth
IMAGE_HW = (240, 320)
ETH_CAMERA_HW = (200, 300)  # the eth camera image, smaller than its pixel grid IMAGE_HW


# ---------------------------------------------------------------------------------------------
# Fixtures in the stages' formats


def tracks(n: int, rng: np.random.Generator, hw=IMAGE_HW) -> np.ndarray:
    """(n, 20, 2) pixel tracks walking at 4 px/step in random directions inside the image."""
    heading = rng.uniform(0, 2 * np.pi, n)
    step = 4.0 * np.stack([np.cos(heading), np.sin(heading)], -1)  # (n, 2)
    start = rng.uniform([100, 80], [hw[1] - 100, hw[0] - 80], (n, 2))
    return start[:, None] + np.arange(N_PAST + N_FUTURE)[None, :, None] * step[:, None]


def window_table(parts: list[tuple[str, str, np.ndarray]], to_metres=None) -> pd.DataFrame:
    """Long-format table of windows (scene, split, pixel tracks (n, 20, 2)) plus x_m, y_m."""
    rows, window = [], 0
    for scene, split, xy in parts:
        metres = xy if to_metres is None else to_metres(scene, xy)
        for i in range(len(xy)):
            for step in range(N_PAST + N_FUTURE):
                rows.append({"window_id": window, "scene_id": scene, "track_id": i, "step": step,
                             "frame": 100 * i + 10 * step, "x": xy[i, step, 0], "y": xy[i, step, 1],
                             "split": split, "t_f": N_FUTURE, "source": "sgan",
                             "x_m": metres[i, step, 0], "y_m": metres[i, step, 1]})
            window += 1
    return pd.DataFrame(rows)


def write_maps(folder: Path, names, classes: list[str], hw=(60, 80), key: str = "videos",
               entries: dict[str, dict] | None = None) -> None:
    """`maps.npz` + `index.json` as pipeline.data.semantic_maps stores them: uint8 probabilities
    per scene."""
    maps = np.zeros((len(classes), *hw), np.float32)
    maps[1:] = 1.0 / (len(classes) - 1)
    write_maps_folder(folder, {name: quantise(maps) for name in names}, classes, key, entries)


def write_ethucy(windows: Path) -> None:
    """Fold `eth` (test: eth; train/val: zara1) and its scene folder, homographies as above."""
    rng = np.random.default_rng(0)

    def metres(scene: str, xy: np.ndarray) -> np.ndarray:
        h, swap = ETH_SCENES[scene]
        return to_metres(xy, np.full(len(xy), scene), {scene: EthUcySceneInfo(IMAGE_HW, h, swap)})

    table = window_table([("zara1", "train", tracks(12, rng)), ("zara1", "val", tracks(4, rng)),
                          ("eth", "test", tracks(5, rng))], metres)
    windows.mkdir(parents=True, exist_ok=True)
    table.to_parquet(windows / "ethucy_eth.parquet", index=False)
    scenes = windows / "ethucy_semantic"
    write_maps(scenes, ETH_SCENES, MAP_CLASSES, key="scenes", entries={
        name: {"image_hw": list(IMAGE_HW), "homography": h.tolist(), "swap": swap}
        for name, (h, swap) in ETH_SCENES.items()})


def write_ethucy_images(root: Path) -> None:
    """Camera images in `ethucy-scenes/<scene>/reference.png`: eth's smaller than its pixel grid (as
    zara2's), a white frame, so that its black border shows where the grid extends beyond it."""
    for name, hw in (("eth", ETH_CAMERA_HW), ("zara1", IMAGE_HW)):
        (root / name).mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(root / name / "reference.png"), np.full((*hw, 3), 255, np.uint8))


def write_sdd(windows: Path, sdd_root: Path, maps: Path) -> None:
    rng = np.random.default_rng(1)
    table = window_table([("gates_0", "train", tracks(12, rng)), ("gates_1", "val", tracks(4, rng)),
                          ("gates_2", "test", tracks(5, rng))])
    windows.mkdir(parents=True, exist_ok=True)
    table.to_parquet(windows / "sdd_trajnet.parquet", index=False)
    for video in range(3):
        folder = sdd_root / "annotations" / "gates" / f"video{video}"
        folder.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(folder / "reference.jpg"), np.zeros((*IMAGE_HW, 3), np.uint8))
    write_maps(maps, [f"gates_{v}" for v in range(3)], CLASS_NAMES)


def tiny_params() -> dict:
    """params.yaml with the real sections' keys and tiny values (both profiles the same)."""
    real = read_params(REPO / "params.yaml")
    ynet = {**real["ynet"]["cpu"], "batch_size": 2, "learning_rate": 1e-3, "augmentations": 2,
            "encoder_channels": [4, 4, 8, 8, 8], "decoder_channels": [8, 8, 8, 4, 4], "threads": 1,
            "distance_gain": 1.0}
    short = {**real["short_term_models"]["cpu"],
             "epochs": {m: {"sdd": 2, "ethucy": 2} for m in ("ynet", "sgan", "pecnet")},
             "ynet_steps_per_epoch": 3, "val_windows": 3, "rounds": 2,
             "ynet_sdd": {"resize": 0.25, "kernel_size": 5, "sigma": 1.0},
             "ynet_ethucy": {"resize": 0.25, "kernel_size": 5, "sigma": 1.0, "crop": 32,
                             "crop_lead_steps": 2.0},  # whole scenes on sdd, crops on eth
             "ynet_datasets": ["sdd", "eth"], "why_subset": "tiny test"}
    sgan = {**real["sgan"]["cpu"], "batch_size": 8, "pool_hidden": 16, "best_of_k": 2, "val_k": 2}
    pecnet = {**real["pecnet"]["cpu"], "batch_size": 8, "past_hidden": [16], "decoder_hidden": [16],
              "predictor_hidden": [16], "nonlocal_hidden": [8], "nonlocal_dim": 8, "val_k": 2}
    both = lambda section: {"cpu": section, "paper": section}  # noqa: E731
    return {"profile": "cpu", "short_term": real["short_term"], "runtime": real["runtime"],
            "train_baseline": {"seed": 0, "threads": 1}, "ynet": both(ynet),
            "short_term_models": both(short), "sgan": both(sgan), "pecnet": both(pecnet),
            "short_term_baselines": real["short_term_baselines"],
            "short_term_pecnet_test_selection": {"folds": ["eth"]}}


BUILT: list[Path] = []  # the project folder, once built


@pytest.fixture(scope="module")
def project(tmp_path_factory) -> Path:
    """A project folder after every short-term run the tests need: built once a session, and
    shared with tests/test_short_term_baselines.py (which imports this fixture; its tests write
    only under compat/)."""
    torch.set_num_threads(1)
    if not BUILT:
        BUILT.append(build_project(tmp_path_factory.mktemp("short_term")))
    return BUILT[0]


def build_project(root: Path) -> Path:
    """Every short-term run the tests need, under `root`."""
    (root / "params.yaml").write_text(yaml.safe_dump(tiny_params()))
    windows = root / "data" / "short_term"
    write_ethucy(windows)
    write_ethucy_images(root / "ethucy-scenes")
    write_sdd(windows, root / "sdd", root / "semantic_maps")
    runs = root / "metrics" / "short_term" / "runs"
    cwd = Path.cwd()
    try:
        os.chdir(root)  # stages read ./params.yaml
        for dataset, model in (("eth", "ynet"), ("eth", "sgan"), ("eth", "pecnet"), ("sdd", "ynet"),
                               ("sdd", "pecnet"), ("hotel", "ynet")):
            maps = windows / "ethucy_semantic" if dataset != "sdd" else root / "semantic_maps"
            common = ["--dataset", dataset, "--windows", str(windows),
                      "--checkpoint-dir", str(root / "checkpoints" / f"{dataset}_{model}")]
            trained = root / "metrics" / "short_term" / "train" / f"{dataset}_{model}.json"
            stored = root / "predictions" / dataset
            scoring = ["--predictions", str(stored / f"{model}.parquet")]
            if model == "ynet":
                common += ["--maps", str(maps), "--sdd", str(root / "sdd")]
                scoring += ["--ethucy-scenes", str(root / "ethucy-scenes"),
                            "--qualitative", str(stored / "ynet_qualitative.npz")]
                stages = train_short_term_ynet, evaluate_short_term_ynet
            else:
                common += ["--model", model]
                stages = train_short_term_baseline, evaluate_short_term_baseline
            stages[0].main([*common, "--metrics", str(trained)])
            stages[1].main([*common, "--train-metrics", str(trained),
                            "--metrics", str(runs / f"{dataset}_{model}.json"), *scoring])
        tables_main(["--runs", str(runs), "--out", str(root / "metrics" / "short_term")])
    finally:
        os.chdir(cwd)
    return root


def run_record(project: Path, name: str) -> dict:
    return json.loads((project / "metrics" / "short_term" / "runs" / f"{name}.json").read_text())


# ---------------------------------------------------------------------------------------------
# Runs


@pytest.mark.parametrize("name, unit, ks", [("eth_ynet", "m", [20]), ("eth_sgan", "m", [20]),
                                            ("eth_pecnet", "m", [20]), ("sdd_ynet", "px", [20, 5]),
                                            ("sdd_pecnet", "px", [20, 5])])
def test_a_run_writes_its_metrics_layout(project, name, unit, ks):
    record = run_record(project, name)
    assert [record["dataset"], record["model"]] == name.split("_")
    assert record["trained"] is True and record["unit"] == unit and record["ks"] == ks
    assert record["n_windows"] == 5 and record["rounds"] == 2
    for k in ks:
        result = record[f"k{k}"]
        for metric in ("ade", "fde", "ade_joint", "fde_joint"):
            assert set(result[metric]) == {"mean", "std", "min", "max"}
            assert np.isfinite(result[metric]["mean"]) and result[metric]["mean"] > 0
        assert len(result["per_round"]) == 2
        assert result["fde_joint"]["mean"] >= result["fde"]["mean"]
    assert record["train"]["epochs"] == 2 and record["train"]["val_windows"] == 3
    assert record["train_seconds"] > 0 and record["eval_seconds"] > 0
    assert (project / "checkpoints" / name / "best.pt").exists()


def test_ynet_runs_the_short_term_configuration(project):
    record = run_record(project, "eth_ynet")["train"]["settings"]
    assert record["waypoints"] == [N_FUTURE - 1] and record["semantic_classes"] == 3
    assert record["resize"] == 0.25 and record["steps_per_epoch"] == 3
    assert run_record(project, "sdd_ynet")["train"]["settings"]["semantic_classes"] == 6


def test_ynet_training_overrides_the_long_term_models_only_where_set():
    params = read_params(REPO / "params.yaml")
    short = load_profile(ShortTermModelsParams, "short_term_models", {**params, "profile": "cpu"})
    base = YnetSettings(learning_rate=3e-4, batch_size=2)
    for training, rate, batch, scale in ((YnetTraining(learning_rate=2e-3), 2e-3, 2, 1.0),
                                         (YnetTraining(batch_size=16, bf16=True), 3e-4, 16, 1.0),
                                         (YnetTraining(trajectory_lr_scale=3.0), 3e-4, 2, 3.0)):
        by_benchmark = YnetTrainingByBenchmark(sdd=YnetTraining(), ethucy=training)
        settings = short_term("eth").ynet_settings(base, replace(short, ynet_training=by_benchmark),
                                                   N_FUTURE, 3)
        assert (settings.learning_rate, settings.batch_size) == (rate, batch)
        assert settings.trajectory_lr_scale == scale
        assert settings.bf16 == training.bf16 and settings.waypoints == [N_FUTURE - 1]
    for bad in ({"learning_rate": 0.0}, {"batch_size": 0}, {"trajectory_lr_scale": -1.0},
                {"grad_clip_norm": -1.0}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            YnetTraining(**bad)
    paper = load_profile(ShortTermModelsParams, "short_term_models", {**params, "profile": "paper"})
    for benchmark in ("sdd", "ethucy"):  # the authors' recipe
        assert paper.ynet_training.of(benchmark).overrides() == {
            "bf16": False, "lr_schedule": "constant"}


def test_ynet_training_departs_per_benchmark():
    """A departure set for SDD leaves every ETH/UCY fold as it was, and the other way round."""
    params = read_params(REPO / "params.yaml")
    short = load_profile(ShortTermModelsParams, "short_term_models", {**params, "profile": "cpu"})
    base = YnetSettings(learning_rate=3e-4, batch_size=2)
    by_benchmark = YnetTrainingByBenchmark(sdd=YnetTraining(learning_rate=5e-4, trajectory_lr_scale=2.0),
                                           ethucy=YnetTraining(learning_rate=1e-3))
    split = replace(short, ynet_training=by_benchmark)
    sdd = short_term("sdd").ynet_settings(base, split, N_FUTURE, 3)
    assert (sdd.learning_rate, sdd.trajectory_lr_scale) == (5e-4, 2.0)
    for fold in ("eth", "hotel", "univ", "zara1", "zara2"):
        settings = short_term(fold).ynet_settings(base, split, N_FUTURE, 3)
        assert (settings.learning_rate, settings.trajectory_lr_scale) == (1e-3, 1.0)
    with pytest.raises(ValueError, match="unknown benchmark 'kitti'"):
        by_benchmark.of("kitti")


def test_ttst_threshold_is_the_benchmarks():
    """SDD and every ETH/UCY fold sample with their own benchmark's threshold; `paper` keeps the
    authors' 0.01 on both."""
    params = read_params(REPO / "params.yaml")
    short = load_profile(ShortTermModelsParams, "short_term_models", {**params, "profile": "cpu"})
    split = replace(short, rel_threshold={"sdd": 0.01, "ethucy": 0.0005})
    assert ynet_options(split, short_term("sdd"), 20).rel_threshold == 0.01
    for fold in ("eth", "hotel", "univ", "zara1", "zara2"):
        options = ynet_options(split, short_term(fold), 20)
        assert (options.rel_threshold, options.K_e, options.K_a) == (0.0005, 20, 1)
        assert options.use_ttst and not options.use_cws
    paper = load_profile(ShortTermModelsParams, "short_term_models", {**params, "profile": "paper"})
    assert paper.rel_threshold == {"sdd": 0.01, "ethucy": 0.01} and paper.temperature == 1.0


def test_smaller_k_is_never_better(project):
    record = run_record(project, "sdd_pecnet")
    assert record["k5"]["ade"]["mean"] >= record["k20"]["ade"]["mean"] - 1e-9


def test_ynet_outside_the_profile_datasets_leaves_a_reason(project):
    record = run_record(project, "hotel_ynet")
    assert record["trained"] is False and "tiny test" in record["not_run_reason"]
    assert not (project / "checkpoints" / "hotel_ynet").exists()


def test_ynet_resumes_to_the_same_weights(tmp_path):
    """3-channel maps and capped epochs through `train`: 2 epochs straight == 1, then resumed."""
    torch.set_num_threads(1)
    rng = np.random.default_rng(2)
    xy = tracks(10, rng)

    def arrays(rows, split):
        n = len(rows)
        return WindowArrays(past=xy[rows, :N_PAST], future=xy[rows, N_PAST:], window_id=rows,
                            scene_id=np.array(["zara1"] * n), track_id=rows,
                            first_frame=np.zeros(n), split=np.array([split] * n))

    settings = YnetSettings(
        resize=0.25, epochs=2, batch_size=2, learning_rate=1e-3, augmentations=1, kernel_size=5,
        sigma=1.0, waypoints=[N_FUTURE - 1], encoder_channels=[4, 4, 8, 8, 8],
        decoder_channels=[8, 8, 8, 4, 4], threads=1, semantic_classes=3,
        steps_per_epoch=2)
    maps = {"zara1": np.full((3, 60, 80), 1 / 3, np.float32)}
    sizes = {"zara1": IMAGE_HW}
    args = (arrays(np.arange(8), "train"), arrays(np.arange(8, 10), "val"), maps, sizes)

    def train_in(folder, epochs=None):
        train(*args, settings, N_PAST, folder / "last.pt", folder / "best.pt", folder / "history.csv",
              epochs)

    train_in(tmp_path / "a")
    train_in(tmp_path / "b", epochs=1)
    train_in(tmp_path / "b")
    straight, resumed = (torch.load(tmp_path / f / "last.pt", weights_only=True)["state"]["model"]
                         for f in ("a", "b"))
    for name in straight:
        torch.testing.assert_close(straight[name], resumed[name], rtol=0, atol=0)


def test_steps_per_epoch_caps_the_optimiser_steps(tmp_path):
    torch.set_num_threads(1)
    xy = tracks(10, np.random.default_rng(0))
    rows = np.arange(8)
    train_arrays = WindowArrays(past=xy[rows, :N_PAST], future=xy[rows, N_PAST:], window_id=rows,
                                scene_id=np.array(["zara1"] * 8), track_id=rows,
                                first_frame=np.zeros(8), split=np.array(["train"] * 8))
    val_arrays = subset(train_arrays, np.arange(2))
    maps, sizes = {"zara1": np.full((3, 60, 80), 1 / 3, np.float32)}, {"zara1": IMAGE_HW}
    for cap, steps in ((0, 4), (3, 3)):  # 8 windows in batches of 2: 4 steps uncapped
        settings = YnetSettings(resize=0.25, epochs=1, batch_size=2, augmentations=1, kernel_size=5,
                                sigma=1.0, waypoints=[N_FUTURE - 1], encoder_channels=[4, 4, 8, 8, 8],
                                decoder_channels=[8, 8, 8, 4, 4], threads=1,
                                semantic_classes=3, steps_per_epoch=cap)
        folder = tmp_path / str(cap)
        train(train_arrays, val_arrays, maps, sizes, settings, N_PAST, folder / "last.pt",
              folder / "best.pt", folder / "history.csv")
        adam = torch.load(folder / "last.pt", weights_only=True)["state"]["optimizer"]["state"]
        assert {int(state["step"]) for state in adam.values()} == {steps}

def fold_benchmark(tmp_path: Path):
    write_ethucy(tmp_path)
    table = pd.read_parquet(tmp_path / "ethucy_eth.parquet")
    scenes = load_ethucy_scenes(tmp_path / "ethucy_semantic")
    return splits_in_metres(table, "eth", N_PAST, N_FUTURE, scenes)


def test_a_perfect_pixel_prediction_is_zero_metres_off(tmp_path):
    bench = fold_benchmark(tmp_path)
    assert bench.unit == "m"
    errors = window_errors(bench.to_unit(bench.test.future[:, None]), bench.truth)
    np.testing.assert_allclose(errors.ade, 0, atol=1e-9)
    np.testing.assert_allclose(errors.fde, 0, atol=1e-9)


@pytest.mark.parametrize("offset, metres", [((1.0, 0.0), 0.1), ((0.0, 1.0), 0.05)])
def test_a_one_pixel_offset_costs_its_metres_through_the_homography(tmp_path, offset, metres):
    """eth is swapped: H takes (row, column), so x (column) gets H's 0.1 m and y (row) its 0.05 m."""
    bench = fold_benchmark(tmp_path)
    shifted = bench.test.future[:, None] + np.array(offset)
    goals = shifted[:, :, -1]
    errors = window_errors(bench.to_unit(shifted), bench.truth, bench.to_unit(goals))
    np.testing.assert_allclose(errors.ade, metres, rtol=1e-9)
    np.testing.assert_allclose(errors.fde, metres, rtol=1e-9)


def test_to_metres_inverts_metres_to_pixels():
    rng = np.random.default_rng(3)
    h = np.array([[0.02, 0.001, -3.0], [0.0005, 0.03, 1.0], [1e-5, 2e-5, 1.0]])
    metres = rng.uniform(0, 10, (6, 12, 2))
    for swap in (False, True):
        pixels = metres_to_pixels(metres, h, swap)
        back = to_metres(pixels, np.full(6, "s"), {"s": EthUcySceneInfo((480, 640), h, swap)})
        np.testing.assert_allclose(back, metres, atol=1e-9)


def test_tables_and_homographies_that_disagree_fail(tmp_path):
    write_ethucy(tmp_path)
    table = pd.read_parquet(tmp_path / "ethucy_eth.parquet")
    scenes = load_ethucy_scenes(tmp_path / "ethucy_semantic")
    scenes["eth"] = EthUcySceneInfo(IMAGE_HW, scenes["eth"].homography, swap=False)  # wrong flag
    with pytest.raises(ValueError, match="disagree"):
        splits_in_metres(table, "eth", N_PAST, N_FUTURE, scenes)


# ---------------------------------------------------------------------------------------------
# Stored predictions and the qualitative windows

QUALITATIVE = {"scene_image": (np.uint8, 3), "past": (np.float32, 2), "future": (np.float32, 2),
               "goal_heatmap": (np.float32, 2), "sampled_goals": (np.float32, 2),
               "trajectory_heatmap": (np.float32, 2), "predictions": (np.float32, 3),
               "scene_id": (np.str_, 0)}  # the long-term qualitative.npz's keys: dtype, ndim


def stored_truth(metadata: dict) -> WindowArrays:
    """The test windows of the table a predictions file names, in the columns it compares with."""
    table = pd.read_parquet(metadata["window_table"])
    x, y = metadata["truth_columns"]
    return to_arrays(table[table["split"] == "test"].assign(x=table[x], y=table[y]), N_PAST)


@pytest.mark.parametrize("dataset, model, unit, goals", [
    ("eth", "ynet", "m", True), ("eth", "sgan", "m", False), ("eth", "pecnet", "m", False),
    ("sdd", "ynet", "px", True), ("sdd", "pecnet", "px", False)])
def test_stored_predictions_score_to_the_run_records_numbers(project, dataset, model, unit, goals):
    record = run_record(project, f"{dataset}_{model}")
    stored, metadata = read_predictions(project / "predictions" / dataset / f"{model}.parquet")
    table_stem = "sdd_trajnet" if dataset == "sdd" else f"ethucy_{dataset}"
    assert {key: metadata[key] for key in ("model", "benchmark", "unit", "seeds", "k", "ks_scored")} \
        == {"model": model, "benchmark": f"short_term_{table_stem}", "unit": unit, "seeds": [0, 1],
            "k": 20, "ks_scored": record["ks"]}
    truth = stored_truth(metadata)
    for r, in_memory in enumerate(record["k20"]["per_round"]):
        arrays = prediction_arrays(stored, round=r)
        np.testing.assert_array_equal(arrays.window_ids, truth.window_id)
        assert (arrays.goals is not None) == goals
        if model == "ynet":  # TTST's goal masses, summing to 1 per window
            np.testing.assert_allclose(arrays.weights.sum(axis=1), 1.0)
        else:
            assert np.isnan(arrays.weights).all()
        assert arrays.samples.shape == (5, 20, N_FUTURE, 2)
        from_file = min_ade_fde(arrays.samples, truth.future, arrays.goals)
        assert {key: float(value.mean()) for key, value in from_file.items()} == in_memory
    # every stored window has its scene and the frame of each step in the table
    table = pd.read_parquet(metadata["window_table"])
    steps = table[table["window_id"].isin(stored["window_id"].unique())]
    assert steps.groupby("window_id").size().eq(N_PAST + N_FUTURE).all()
    assert steps["scene_id"].notna().all() and steps["frame"].notna().all()


def test_a_ynet_run_outside_the_profile_stores_its_reason(project):
    reason = run_record(project, "hotel_ynet")["not_run_reason"]
    stored, metadata = read_predictions(project / "predictions" / "hotel" / "ynet.parquet")
    assert len(stored) == 0 and metadata["not_run_reason"] == reason and metadata["unit"] == "m"
    with np.load(project / "predictions" / "hotel" / "ynet_qualitative.npz") as npz:
        assert npz.files == ["not_run_reason"] and str(npz["not_run_reason"]) == reason


@pytest.mark.parametrize("dataset, crop", [("eth", 32), ("sdd", 0)])
def test_the_qualitative_windows_have_the_long_term_layout(project, dataset, crop):
    path = project / "predictions" / dataset / "ynet_qualitative.npz"
    with np.load(path) as npz:
        arrays = {key: npz[key] for key in npz.files}
    assert set(arrays) == {f"{key}_{i}" for key in QUALITATIVE for i in range(3)}
    for name, value in arrays.items():
        dtype, ndim = QUALITATIVE[name.rsplit("_", 1)[0]]
        assert value.dtype.type == dtype and value.ndim == ndim, name
    windows = project / "data" / "short_term"
    table = pd.read_parquet(short_term(dataset).table(windows))
    test = to_arrays(table[table["split"] == "test"], N_PAST)
    height, width = (round(side * 0.25) for side in IMAGE_HW)  # the maps' resize
    for i, row in enumerate(qualitative_rows(test)):
        assert str(arrays[f"scene_id_{i}"]) == test.scene_id[row]
        # coordinates in pixels of the scene image at the model's resize
        np.testing.assert_allclose(arrays[f"past_{i}"], test.past[row] * 0.25, rtol=1e-6)
        np.testing.assert_allclose(arrays[f"future_{i}"], test.future[row] * 0.25, rtol=1e-6)
        assert arrays[f"scene_image_{i}"].shape == (height, width, 3)
        assert arrays[f"goal_heatmap_{i}"].shape == arrays[f"trajectory_heatmap_{i}"].shape == (height, width)
        assert arrays[f"predictions_{i}"].shape == (20, N_FUTURE, 2)
        reached = np.count_nonzero(arrays[f"goal_heatmap_{i}"])  # a crop reaches crop^2 pixels
        assert 0 < reached <= (crop * crop if crop else height * width)
    if dataset == "eth":  # the camera frame in the grid's top-left corner, black beyond it
        assert (arrays["scene_image_0"][0, 0] == 255).all() and (arrays["scene_image_0"][-1, -1] == 0).all()
    loaded = load_qualitative(path)
    assert len(loaded.examples) == 3 and loaded.problems == ()


def test_an_index_listing_no_maps_is_named(tmp_path):
    write_maps(tmp_path / "maps", [], CLASS_NAMES)
    with pytest.raises(IntermediateError, match="maps: the index lists no maps"):
        ynet_maps(tmp_path / "maps")


def test_scoring_runs_on_the_scoring_params_threads_not_the_trainings(project):
    """A model trained on one thread (beside another training) is scored on the threads the
    scoring params give (`eval_threads`: alone on every core)."""
    windows = project / "data" / "short_term"
    benchmark = short_term("eth")
    bench = benchmark.load(windows, N_PAST, N_FUTURE)
    maps, _ = ynet_maps(benchmark.maps(windows))
    sizes = benchmark.scene_sizes(windows, None, {"eth"})
    try:
        _, loaded, _ = load_for_scoring(project / "checkpoints" / "eth_ynet" / "best.pt",
                                        bench.test, maps, sizes, threads=2)
        assert loaded.threads == 1 and torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(1)


def test_a_cropped_qualitative_window_lies_where_scoring_puts_it(project):
    """`qualitative` on a crop adds the crop's origin back: its samples are `predict_scenes`'s
    (same seed, one window, one batch) in pixels of the resized map."""
    torch.set_num_threads(1)
    windows = project / "data" / "short_term"
    benchmark = short_term("eth")
    bench = benchmark.load(windows, N_PAST, N_FUTURE)
    maps, _ = ynet_maps(benchmark.maps(windows))
    sizes = benchmark.scene_sizes(windows, None, {"eth"})
    model, loaded, scenes = load_for_scoring(project / "checkpoints" / "eth_ynet" / "best.pt",
                                             bench.test, maps, sizes, threads=1)
    assert loaded.crop == 32
    options = sampling_options(20, 1, TTST, CwsParams(), True, False)
    scene, row = scenes[0], 2
    _, origin = window_inputs(scene.semantic, scene.past[row:row + 1], loaded.max_distance,
                              loaded.crop, PAD_CLASS, loaded.crop_lead_steps)
    assert (origin != 0).any()  # the crop does not start at the map's corner
    drawn = qualitative(model, scene, row, loaded, options, np.zeros((*IMAGE_HW, 3), np.uint8), 7,
                        loaded.crop, loaded.crop_lead_steps)
    paths, goals = predict_scenes(model, [scene.subset([row])], loaded, options, 7,
                                  EvalParams(batch_size=1, chunk_size=8, bf16=False),
                                  len(bench.test), "one", loaded.crop, loaded.crop_lead_steps)
    index = scene.index[row]
    np.testing.assert_allclose(drawn["sampled_goals"], goals[index] * loaded.resize, atol=1e-4)
    np.testing.assert_allclose(drawn["predictions"], paths[index] * loaded.resize, atol=1e-4)


def test_qualitative_rows_prefer_other_scenes_then_other_tracks():
    moved = np.array([5.0, 9.0, 3.0, 7.0, 1.0])  # rows by distance: 1, 3, 0, 2, 4
    past = np.zeros((5, N_PAST, 2))
    future = np.zeros((5, N_FUTURE, 2))
    future[:, -1, 0] = moved
    test = WindowArrays(past=past, future=future, window_id=np.arange(5),
                        scene_id=np.array(["a", "a", "b", "a", "b"]),
                        track_id=np.array([0, 1, 2, 1, 3]), first_frame=np.zeros(5),
                        split=np.array(["test"] * 5))
    # row 1 (scene a), row 2 (the farthest of scene b), then row 0: row 3 is row 1's track
    assert qualitative_rows(test, 3) == [1, 2, 0]
    assert qualitative_rows(test, 5) == [1, 2, 0, 4, 3]  # row 4: a new track; row 3 last
    assert qualitative_rows(subset(test, np.array([0])), 3) == [0]


def test_a_heatmap_goes_into_the_scene_frame_at_its_origin():
    heatmap = torch.tensor([[1.0, 2.0], [3.0, 4.0]])
    out = in_scene_frame(heatmap, (-1, 1), 3, 3)  # column -1 falls off the map
    np.testing.assert_array_equal(out, [[0, 0, 0], [2, 0, 0], [4, 0, 0]])
    np.testing.assert_array_equal(in_scene_frame(heatmap, (0, 0), 1, 2), [[1, 2]])  # padding cut
    assert out.dtype == np.float32


def test_an_ethucy_camera_image_sits_in_its_grids_corner(tmp_path):
    write_ethucy_images(tmp_path)
    image = ethucy_scene_image(tmp_path, "eth", (210, 320))
    assert image.shape == (210, 320, 3) and image.dtype == np.uint8
    assert (image[:200, :300] == 255).all() and (image[200:] == 0).all() and (image[:, 300:] == 0).all()
    with pytest.raises(ValueError, match=r"eth/reference.png: 200 x 300 pixels, larger than"):
        ethucy_scene_image(tmp_path, "eth", (150, 320))
    with pytest.raises(ValueError, match="no ETH/UCY scene 'nowhere'"):
        ethucy_scene_image(tmp_path, "nowhere", (150, 320))


# ---------------------------------------------------------------------------------------------
# Merged files and the report


def test_merged_files_have_the_report_layout(project):
    out = project / "metrics" / "short_term"
    sdd = json.loads((out / "sdd.json").read_text())
    assert sdd["unit"] == "px" and sdd["rounds"] == 2 and set(sdd["models"]) == {"ynet", "pecnet"}
    assert set(sdd["models"]["ynet"]) == {"k20", "k5"}
    assert set(sdd["models"]["ynet"]["k5"]["ade"]) == {"mean", "std", "min", "max", "rounds"}
    eth = json.loads((out / "ethucy_eth.json").read_text())
    assert eth["unit"] == "m" and set(eth["models"]) == {"ynet", "sgan", "pecnet"}
    assert eth["models"]["ynet"]["ade"]["mean"] == run_record(project, "eth_ynet")["k20"]["ade"]["mean"]
    hotel = json.loads((out / "ethucy_hotel.json").read_text())
    assert "not_run_reason" in hotel["models"]["ynet"]
    assert {p.name for p in out.glob("*.json")} == {
        "sdd.json", *(f"ethucy_{d}.json" for d in SHORT_TERM_DATASETS if d != "sdd")}


def test_the_report_shows_the_merged_numbers_as_measured(project):
    paper = load_paper_values(REPO / "pipeline" / "report" / "paper_values.yaml")
    store = load_metrics(project / "metrics")
    bands = ReportParams(close=0.05, far=0.2)
    table1 = table_sdd_short(paper["sdd_short"], store, bands)
    kinds = {(c["model"], c["k"]): cell.kind for c, cell in
             zip(paper["sdd_short"]["columns"], table1.rows[0].cells)}
    assert kinds["ynet", 20] == kinds["ynet", 5] == kinds["pecnet", 20] == kinds["pecnet", 5] == "measured"
    assert kinds["sgan", 20] == "absent"  # not run in this fixture
    table2 = table_eth_ucy(paper["eth_ucy"], store, bands)
    eth_row = table2.rows[paper["eth_ucy"]["scenes"].index("eth")]
    labels = [(col.group, col.label) for col in table2.columns]
    measured = {label for label, cell in zip(labels, eth_row.cells) if cell.kind == "measured"}
    assert {("Y-net", "ADE"), ("S-GAN", "FDE"), ("PECNet", "ADE")} <= measured


def test_params_yaml_section_validates_for_both_profiles():
    params = read_params(REPO / "params.yaml")
    cpu = load_profile(ShortTermModelsParams, "short_term_models", {**params, "profile": "cpu"})
    paper = load_profile(ShortTermModelsParams, "short_term_models", {**params, "profile": "paper"})
    assert paper.ynet_datasets == list(SHORT_TERM_DATASETS) and paper.rounds >= 3
    assert paper.ynet_sdd.resize == 0.25 and abs(paper.ynet_ethucy.resize - 1 / 1.5) < 1e-6
    assert paper.epochs["ynet"] == {"sdd": 300, "ethucy": 300}
    assert set(cpu.ynet_datasets) <= set(SHORT_TERM_DATASETS)
    assert cpu.temperature == paper.temperature == 1.0
