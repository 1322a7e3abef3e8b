"""inD from the user's own copy: a tiny synthetic copy in the official inD layout, written here.

The copy (`write_ind_copy`): three recordings at 25 FPS, background 400 x 300 px, orthoPxToMeter
0.01 (one background pixel = 0.01 * 12 = 0.12 m):
- 00, location 4 (test): pedestrian 0 for 1750 frames (70 steps at 1 FPS), a car;
- 07, location 1 (train): pedestrian 0 for 900 frames, a 10-frame gap, 500 more frames (pieces of
  36 and 20 steps), a bicycle, pedestrian 2 for only 100 frames (4 steps);
- 08, location 1 (validation, `val_recordings: [8]`): pedestrian 0 for 1000 frames (40 steps).
Windows of 5 + 30 steps, by hand: test 70 // 35 = 2, train 36 // 35 + 20 // 35 + 4 // 35 = 1,
val 40 // 35 = 1; of 5 + 5 steps: test 7, train 3 + 2 + 0 = 5, val 4.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import torch
import yaml

from pipeline.benchmarks import ind
from pipeline.runners import long_term_benchmark
from pipeline.runners.long_term_benchmark import EvalSettings, evaluate_benchmark
from pipeline.runners.long_term_training import TrainSettings, train_benchmark
from pipeline.stages import ind_windows
from pipeline.benchmarks.ind import IND, IndError, at_ind_scale
from pipeline.data.labels import MaskError
from pipeline.config.cws import CwsParams
from pipeline.config.data import DataParams, IndParams
from pipeline.config.eval import EvalParams
from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.ind_benchmark import IndBenchmarkParams
from pipeline.config.loading import ParamsError, from_dict, load_profile, load_section, read_params
from pipeline.config.pecnet import PecnetConfig
from pipeline.config.segmentation import SegmentationParams
from pipeline.config.sgan import SganConfig
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.config.runtime import RuntimeParams
from pipeline.config.ttst import TtstParams
from pipeline.config.ynet import YnetSettings
from pipeline.runners.segmentation import export_model
from pipeline.data.window_table import COLUMNS, to_arrays
from pipeline.harness.predictions import prediction_arrays, read_predictions
from pipeline.harness.scoring import min_ade_fde
from ynet.segmentation import UNet, UNetConfig
from tests.test_train_ynet import TTST

REPO = Path(__file__).resolve().parents[1]
FPS = 25
ORTHO = 0.01
METRES_PER_PIXEL = ORTHO * 12
IMAGE_HW = (300, 400)
WINDOWS = WindowParams()  # n_past 5, target_fps 1

# The official inD columns (the stage reads a subset; the copy holds them all).
TRACK_COLUMNS = ["recordingId", "trackId", "frame", "trackLifetime", "xCenter", "yCenter", "heading",
                 "width", "length", "xVelocity", "yVelocity", "xAcceleration", "yAcceleration",
                 "lonVelocity", "latVelocity", "lonAcceleration", "latAcceleration"]
TRACKS_META_COLUMNS = ["recordingId", "trackId", "initialFrame", "finalFrame", "numFrames", "width",
                       "length", "class"]
RECORDING_META_COLUMNS = ["recordingId", "locationId", "frameRate", "speedLimit", "weekday",
                          "startTime", "duration", "numTracks", "numVehicles", "numVRUs",
                          "latLocation", "lonLocation", "xUtmOrigin", "yUtmOrigin", "orthoPxToMeter"]

# recording -> (location, [(track, class, frames, x0, y0, vx, vy)]); metres, metres per frame.
RECORDINGS = {
    0: (4, [(0, "pedestrian", range(0, 1750), 6.0, -6.0, 0.016, -0.004),
            (1, "car", range(0, 2000), 10.0, -10.0, 0.1, 0.0)]),
    7: (1, [(0, "pedestrian", [*range(0, 900), *range(910, 1410)], 3.0, -20.0, 0.01, 0.005),
            (1, "bicycle", range(0, 1800), 5.0, -5.0, 0.01, 0.0),
            (2, "pedestrian", range(100, 200), 20.0, -20.0, 0.0, 0.01)]),
    8: (1, [(0, "pedestrian", range(50, 1050), 40.0, -3.0, -0.02, -0.01)]),
}
VAL = [8]
EXPECTED = {"tf30": {"train": 1, "val": 1, "test": 2}, "tf5": {"train": 5, "val": 4, "test": 7}}


def write_ind_copy(root: Path, frame_rate: float = FPS, labels: Path | None = None) -> Path:
    """The inD release layout `<root>/data/XX_*`; masks `<labels>/XX_background_mask.png` if asked."""
    data = root / "data"
    data.mkdir(parents=True)
    rng = np.random.default_rng(0)
    for recording, (location, tracks) in RECORDINGS.items():
        rows, meta = [], []
        for track, cls, frames, x0, y0, vx, vy in tracks:
            frames = np.asarray(list(frames))
            t = frames - frames[0]
            n = len(frames)
            rows.append(pd.DataFrame({
                "recordingId": recording, "trackId": track, "frame": frames, "trackLifetime": t,
                "xCenter": x0 + vx * t, "yCenter": y0 + vy * t, "heading": 0.0, "width": 0.5,
                "length": 0.5, "xVelocity": vx * frame_rate, "yVelocity": vy * frame_rate,
                "xAcceleration": 0.0, "yAcceleration": 0.0, "lonVelocity": 1.0, "latVelocity": 0.0,
                "lonAcceleration": 0.0, "latAcceleration": 0.0}, columns=TRACK_COLUMNS))
            meta.append([recording, track, frames[0], frames[-1], n, 0.5, 0.5, cls])
        prefix = data / f"{recording:02d}_"
        pd.concat(rows).to_csv(f"{prefix}tracks.csv", index=False)
        pd.DataFrame(meta, columns=TRACKS_META_COLUMNS).to_csv(f"{prefix}tracksMeta.csv", index=False)
        pd.DataFrame([[recording, location, frame_rate, 50.0, "monday", "08:00", 80.0, len(tracks),
                       1, len(tracks) - 1, 50.78, 6.06, 300000.0, 5600000.0, ORTHO]],
                     columns=RECORDING_META_COLUMNS).to_csv(f"{prefix}recordingMeta.csv", index=False)
        image = rng.integers(0, 255, (*IMAGE_HW, 3), dtype=np.uint8)
        cv2.imwrite(f"{prefix}background.png", image)
        if labels is not None:
            labels.mkdir(exist_ok=True)
            mask = np.ones(IMAGE_HW, np.uint8)  # pavement
            mask[:, 200:] = 2  # road
            mask[100:150] = 4  # terrain
            cv2.imwrite(str(labels / f"{recording:02d}_background_mask.png"), mask)
    return root


def build(root: Path, **changes) -> ind.IndWindows:
    return ind.build(IndParams(path=str(root), val_recordings=VAL, **changes), WINDOWS)


@pytest.fixture(scope="module")
def copy(tmp_path_factory) -> Path:
    return write_ind_copy(tmp_path_factory.mktemp("ind"))


@pytest.fixture(scope="module")
def built(copy) -> ind.IndWindows:
    return build(copy)


# ---------------------------------------------------------------------------------------------
# Parameters


def test_params_yaml_sections_validate():
    params = read_params(REPO / "params.yaml")
    data = load_section(DataParams, "data", params)
    assert data.ind.path == "" and data.ind.labels == "" and not data.ind.provided
    for profile in params["ind_benchmark"]:
        load_profile(IndBenchmarkParams, "ind_benchmark", {**params, "profile": profile})
    paper = load_profile(IndBenchmarkParams, "ind_benchmark", {**params, "profile": "paper"})
    assert paper.ynet_resize == 0.33  # the authors' inD config


def test_params_checks():
    with pytest.raises(ParamsError, match=r"unknown key\(s\) \['pth'\]"):
        from_dict(DataParams, {"ind": {"pth": "x", "labels": "", "val_recordings": []}}, "data")
    with pytest.raises(ParamsError, match="labels is set but path is empty"):
        from_dict(DataParams, {"ind": {"path": "", "labels": "masks", "val_recordings": [7]}}, "data")
    with pytest.raises(ParamsError, match="distinct recording numbers"):
        from_dict(DataParams, {"ind": {"path": "x", "labels": "", "val_recordings": [7, 7]}}, "data")
    assert from_dict(IndParams, {"path": None, "labels": None}, "data.ind").path == ""


# ---------------------------------------------------------------------------------------------
# Reading and cutting


def test_world_metres_map_to_background_pixels_with_y_flipped():
    x, y = ind.world_to_pixels(np.array([6.0, 1.2, 0.0]), np.array([-6.0, 2.4, 0.0]), ORTHO)
    np.testing.assert_allclose(x, [50.0, 10.0, 0.0])  # 6 m / 0.12 m per pixel
    np.testing.assert_allclose(y, [50.0, -20.0, 0.0])  # world y up = image rows up


def test_window_positions_are_background_pixels(built):
    table = built.tables[30]
    rows = table[(table["scene_id"] == "ind_loc4_rec00") & (table["step"] == 0)].sort_values("frame")
    assert rows["frame"].tolist() == [0, 875]  # second window: 35 steps of 25 frames later
    # pedestrian 0 of recording 00 starts at (6, -6) m and moves (0.016, -0.004) m per frame
    np.testing.assert_allclose(rows["x"], [6.0 / METRES_PER_PIXEL, (6.0 + 0.016 * 875) / METRES_PER_PIXEL])
    np.testing.assert_allclose(rows["y"], [6.0 / METRES_PER_PIXEL, (6.0 + 0.004 * 875) / METRES_PER_PIXEL])
    assert built.metrics["pedestrian_positions_outside_image"] == 0


def test_only_pedestrians_are_kept(built):
    for table in built.tables.values():
        pairs = set(map(tuple, table[["scene_id", "track_id"]].drop_duplicates().to_numpy().tolist()))
        assert pairs <= {("ind_loc4_rec00", 0), ("ind_loc1_rec07", 0), ("ind_loc1_rec07", 2),
                         ("ind_loc1_rec08", 0)}
    tf5 = built.tables[5]
    assert tf5.loc[tf5["scene_id"] == "ind_loc1_rec07", "track_id"].unique().tolist() == [0]
    assert built.metrics["tracks_per_class"] == {"bicycle": 1, "car": 1, "pedestrian": 4}
    n_pedestrian_rows = 1750 + 1400 + 100 + 1000
    assert built.metrics["pedestrian_positions"] == n_pedestrian_rows


def test_25_fps_becomes_1_fps_and_a_frame_gap_splits_the_track(built):
    table = built.tables[5]
    steps = table.groupby("window_id")["frame"].diff().dropna()
    assert steps.eq(FPS).all()
    track = table[(table["scene_id"] == "ind_loc1_rec07") & (table["track_id"] == 0) & (table["step"] == 0)]
    # piece 1: frames 0..899 (36 steps: 3 windows of 10); piece 2 starts after the gap at 910
    assert sorted(track["frame"]) == [0, 250, 500, 910, 1160]
    dx = table.sort_values(["window_id", "step"]).groupby("window_id")["x"].diff().dropna()
    rec08 = table.loc[dx.index, "scene_id"] == "ind_loc1_rec08"
    np.testing.assert_allclose(dx[rec08], -0.02 * FPS / METRES_PER_PIXEL)


def test_window_counts_and_splits(built):
    assert built.metrics["windows"] == EXPECTED
    for t_f, table in built.tables.items():
        assert list(table.columns) == list(COLUMNS) and table["t_f"].eq(t_f).all()
        assert table.groupby("window_id").size().eq(5 + t_f).all()
        assert table["window_id"].drop_duplicates().tolist() == list(range(table["window_id"].nunique()))
        assert table["source"].eq("raw").all()
    splits = dict(built.tables[30][["scene_id", "split"]].drop_duplicates().to_numpy().tolist())
    assert splits == {"ind_loc4_rec00": "test", "ind_loc1_rec07": "train", "ind_loc1_rec08": "val"}
    assert built.metrics["recordings"] == {"train": [7], "val": [8], "test": [0]}
    scenes = built.index["scenes"]
    assert scenes["ind_loc4_rec00"]["split"] == "test" and scenes["ind_loc1_rec07"]["location"] == 1
    assert (scenes["ind_loc1_rec08"]["height"], scenes["ind_loc1_rec08"]["width"]) == IMAGE_HW


def test_outputs_are_written_and_fingerprinted(built, copy, tmp_path):
    ind.write(built, tmp_path / "out", tmp_path / "m.json")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "backgrounds", "index.json", "tf30.parquet", "tf5.parquet"]
    assert len(list((tmp_path / "out" / "backgrounds").glob("ind_*.png"))) == 3
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "out" / "tf30.parquet"), built.tables[30])
    metrics = json.loads((tmp_path / "m.json").read_text())
    assert metrics["provided"] is True and metrics["status"] == "ok"
    assert metrics["source_fingerprint"]["files"] == 12
    path = copy / "data" / "07_tracksMeta.csv"
    os.utime(path, ns=(path.stat().st_atime_ns, path.stat().st_mtime_ns + 10**9))
    assert build(copy).metrics["source_fingerprint"]["sha256"] != metrics["source_fingerprint"]["sha256"]


def test_not_provided_writes_a_record_and_empty_tables(tmp_path):
    result = ind.build(IndParams(), WINDOWS)
    ind.write(result, tmp_path / "out", tmp_path / "m.json")
    metrics = json.loads((tmp_path / "m.json").read_text())
    assert metrics["provided"] is False and metrics["status"] == "not provided"
    assert "licence" in metrics["reason"] and "data.ind.path" in metrics["reason"]
    assert metrics["windows"]["tf30"] == {"train": 0, "val": 0, "test": 0}
    for t_f in (30, 5):
        table = pd.read_parquet(tmp_path / "out" / f"tf{t_f}.parquet")
        assert len(table) == 0 and {c: str(t) for c, t in table.dtypes.items()} == COLUMNS
    assert json.loads((tmp_path / "out" / "index.json").read_text())["provided"] is False


# ---------------------------------------------------------------------------------------------
# Bad input: a clear error naming the file, and nothing written


def break_copy(root: Path, how: str) -> None:
    data = root / "data"
    if how == "missing tracks":
        (data / "07_tracks.csv").unlink()
    elif how == "missing column":
        table = pd.read_csv(data / "08_tracks.csv").drop(columns="xCenter")
        table.to_csv(data / "08_tracks.csv", index=False)
    elif how == "frame rate":
        meta = pd.read_csv(data / "00_recordingMeta.csv").assign(frameRate=25.5)
        meta.to_csv(data / "00_recordingMeta.csv", index=False)
    elif how == "unknown track":
        meta = pd.read_csv(data / "08_tracksMeta.csv")
        meta.iloc[:0].to_csv(data / "08_tracksMeta.csv", index=False)
    elif how == "missing background":
        (data / "00_background.png").unlink()
    elif how == "not a number":
        table = pd.read_csv(data / "07_tracks.csv")
        table["yCenter"] = table["yCenter"].astype(str)
        table.loc[3, "yCenter"] = "n/a?"
        table.to_csv(data / "07_tracks.csv", index=False)


@pytest.mark.parametrize("how, message", [
    ("missing tracks", r"07_tracks\.csv: missing file"),
    ("missing column", r"08_tracks\.csv: missing column\(s\) \['xCenter'\]"),
    ("frame rate", r"00_recordingMeta\.csv: frameRate 25\.5 is not a multiple of the target 1 FPS"),
    ("unknown track", r"08_tracks\.csv: trackId\(s\) \[0\] have no row in 08_tracksMeta\.csv"),
    ("missing background", r"00_background\.png: missing file"),
    ("not a number", r"07_tracks\.csv: cannot be read"),
])
def test_bad_copy_fails_naming_file_and_problem(tmp_path, how, message):
    root = write_ind_copy(tmp_path / "copy")
    break_copy(root, how)
    with pytest.raises(IndError, match=message):
        build(root)


def test_frame_rate_must_be_a_multiple_of_the_target(copy):
    with pytest.raises(IndError, match=r"frameRate 25 is not a multiple of the target 2 FPS"):
        ind.build(IndParams(path=str(copy), val_recordings=VAL), WindowParams(raw_fps=30, target_fps=2))


@pytest.mark.parametrize("val, message", [
    ([0], r"recording\(s\) \[0\] are at the test location 4"),
    ([30], r"recording\(s\) \[30\] not in the inD copy"),
])
def test_validation_recordings_are_checked(copy, val, message):
    with pytest.raises(IndError, match=message):
        ind.build(IndParams(path=str(copy), val_recordings=val), WINDOWS)


def test_not_the_release_folder_is_explained(tmp_path):
    with pytest.raises(IndError, match=r"not a folder; data.ind.path must be the inD release folder"):
        build(tmp_path / "nowhere")
    (tmp_path / "empty" / "data").mkdir(parents=True)
    with pytest.raises(IndError, match=r"no XX_recordingMeta\.csv"):
        build(tmp_path / "empty")


def test_bad_mask_fails_naming_the_file(tmp_path):
    root = write_ind_copy(tmp_path / "copy", labels=tmp_path / "masks")
    cv2.imwrite(str(tmp_path / "masks" / "07_background_mask.png"), np.full((10, 10), 1, np.uint8))
    with pytest.raises(MaskError, match=r"07_background_mask\.png: size \(10, 10\)"):
        build(root, labels=str(tmp_path / "masks"))


def write_params(folder: Path, path: str = "", labels: str = "", **sections) -> None:
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params["data"]["ind"].update(path=path, labels=labels, val_recordings=VAL)
    for key, value in sections.items():
        params[key] = value
    (folder / "params.yaml").write_text(yaml.safe_dump(params))


def test_failed_run_leaves_the_previous_outputs(tmp_path, monkeypatch):
    root = write_ind_copy(tmp_path / "copy")
    monkeypatch.chdir(tmp_path)
    write_params(tmp_path, path=str(root))
    ind_windows.main(["--out", "out", "--metrics", "m.json"])
    before = {p: p.read_bytes() for p in [*(tmp_path / "out").rglob("*.*"), tmp_path / "m.json"]}
    break_copy(root, "missing column")
    with pytest.raises(SystemExit, match=r"ind_windows: .*08_tracks\.csv: missing column"):
        ind_windows.main(["--out", "out", "--metrics", "m.json"])
    assert {p: p.read_bytes() for p in before} == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


# ---------------------------------------------------------------------------------------------
# The benchmark, with tiny settings


@dataclasses.dataclass(frozen=True)
class BenchmarkSettings:
    """Training and scoring settings together, as params.yaml's sections give them (`run_benchmark`)."""

    profile: str
    ind: IndBenchmarkParams
    ynet: YnetSettings
    eval: EvalParams
    ttst: TtstParams
    cws: CwsParams
    segmentation: SegmentationParams
    baseline_configs: dict
    train_baseline: TrainBaselineParams
    evaluate_baseline: EvaluateBaselineParams
    runtime: RuntimeParams = dataclasses.field(default_factory=lambda: RuntimeParams(device="cpu"))

    @property
    def training(self) -> TrainSettings:  # as stage train_ind builds them
        ynet, segmentation = at_ind_scale(self.ind, self.ynet, self.segmentation)
        return TrainSettings(self.profile, ynet, segmentation, self.ind.freeze_encoder_epochs,
                             self.baseline_configs, self.train_baseline, self.runtime)

    @property
    def evaluation(self) -> EvalSettings:  # as stage evaluate_ind builds them
        return EvalSettings(self.profile, self.eval, self.ttst, self.cws, self.evaluate_baseline,
                            self.train_baseline.threads, self.runtime)


def run_benchmark(ind_dir: Path, segmentation_model: Path, checkpoint_dir: Path,
                  settings: BenchmarkSettings) -> tuple[dict, dict]:
    """Train, then score: the two stages' runners in one call; returns what `evaluate_benchmark`
    returns."""
    trained = train_benchmark(IND, ind_dir, segmentation_model, checkpoint_dir, settings.training)
    if not trained["provided"]:
        return trained, {}
    return evaluate_benchmark(IND, ind_dir, checkpoint_dir, trained, settings.evaluation)


def tiny_settings(**changes) -> BenchmarkSettings:
    settings = BenchmarkSettings(
        profile="cpu",
        ind=IndBenchmarkParams(ynet_resize=0.33, segmentation_downsample=3, freeze_encoder_epochs=1),
        ynet=YnetSettings(epochs=1, batch_size=2, augmentations=1, kernel_size=7, sigma=1.5,
                          encoder_channels=[4, 4, 8, 8, 8], decoder_channels=[8, 8, 8, 4, 4],
                          threads=1),
        eval=EvalParams(k_e=3, k_a=1, rounds=1, ablation_rounds=1, ka_grid_k_e=[3], ka_grid_k_a=[2],
                        batch_size=2, chunk_size=2),
        ttst=TTST, cws=CwsParams(),
        segmentation=SegmentationParams(base_channels=4, depth=2, epochs=2, crops_per_image=1,
                                        lr_drop_epoch=1, bf16=False, crop=32, pad_multiple=32),
        baseline_configs={
            "sgan": SganConfig(epochs=1, batch_size=8, embedding_dim=4, encoder_hidden=8,
                               decoder_hidden=8, noise_dim=2, bottleneck_dim=4, pool_hidden=8, mlp_dim=8,
                               discriminator_hidden=8, best_of_k=2, val_k=2),
            "pecnet": PecnetConfig(epochs=1, batch_size=8, past_hidden=[16], endpoint_hidden=[8],
                                   latent_hidden=[8], decoder_hidden=[16], predictor_hidden=[16],
                                   nonlocal_hidden=[8], nonlocal_dim=4, nonlocal_rounds=1,
                                   feature_dim=4, latent_dim=2, data_scale=0.02, kl_weight=0.01,
                                   val_k=2),
        },
        train_baseline=TrainBaselineParams(seed=0, threads=1),
        evaluate_baseline=EvaluateBaselineParams(k=3, split="test", rounds=1, seed=0, threads=1),
    )
    return dataclasses.replace(settings, **changes)


def write_tiny_unet(path: Path) -> Path:
    torch.manual_seed(0)
    model = UNet(UNetConfig(base_channels=4, depth=2))
    params = SegmentationParams(base_channels=4, depth=2, epochs=1, crops_per_image=1, lr_drop_epoch=1,
                                bf16=False, crop=32, pad_multiple=32)
    export_model(path, model, params, "cpu", ["gates_1"],
                 [{"epoch": 1, "loss": 0.5, "lr": 1e-3, "crops": 1, "seconds": 0.1}])
    return path


def test_load_gives_the_windows_and_one_labelled_background_per_location(tmp_path):
    root = write_ind_copy(tmp_path / "copy", labels=tmp_path / "masks")
    ind.write(build(root, labels=str(tmp_path / "masks")), tmp_path / "ind", tmp_path / "w.json")
    assert IND.not_provided(tmp_path / "ind") is None
    data = IND.load(tmp_path / "ind")
    assert {split: len(arrays) for split, arrays in data.splits.items()} == EXPECTED["tf30"]
    assert len(data.base) == sum(EXPECTED["tf5"].values()) and data.base.future.shape[1] == 5
    assert data.horizon == 30 and data.table == tmp_path / "ind" / "tf30.parquet"
    assert set(data.sizes) == set(data.backgrounds) == {"ind_loc4_rec00", "ind_loc1_rec07", "ind_loc1_rec08"}
    assert data.sizes["ind_loc1_rec07"] == IMAGE_HW
    # recordings 07 and 08 share location 1's background: the first only
    assert data.finetune_scenes == ["ind_loc1_rec07"] and data.scored_scenes == ["ind_loc4_rec00"]
    assert all(b.image.is_file() and b.labels.is_file() for b in data.backgrounds.values())

    ind.write(ind.build(IndParams(), WINDOWS), tmp_path / "absent", tmp_path / "w.json")
    assert IND.not_provided(tmp_path / "absent") == ind.NOT_PROVIDED_REASON


def test_at_ind_scale_sets_ynet_resize_and_unet_downsample():
    tiny = tiny_settings()
    ynet, segmentation = at_ind_scale(tiny.ind, tiny.ynet, tiny.segmentation)
    assert ynet == dataclasses.replace(tiny.ynet, resize=0.33) != tiny.ynet
    assert segmentation == dataclasses.replace(tiny.segmentation, downsample=3) != tiny.segmentation


def test_benchmark_not_provided_is_a_record(tmp_path):
    ind.write(ind.build(IndParams(), WINDOWS), tmp_path / "ind", tmp_path / "w.json")
    result, predictions = run_benchmark(tmp_path / "ind", tmp_path / "absent.pt", tmp_path / "ckpt",
                                        tiny_settings())
    assert result == {"provided": False, "status": "not provided", "reason": ind.NOT_PROVIDED_REASON}
    assert (tmp_path / "ckpt").is_dir() and predictions == {}
    long_term_benchmark.write_predictions(IND, tmp_path / "stored", predictions, result["reason"])
    for model in long_term_benchmark.MODELS:  # a declared file per model, giving the reason
        stored, metadata = read_predictions(tmp_path / "stored" / f"{model}.parquet")
        assert len(stored) == 0 and metadata["not_run_reason"] == ind.NOT_PROVIDED_REASON
        assert metadata["model"] == model and metadata["unit"] == "px"


def test_benchmark_smoke_on_the_fixture_with_labels(tmp_path):
    torch.set_num_threads(1)
    root = write_ind_copy(tmp_path / "copy", labels=tmp_path / "masks")
    ind.write(build(root, labels=str(tmp_path / "masks")), tmp_path / "ind", tmp_path / "w.json")
    result, predictions = run_benchmark(
        tmp_path / "ind", write_tiny_unet(tmp_path / "unet.pt"), tmp_path / "ckpt", tiny_settings())
    assert result["provided"] is True and result["status"] == "ok" and result["t_f"] == 30
    assert result["windows"] == EXPECTED["tf30"] and result["n_windows"] == 2
    assert result["resize"] == 0.33 and result["train"]["epochs"] == 1
    for key in ("ade", "fde", "ade_joint", "fde_joint"):
        assert np.isfinite(result["main"][key]["mean"])
    assert set(result["ablation"]) == {"none", "cws", "ttst_cws"}
    assert [(row["k_e"], row["k_a"]) for row in result["ka_grid"]] == [(3, 2)]
    assert set(result["baselines"]) == {"sgan", "pecnet", "rpecnet", "constant_velocity"}
    for model, scores in result["baselines"].items():
        assert scores["horizon"] == 30 and scores["n_windows"] == 2 and np.isfinite(scores["ade"]["std"])
    assert result["baselines"]["rpecnet"]["trained_horizon"] == 5
    semantic = result["semantic"]
    assert semantic["source"] == "finetuned" and semantic["train_scenes"] == ["ind_loc1_rec07"]
    assert semantic["test"]["scenes"] == ["ind_loc4_rec00"] and 0 <= semantic["test"]["miou"] <= 1
    assert sorted(p.name for p in (tmp_path / "ckpt").iterdir()) == [
        "pecnet_tf30", "pecnet_tf5", "segmentation", "sgan_tf30", "ynet"]
    json.dumps(result)  # the metrics file holds plain JSON values only

    # every round of every model's test predictions stored: scored from the file, the same numbers
    long_term_benchmark.write_predictions(IND, tmp_path / "stored", predictions)
    n_past = json.loads((tmp_path / "ind" / "index.json").read_text())["n_past"]
    test = to_arrays(pd.read_parquet(tmp_path / "ind" / "tf30.parquet").query("split == 'test'"),
                     n_past)
    per_round = {"ynet": result["main"]["per_round"],
                 **{model: scores["per_round"] for model, scores in result["baselines"].items()}}
    assert set(per_round) == set(long_term_benchmark.MODELS)
    for model, rounds in per_round.items():
        stored, metadata = read_predictions(tmp_path / "stored" / f"{model}.parquet")
        assert metadata["benchmark"] == "ind_long_term" and metadata["unit"] == "px"
        assert metadata["window_table"] == str(tmp_path / "ind" / "tf30.parquet")
        assert metadata["k"] == 3  # Y-net: K_e x K_a = 3 x 1; the baselines: evaluate_baseline.k
        for r, in_memory in enumerate(rounds):
            arrays = prediction_arrays(stored, round=r)
            np.testing.assert_array_equal(arrays.window_ids, test.window_id)
            assert (arrays.goals is not None) == (model == "ynet")
            scored = min_ade_fde(arrays.samples, test.future, arrays.goals)
            assert {key: float(value.mean()) for key, value in scored.items()} == in_memory


# ---------------------------------------------------------------------------------------------
# `dvc repro` in a temporary copy of the repository, without and with the path


def copy_repo(target: Path) -> None:
    for name in ("dvc.yaml", "params.yaml", "pyproject.toml"):
        shutil.copy(REPO / name, target / name)
    for package in ("pipeline", "ynet"):
        shutil.copytree(REPO / package, target / package, ignore=shutil.ignore_patterns("__pycache__"))


def dvc(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "DVC_NO_ANALYTICS": "1"}
    result = subprocess.run(["dvc", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    return result


def tiny_profile(params: dict) -> dict:
    """The cpu profile shrunk so the benchmark on the fixture takes seconds."""
    tiny = tiny_settings()
    out = {"ynet": {**params["ynet"], "cpu": dataclasses.asdict(tiny.ynet)},
           "eval": {**params["eval"], "cpu": {**params["eval"]["cpu"], "k_e": 3, "rounds": 1,
                                             "ablation_rounds": 1, "ka_grid_k_e": [3], "ka_grid_k_a": [2],
                                             "batch_size": 2, "chunk_size": 2}},
           "evaluate_baseline": dataclasses.asdict(tiny.evaluate_baseline),
           "train_baseline": dataclasses.asdict(tiny.train_baseline)}
    for model in ("sgan", "pecnet"):
        out[model] = {**params[model], "cpu": dataclasses.asdict(tiny.baseline_configs[model])}
    return out


def test_dvc_repro_without_and_with_the_path(tmp_path):
    repo = tmp_path / "repo"
    repo.mkdir()
    copy_repo(repo)
    dvc(["init", "--no-scm", "-q"], repo)
    write_tiny_unet(repo / "data" / "segmentation" / "model.pt")  # stands in for stage segmentation

    dvc(["repro", "--single-item", "code_fingerprints", "ind_windows", "train_ind", "evaluate_ind"], repo)
    windows = json.loads((repo / "metrics/ind_windows.json").read_text())
    assert windows["provided"] is False and "data.ind.path" in windows["reason"]
    assert windows["windows"] == {"tf30": {"train": 0, "val": 0, "test": 0},
                                  "tf5": {"train": 0, "val": 0, "test": 0}}
    benchmark = json.loads((repo / "metrics/ind_benchmark.json").read_text())
    assert benchmark == {"provided": False, "status": "not provided", "reason": windows["reason"]}
    for model in long_term_benchmark.MODELS:  # the declared predictions, empty, giving the reason
        stored, metadata = read_predictions(repo / "data" / "predictions" / "ind" / f"{model}.parquet")
        assert len(stored) == 0 and metadata["not_run_reason"] == windows["reason"]

    root = write_ind_copy(tmp_path / "copy")
    params = yaml.safe_load((repo / "params.yaml").read_text())
    write_params(repo, path=str(root), **tiny_profile(params))
    dvc(["repro", "--single-item", "code_fingerprints", "ind_windows", "train_ind", "evaluate_ind"], repo)
    windows = json.loads((repo / "metrics/ind_windows.json").read_text())
    assert windows["provided"] is True and windows["windows"] == EXPECTED
    benchmark = json.loads((repo / "metrics/ind_benchmark.json").read_text())
    assert benchmark["provided"] is True and benchmark["semantic"]["source"] == "sdd_unet"
    assert np.isfinite(benchmark["main"]["ade"]["mean"]) and set(benchmark["baselines"]) == {
        "sgan", "pecnet", "rpecnet", "constant_velocity"}
    stored, _ = read_predictions(repo / "data" / "predictions" / "ind" / "ynet.parquet")
    assert stored["window_id"].nunique() == benchmark["n_windows"]
    assert "ind_windows" in (repo / "dvc.lock").read_text()

    status = dvc(["status", "ind_windows"], repo)  # the copy outside the repo is not a dependency
    assert "changed" not in status.stdout
