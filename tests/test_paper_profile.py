"""The `paper` profile end to end on a tiny fixture, so it cannot rot unnoticed.

Runs the stage modules `train_ynet` and `evaluate_ynet` with params.yaml's real `paper` settings
(resize 0.25, kernel 31, sigma 4, distance gain 1, PyTorch's default head init, batch 8, all 8
augmentations, K_e 20, K_a up to 5, 3 rounds, the full ablation and K_a grid), changing only the
number of epochs, on three small scenes: training steps, evaluation, the metrics file.
"""

import json
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import torch
import yaml

from pipeline.stages import evaluate_ynet, train_ynet
from pipeline.data.semantic_maps import quantise
from pipeline.data.window_table import conform
from pipeline.harness.predictions import prediction_arrays, read_predictions
from tests.fixtures import write_maps_folder
from ynet.segmentation import CLASS_NAMES

REPO = Path(__file__).resolve().parents[1]
IMAGE_HW = (256, 320)  # original pixels; the paper's resize 0.25 gives 64 x 80 maps
N_PAST, N_FUTURE = 5, 30


def paper_params() -> dict:
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params["profile"] = "paper"
    params["ynet"]["paper"]["epochs"] = 1  # the one change: 300 epochs do not fit a test
    return params


def test_the_paper_settings_are_the_authors():
    """What this smoke test exercises is the authors' configuration (docs/profiles.md, `paper`)."""
    ynet, evaluation = paper_params()["ynet"]["paper"], paper_params()["eval"]["paper"]
    assert (ynet["resize"], ynet["kernel_size"], ynet["sigma"]) == (0.25, 31, 4.0)
    assert (ynet["distance_gain"], ynet["head_bias"], ynet["batch_size"]) == (1.0, None, 8)
    assert (ynet["learning_rate"], ynet["augmentations"], ynet["waypoints"]) == (1e-4, 8, [14, 29])
    assert (evaluation["k_e"], evaluation["rounds"]) == (20, 3)
    assert 5 in evaluation["ka_grid_k_a"] and 20 in evaluation["ka_grid_k_e"]


def windows(scene_id: str, split: str, n: int, first_id: int, rng) -> pd.DataFrame:
    """`n` walkers crossing the scene in straight lines at 1 FPS, 5 + 30 steps each."""
    rows = []
    height, width = IMAGE_HW
    for i in range(n):
        start = rng.uniform([20, 20], [width / 3, height - 20])
        velocity = rng.uniform([4, -2], [6, 2])
        xy = start + np.arange(N_PAST + N_FUTURE)[:, None] * velocity
        rows.append(pd.DataFrame({
            "window_id": first_id + i, "scene_id": scene_id, "track_id": i,
            "step": np.arange(N_PAST + N_FUTURE), "frame": 30 * np.arange(N_PAST + N_FUTURE),
            "x": xy[:, 0], "y": xy[:, 1], "split": split, "t_f": N_FUTURE, "source": "release"}))
    return pd.concat(rows)


def write_fixture(root: Path, qualitative_scenes: list[str]) -> None:
    rng = np.random.default_rng(0)
    tables, maps = [], {}
    layout = [("gates_0", "train", 8), ("gates_1", "val", 2)] + [
        (scene, "test", 1) for scene in qualitative_scenes]
    for scene_id, split, n in layout:
        tables.append(windows(scene_id, split, n, 100 * len(tables), rng))
        scene, video = scene_id.rsplit("_", 1)
        folder = root / "sdd" / "annotations" / scene / f"video{video}"
        folder.mkdir(parents=True)
        image = rng.integers(0, 255, (*IMAGE_HW, 3), dtype=np.uint8)
        assert cv2.imwrite(str(folder / "reference.jpg"), image)
        probs = rng.dirichlet(np.ones(6), size=(IMAGE_HW[0] // 4, IMAGE_HW[1] // 4))
        maps[scene_id] = quantise(probs.transpose(2, 0, 1).astype(np.float32))
    (root / "windows").mkdir()
    conform(pd.concat(tables)).to_parquet(root / "windows" / "release_tf30.parquet")
    write_maps_folder(root / "semantic_maps", maps, CLASS_NAMES)


@pytest.mark.slow
def test_paper_profile_trains_evaluates_and_writes_its_metrics(tmp_path, monkeypatch):
    params = paper_params()
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    write_fixture(tmp_path, params["eval"]["paper"]["qualitative_scenes"])
    monkeypatch.chdir(tmp_path)

    train_ynet.main(["--windows", "windows/release_tf30.parquet", "--semantic-maps", "semantic_maps",
                     "--sdd", "sdd", "--n-past", str(N_PAST), "--checkpoint-dir", "checkpoints",
                     "--model", "model.pt", "--history", "history.csv",
                     "--metrics", "ynet_train.json"])
    trained = json.loads(Path("ynet_train.json").read_text())
    assert trained["profile"] == "paper" and trained["epochs"] == 1
    assert trained["train_windows"] == 8 and np.isfinite(trained["best_val_ade"])
    saved = torch.load("model.pt", weights_only=True)
    assert saved["settings"]["resize"] == 0.25 and saved["config"]["head_bias"] is None

    evaluate_ynet.main(["--windows", "windows/release_tf30.parquet", "--model", "model.pt",
                        "--semantic-maps", "semantic_maps", "--sdd", "sdd", "--n-past", str(N_PAST),
                        "--metrics", "ynet_eval.json", "--qualitative", "qualitative.npz",
                        "--predictions", "ynet.parquet"])
    result = json.loads(Path("ynet_eval.json").read_text())
    evaluation = params["eval"]["paper"]
    assert result["profile"] == "paper" and result["n_windows"] == 3
    assert result["main"]["k_e"] == 20 and len(result["main"]["per_round"]) == 3
    assert np.isfinite(result["main"]["ade"]["mean"]) and result["main"]["fde"]["mean"] > 0
    assert set(result["ablation"]) == {"ttst_cws", "none", "cws"}
    assert all(len(row["per_round"]) == 3 for row in result["ablation"].values())
    grid = {(row["k_e"], row["k_a"]) for row in result["ka_grid"]}
    assert grid == {(k_e, k_a) for k_e in evaluation["ka_grid_k_e"] for k_a in evaluation["ka_grid_k_a"]}
    stored, metadata = read_predictions(Path("ynet.parquet"))  # the main setting's 3 rounds
    assert metadata["seeds"] == [0, 1, 2] and metadata["benchmark"] == "sdd_long_term_release_tf30"
    assert prediction_arrays(stored, round=2).samples.shape == (3, 20, N_FUTURE, 2)
    with np.load("qualitative.npz") as figure:
        assert figure["predictions_0"].shape == (20, N_FUTURE, 2)
