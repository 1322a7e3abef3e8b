"""Every input a stage reads is checked: a bad one stops the stage with a message naming the file,
the line or key, and what is wrong, and leaves no partial output.

These are the checks that no other test asserted the message of (the catalogue of all checks and
where each is tested was written alongside). Bad inputs are built in `tmp_path`, with the fixture
writers of `tests/fixtures.py`, `tests/test_labels.py` and `tests/test_ind.py`; where the check runs
inside a stage's `main(argv)` the stage is run in `tmp_path` with a minimal params.yaml, and no
output may be left behind. The files one stage writes for another (`index.json`, `maps.npz`) are
checked on reading too: their section ends with every stage that reads one, given a bad one.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import yaml

from pipeline.benchmarks import ind
from pipeline.benchmarks.ethucy import (
    MAP_CLASSES, SCENES, ethucy_fold_windows, load_ethucy_scenes, read_oracle, sgan_file_scene,
    sgan_window_rows, write_ethucy_maps,
)
from pipeline.benchmarks.ind import IndError
from pipeline.benchmarks.short_term import ShortTermInputError, read_rows
from pipeline.benchmarks.trajnet_sdd import fixed_windows, read_sdd_ratios, sdd_trajnet_windows
from pipeline.config.compat import CompatParams
from pipeline.config.cws import CwsParams
from pipeline.config.data import IndParams
from pipeline.config.eval import EvalParams
from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.fetch import FetchParams
from pipeline.config.ind_benchmark import IndBenchmarkParams
from pipeline.config.labels import LabelsParams
from pipeline.config.loading import ParamsError, from_dict, load_profile, load_section, read_params
from pipeline.config.segmentation import AugmentParams, SegmentationParams
from pipeline.config.semantic import SemanticParams
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams, YnetScale
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.ttst import TtstParams
from pipeline.config.windows import WindowParams
from pipeline.config.ynet_horizons import HorizonParams
from pipeline.data.checksums import ChecksumError, read_manifest
from pipeline.data.homography import HomographyError, read_homography
from pipeline.data.labels import MaskError, find_masks, read_index, read_label_map
from pipeline.data.tracks import AnnotationError, build_tracks, parse_annotations
from pipeline.data.window_table import conform, to_arrays
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.windows import ReleaseError, raw_windows, validate_release
from pipeline.io import IntermediateError
from pipeline.runners import long_term_benchmark
from pipeline.stages import (evaluate_ind, evaluate_short_term_baseline, evaluate_short_term_ynet,
                             evaluate_ynet, evaluate_ynet_horizon, train_ind, train_short_term_baseline,
                             train_short_term_ynet, train_ynet, train_ynet_horizon, ynet_slot_scoring)
from pipeline.stages import audit as audit_stage
from pipeline.stages import fetch as fetch_stage
from pipeline.stages import horizon_windows as horizon_windows_stage
from pipeline.stages import ind_windows as ind_windows_stage
from pipeline.stages import labels as labels_stage
from pipeline.stages import segmentation as segmentation_stage
from pipeline.stages import semantic_maps as semantic_maps_stage
from pipeline.stages import short_term_windows as short_term_stage
from pipeline.stages import tracks as tracks_stage
from pipeline.stages import windows as windows_stage
from tests.fixtures import (STRIDE, annotation_lines, release_rows, write_annotations, write_manifest,
                            write_maps_folder, write_mirror)
from tests.test_ind import VAL, write_ind_copy
from tests.test_labels import good_mask, make_fixture, write_png
from ynet.segmentation import CLASS_NAMES

REPO = Path(__file__).resolve().parents[1]

WINDOWS_YAML = ("windows: {n_past: 5, horizons: [5, 30], raw_fps: 30, target_fps: 1, "
                "label: Pedestrian, release_horizon: 30}\nsplit: {val_videos: []}\n")


def esc(path) -> str:
    return re.escape(str(path))


def nothing_written(folder: Path, *names: str) -> bool:
    """None of `names` exists under `folder`, and no staging leftovers (hidden entries) either."""
    leftovers = [p for p in folder.rglob(".*") if p.name != ".pytest_cache"]
    return not any((folder / n).exists() for n in names) and not leftovers


# ---------------------------------------------------------------------------------------------
# params.yaml: the file, its sections, and every range check of the dataclasses


def test_params_file_missing_or_not_a_mapping(tmp_path):
    with pytest.raises(ParamsError, match=rf"^{esc(tmp_path / 'params.yaml')}: not found"):
        read_params(tmp_path / "params.yaml")
    (tmp_path / "params.yaml").write_text("- just\n- a list\n")
    with pytest.raises(ParamsError, match=rf"^{esc(tmp_path / 'params.yaml')}: expected a mapping "
                                          r"at the top level"):
        read_params(tmp_path / "params.yaml")


def test_missing_section_or_profile_is_named():
    with pytest.raises(ParamsError, match=r"^params.yaml: missing section 'windows'$"):
        load_section(WindowParams, "windows", {"split": {}})
    with pytest.raises(ParamsError, match=r"^params.yaml: missing section 'ynet_horizons'$"):
        load_profile(HorizonParams, "ynet_horizons", {"profile": "cpu"})
    with pytest.raises(ParamsError, match=r"^params.yaml:ynet_horizons: no settings for profile "
                                          r"'gpu'; profiles here: \['cpu'\]"):
        load_profile(HorizonParams, "ynet_horizons",
                     {"profile": "gpu", "ynet_horizons": {"cpu": {"epochs": {10: 1}}}})


def test_section_that_is_not_a_mapping_is_named():
    with pytest.raises(ParamsError, match=r"^params.yaml:windows: expected a mapping, got list"):
        load_section(WindowParams, "windows", {"windows": [5, 30]})
    with pytest.raises(ParamsError, match=r"^seg.augment: expected a mapping, got int"):
        from_dict(SegmentationParams, {**SEGMENTATION, "augment": 3}, "seg")


def test_a_stage_stops_on_a_missing_section_before_writing(tmp_path, monkeypatch):
    write_annotations(tmp_path / "sdd", "gates", 2, annotation_lines(1, range(3), 0, 0, 1, 0))
    monkeypatch.chdir(tmp_path)
    write_manifest(tmp_path / "sdd", tmp_path / "sdd.sha256")
    (tmp_path / "params.yaml").write_text("windows: {}\n")
    with pytest.raises(ParamsError, match=r"^params.yaml: missing section 'compat'$"):
        tracks_stage.main(["--sdd", "sdd", "--manifest", "sdd.sha256", "--out", "out/sdd.parquet",
                           "--sources", "out/sdd_sources.json"])
    assert not (tmp_path / "out").exists()


SEGMENTATION = {"base_channels": 4, "depth": 2, "epochs": 1, "crops_per_image": 1,
                "lr_drop_epoch": 0, "bf16": False}
EVALUATE_BASELINE = {"k": 20, "split": "test", "rounds": 1, "seed": 0, "threads": 1}
SCALE = {"resize": 0.25, "kernel_size": 31, "sigma": 4.0}
SHORT_TERM_MODELS = {
    "epochs": {m: {"sdd": 1, "ethucy": 1} for m in ("ynet", "sgan", "pecnet")},
    "ynet_steps_per_epoch": 0, "ynet_training": {"sdd": {}, "ethucy": {}}, "val_windows": 0,
    "ynet_sdd": SCALE, "ynet_ethucy": SCALE, "ynet_datasets": ["sdd"], "why_subset": "",
    "temperature": 1.0, "rel_threshold": {"sdd": 0.01, "ethucy": 0.01}, "k_sdd": [20, 5],
    "k_ethucy": [20], "rounds": 1,
    "seed": 0, "eval_batch_size": 4, "eval_chunk_size": 4, "eval_threads": 2, "bf16": False,
}
IND_BENCHMARK = {"ynet_resize": 0.33, "segmentation_downsample": 3, "freeze_encoder_epochs": 0}


@pytest.mark.parametrize("cls, base, bad, message", [
    (FetchParams, {}, {"sources": ["kitti"]}, r"unknown source\(s\) \['kitti'\]; known: \['sdd'"),
    (FetchParams, {}, {"locations": []}, r"locations: at least one location is needed"),
    (WindowParams, {}, {"n_past": 1}, r"n_past must be at least 2"),
    (WindowParams, {}, {"horizons": []}, r"horizons must be a non-empty list of positive seconds"),
    (WindowParams, {}, {"horizons": [0, 30]}, r"horizons must be a non-empty list of positive"),
    (IndParams, {}, {"path": 3}, r"\.path: expected str or null, got int 3"),
    (IndParams, {"path": "x"}, {"labels": ["a"]}, r"\.labels: expected str or null, got list \['a'\]"),
    (TtstParams, {"temperature": 1.8, "rel_threshold": 0.002}, {"temperature": 0},
     r"temperature must be > 0, got 0"),
    (TtstParams, {"temperature": 1.8, "rel_threshold": 0.002}, {"rel_threshold": 1.0},
     r"rel_threshold must be in \[0, 1\), got 1.0"),
    (CwsParams, {}, {"sigma_factor": -6.0}, r"sigma_factor must be > 0, got -6.0"),
    (CwsParams, {}, {"ratio": 0}, r"ratio must be > 0, got 0"),
    (CwsParams, {}, {"rot": "yes"}, r"\.rot: expected bool, got str 'yes'"),
    (CompatParams, {}, {"drop_first_row": 1}, r"\.drop_first_row: expected bool, got int 1"),
    (WindowParams, {}, {"target_fps": 0}, r"raw_fps and target_fps must be >= 1, got 30, 0"),
    (WindowParams, {}, {"release_horizon": 0}, r"release_horizon must be >= 1 s, got 0"),
    (WindowParams, {}, {"n_past": True}, r"\.n_past: expected int, got bool True"),
    (WindowParams, {}, {"n_past": 5.0}, r"\.n_past: expected int, got float 5.0"),
    (WindowParams, {}, {"label": 3}, r"\.label: expected str, got int 3"),
    (LabelsParams, {}, {"overlay_alpha": 1.5}, r"overlay_alpha must be in \[0, 1\], got 1.5"),
    (AugmentParams, {}, {"rotate_deg": 200}, r"rotate_deg must be in \[0, 180\], got 200"),
    (AugmentParams, {}, {"scale_min": 2.0}, r"need 0 < scale_min <= scale_max, got 2.0, 1.33"),
    (AugmentParams, {}, {"scale_min": 0}, r"need 0 < scale_min <= scale_max, got 0, 1.33"),
    (AugmentParams, {}, {"perspective": 0.3}, r"perspective must be in \[0, 0.25\), got 0.3"),
    (AugmentParams, {}, {"blur_prob": 1.5}, r"blur_prob must be in \[0, 1\], got 1.5"),
    (AugmentParams, {}, {"blur_sigma": 0.1}, r"blur_sigma must be >= 0.3, got 0.1"),
    (AugmentParams, {}, {"noise_std": -1}, r"noise_std must be >= 0, got -1"),
    (AugmentParams, {}, {"brightness": -0.1}, r"brightness must be >= 0, got -0.1"),
    (AugmentParams, {}, {"contrast": 1.0}, r"contrast must be in \[0, 1\), got 1.0"),
    (AugmentParams, {}, {"colour": -0.5}, r"colour must be in \[0, 1\), got -0.5"),
    (SegmentationParams, SEGMENTATION, {"epochs": 0}, r"epochs must be >= 1, got 0"),
    (SegmentationParams, SEGMENTATION, {"threads": 0}, r"threads must be >= 1, got 0"),
    (SegmentationParams, SEGMENTATION, {"crop": 0}, r"crop must be >= 1, got 0"),
    (SegmentationParams, SEGMENTATION, {"lr_drop_epoch": -1}, r"lr_drop_epoch must be >= 0, got -1"),
    (SegmentationParams, SEGMENTATION, {"lr": 0}, r"need lr > 0 and 0 < lr_drop_factor <= 1, got 0, 0.1"),
    (SegmentationParams, SEGMENTATION, {"lr_drop_factor": 2},
     r"need lr > 0 and 0 < lr_drop_factor <= 1, got 0.0001, 2"),
    (SegmentationParams, SEGMENTATION, {"augment": {"blur_sigma": 0.1}},
     r"\.augment: blur_sigma must be >= 0.3, got 0.1"),  # nested: the key path is named
    (SemanticParams, {}, {"resize": 0}, r"resize must be in \(0, 1\], got 0"),
    (EvalParams, {}, {"k_e": 0}, r"k_e, k_a, rounds, batch_size, chunk_size and threads must be positive"),
    (EvalParams, {}, {"chunk_size": 0}, r"k_e, k_a, rounds, batch_size, chunk_size and threads must be positive"),
    (EvalParams, {}, {"threads": 0}, r"k_e, k_a, rounds, batch_size, chunk_size and threads must be positive"),
    (HorizonParams, {}, {"epochs": {10: 0}}, r"epochs and rounds must be >= 1"),
    (HorizonParams, {}, {"rounds": 0}, r"epochs and rounds must be >= 1"),
    (TrainBaselineParams, {"seed": 0, "threads": 1}, {"threads": 0}, r"threads must be >= 1"),
    (EvaluateBaselineParams, EVALUATE_BASELINE, {"k": 0}, r"k, rounds and threads must be >= 1"),
    (EvaluateBaselineParams, EVALUATE_BASELINE, {"split": "dev"},
     r"split must be train, val or test, got 'dev'"),
    (ShortTermParams, {}, {"n_past": 1}, r"n_past must be at least 2 and n_future at least 1"),
    (ShortTermParams, {}, {"n_future": 0}, r"n_past must be at least 2 and n_future at least 1"),
    (ShortTermParams, {}, {"fps": 7}, r"fps must divide SDD's 30 FPS, got 7"),
    (ShortTermParams, {}, {"fps": 0}, r"fps must divide SDD's 30 FPS, got 0"),
    (ShortTermParams, {}, {"sdd_ratio_version": "C"}, r"sdd_ratio_version must be 'A' or 'B', got 'C'"),
    (ShortTermParams, {}, {"sdd_val_videos": ["gates_2"]},
     r"sdd_val_videos must be TrajNet train videos; not train: \['gates_2'\]"),
    (ShortTermParams, {}, {"ethucy_folds": ["kitti"]}, r"ethucy_folds must be distinct folds of .*got \['kitti'\]"),
    (ShortTermParams, {}, {"ethucy_folds": []}, r"ethucy_folds must be distinct folds of .*got \[\]"),
    (ShortTermParams, {}, {"ethucy_folds": ["eth", "eth"]}, r"ethucy_folds must be distinct folds"),
    (ShortTermParams, {}, {"ethucy_min_agents": 0}, r"ethucy_min_agents must be at least 1"),
    (ShortTermParams, {}, {"ethucy_map_downsample": 0.5}, r"ethucy_map_downsample must be at least 1"),
    (YnetScale, SCALE, {"kernel_size": 4}, r"need 0 < resize <= 1, sigma > 0 and an odd kernel_size"),
    (YnetScale, SCALE, {"resize": 0}, r"need 0 < resize <= 1, sigma > 0 and an odd kernel_size"),
    (YnetScale, SCALE, {"sigma": 0}, r"need 0 < resize <= 1, sigma > 0 and an odd kernel_size"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"epochs": {"ynet": {"sdd": 1, "ethucy": 1}}},
     r"epochs must give every model \['ynet', 'sgan', 'pecnet'\] positive epochs for each of "
     r"\['sdd', 'ethucy'\]"),
    (ShortTermModelsParams, SHORT_TERM_MODELS,
     {"epochs": {m: {"sdd": 0, "ethucy": 1} for m in ("ynet", "sgan", "pecnet")}},
     r"epochs must give every model"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"ynet_steps_per_epoch": -1},
     r"ynet_steps_per_epoch and val_windows must be >= 0 \(0 = all\)"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"val_windows": -1},
     r"ynet_steps_per_epoch and val_windows must be >= 0"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"ynet_datasets": ["kitti"]},
     r"ynet_datasets: unknown dataset\(s\) \['kitti'\]; known: \['sdd', 'eth'"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"k_sdd": []},
     r"k_sdd and k_ethucy must be non-empty lists of positive K"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"k_ethucy": [0]},
     r"k_sdd and k_ethucy must be non-empty lists of positive K"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"rounds": 0},
     r"need rounds >= 1, temperature > 0 and 0 <= rel_threshold < 1"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"temperature": 0}, r"need rounds >= 1, temperature > 0"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"rel_threshold": {"sdd": 0.01, "ethucy": 1.0}},
     r"need rounds >= 1, temperature > 0 and 0 <= rel_threshold < 1 for each of \['sdd', 'ethucy'\], "
     r"got rel_threshold \{'sdd': 0.01, 'ethucy': 1.0\}"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"rel_threshold": {"sdd": 0.01}},
     r"need rounds >= 1, temperature > 0 and 0 <= rel_threshold < 1 for each of \['sdd', 'ethucy'\]"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"eval_chunk_size": 0},
     r"eval_batch_size, eval_chunk_size and eval_threads must be positive"),
    (ShortTermModelsParams, SHORT_TERM_MODELS, {"ynet_ethucy": {**SCALE, "sigma": -1}},
     r"\.ynet_ethucy: need 0 < resize <= 1, sigma > 0"),  # nested: the key path is named
    (IndBenchmarkParams, IND_BENCHMARK, {"ynet_resize": 1.5}, r"ynet_resize must be in \(0, 1\], got 1.5"),
    (IndBenchmarkParams, IND_BENCHMARK, {"segmentation_downsample": 0},
     r"need segmentation_downsample >= 1 and freeze_encoder_epochs >= 0"),
    (IndBenchmarkParams, IND_BENCHMARK, {"freeze_encoder_epochs": -1},
     r"need segmentation_downsample >= 1 and freeze_encoder_epochs >= 0"),
])
def test_out_of_range_value_names_section_and_field(cls, base, bad, message):
    from_dict(cls, base, "sec")  # the base is valid: only `bad` breaks it
    prefix = "" if message.startswith("\\.") else ": "  # nested sections add `.<key>` to `sec`
    with pytest.raises(ParamsError, match=rf"^sec{prefix}{message}"):
        from_dict(cls, {**base, **bad}, "sec")


# ---------------------------------------------------------------------------------------------
# SDD annotations (stage tracks)


@pytest.mark.parametrize("bad_line", [
    '1 10 20 30 40 -5 0 0 0 "Pedestrian"',   # negative frame
    '-1 10 20 30 40 5 0 0 0 "Pedestrian"',   # negative track id
    '1 10 20 30 40 5 0 2 0 "Pedestrian"',    # occluded not 0/1
    '1 10 20 30 40 5 0 0 2 "Pedestrian"',    # generated not 0/1
])
def test_out_of_range_fields_name_file_and_line(tmp_path, bad_line):
    lines = annotation_lines(1, range(3), 0, 0, 1, 0)
    lines.insert(1, bad_line)
    path = write_annotations(tmp_path, "gates", 2, lines)
    with pytest.raises(AnnotationError, match=rf"^{esc(path)}:2: malformed annotation line "
                                              rf"{re.escape(repr(bad_line))}"):
        parse_annotations(path)


def test_annotation_folder_not_named_video_k_stops_the_stage(tmp_path, monkeypatch):
    write_annotations(tmp_path / "sdd", "gates", 2, annotation_lines(1, range(3), 0, 0, 1, 0))
    odd = tmp_path / "sdd" / "annotations" / "gates" / "clip3" / "annotations.txt"
    odd.parent.mkdir()
    odd.write_text("\n".join(annotation_lines(1, range(3), 0, 0, 1, 0)) + "\n")
    message = rf"{esc(odd)}: folder 'clip3' is not 'video<k>'"
    with pytest.raises(AnnotationError, match=rf"^{message}$"):
        build_tracks(tmp_path / "sdd")
    monkeypatch.chdir(tmp_path)
    write_manifest(tmp_path / "sdd", tmp_path / "sdd.sha256")
    (tmp_path / "params.yaml").write_text("compat: {drop_first_row: false}\ndata: {ind: {}}\n")
    with pytest.raises(SystemExit, match=rf"^tracks: {message}$"):
        tracks_stage.main(["--sdd", str(tmp_path / "sdd"), "--manifest", "sdd.sha256",
                           "--out", "out/sdd.parquet", "--sources", "out/sdd_sources.json"])
    assert nothing_written(tmp_path, "out")


# ---------------------------------------------------------------------------------------------
# Manifests and fetching (stage fetch@<source>)


def test_manifest_listing_a_file_twice_or_nothing(tmp_path):
    manifest = tmp_path / "m.sha256"
    manifest.write_text(f"{'a' * 64}  x.txt\n{'b' * 64}  ./x.txt\n")
    with pytest.raises(ChecksumError, match=rf"^{esc(manifest)}:2: 'x.txt' listed twice$"):
        read_manifest(manifest)
    manifest.write_text("\n  \n")
    with pytest.raises(ChecksumError, match=rf"^{esc(manifest)}: empty manifest$"):
        read_manifest(manifest)


def fetch_fixture(tmp_path: Path) -> tuple[Path, Path]:
    root = tmp_path / "mirror" / "sdd"
    write_annotations(root, "gates", 2, annotation_lines(1, range(3), 0, 0, 1, 0))
    manifest = tmp_path / "manifests" / "sdd.sha256"
    write_manifest(root, manifest)
    (tmp_path / "params.yaml").write_text(
        f"fetch: {{sources: [sdd], locations: ['{tmp_path / 'mirror'}'], timeout_s: 5}}\n")
    return root, manifest


def test_fetch_stage_stops_on_a_checksum_mismatch_and_writes_nothing(tmp_path, monkeypatch):
    root, manifest = fetch_fixture(tmp_path)
    (root / "annotations/gates/video2/annotations.txt").write_text("tampered\n")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit, match=rf"^fetch: source 'sdd': no location holds all 2 files of "
                                         rf"{esc(manifest)} with matching SHA-256(.|\n)*"
                                         r"checksum mismatch annotations/gates/video2/annotations.txt"):
        fetch_stage.main(["--source", "sdd", "--manifest", str(manifest), "--out", "data/raw/sdd"])
    assert nothing_written(tmp_path, "data/raw/sdd")


def test_fetch_stage_stops_on_a_malformed_manifest_and_writes_nothing(tmp_path, monkeypatch):
    _, manifest = fetch_fixture(tmp_path)
    manifest.write_text(manifest.read_text() + "not a manifest line\n")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ChecksumError, match=rf"^{esc(manifest)}:3: not a '<sha256>  <path>' line"):
        fetch_stage.main(["--source", "sdd", "--manifest", str(manifest), "--out", "data/raw/sdd"])
    assert nothing_written(tmp_path, "data")


# ---------------------------------------------------------------------------------------------
# Hand-labelled masks (stages labels, semantic_maps, segmentation)


def test_two_masks_for_one_video(tmp_path):
    _, release = make_fixture(tmp_path, {"gates_1": ("train_masks", good_mask())})
    second = write_png(release / "data/SDD_semantic_maps/test_masks/gates_1_mask.png", good_mask())
    with pytest.raises(MaskError, match=rf"^{esc(second)}: a second mask for gates_1 \(first: "
                                        r".*train_masks/gates_1_mask.png\)"):
        find_masks(release)


def test_labels_stage_stops_on_an_unreadable_reference_image_and_writes_nothing(tmp_path, monkeypatch):
    sdd, release = make_fixture(tmp_path, {"gates_1": ("train_masks", good_mask()),
                                           "gates_3": ("train_masks", good_mask())})
    image = sdd / "annotations/gates/video3/reference.jpg"
    image.write_bytes(b"\xff\xd8not a jpeg")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text("labels: {overlay_scale: 0.5, overlay_alpha: 0.5}\n")
    with pytest.raises(MaskError, match=rf"^{esc(image)}: cannot be read as an image$"):
        labels_stage.main(["--sdd", str(sdd), "--release", str(release), "--out", "out/labels",
                           "--figures", "out/figures"])
    assert nothing_written(tmp_path, "out/labels", "out/figures")


def test_missing_label_map_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match=rf"^{esc(tmp_path / 'maps' / 'gates_1.png')}: "
                                                r"missing or unreadable$"):
        read_label_map(tmp_path, "gates_1")


def write_labels_folder(labels: Path, splits: dict[str, str]) -> Path:
    """The labels stage's output: `index.json` and one label map per video (`maps/<video>.png`)."""
    videos = {}
    for name, split in splits.items():
        write_png(labels / "maps" / f"{name}.png", np.ones((4, 6), np.uint8))
        videos[name] = {"split": split, "height": 4, "width": 6, "pixels": {}}
    (labels / "index.json").write_text(json.dumps({"classes": list(CLASS_NAMES), "pad_class": 0,
                                                   "videos": videos}))
    return labels


def test_semantic_maps_stage_stops_on_a_missing_reference_image_and_writes_nothing(tmp_path, monkeypatch):
    labels = write_labels_folder(tmp_path / "labels", {"gates_1": "train"})
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text("semantic: {source: labels, resize: 0.25}\n"
                                          "runtime: {device: cpu, max_minutes: 0}\n")
    image = tmp_path / "sdd/annotations/gates/video1/reference.jpg"
    with pytest.raises(FileNotFoundError, match=rf"^{esc(image)}: missing or unreadable$"):
        semantic_maps_stage.main(["--sdd", str(tmp_path / "sdd"), "--labels", str(labels),
                                  "--model", "none.pt", "--out", "out/maps", "--metrics",
                                  "out/segmentation.json", "--figures", "out/figures"])
    assert nothing_written(tmp_path, "out/maps", "out/segmentation.json", "out/figures")


def test_segmentation_stage_without_train_videos_stops_before_writing(tmp_path, monkeypatch):
    labels = write_labels_folder(tmp_path / "labels", {"gates_2": "test"})
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(
        "profile: cpu\nruntime: {device: cpu, max_minutes: 0}\n"
        f"segmentation: {{cpu: {json.dumps(SEGMENTATION)}}}\n")
    with pytest.raises(SystemExit, match=rf"^segmentation: no train videos in {esc(labels)}/index.json$"):
        segmentation_stage.main(["--sdd", "sdd", "--labels", str(labels), "--checkpoint",
                                 "out/last.pt", "--model", "out/model.pt", "--log", "out/log.csv"])
    assert nothing_written(tmp_path, "out")


# ---------------------------------------------------------------------------------------------
# Homographies (stage short_term_windows)


@pytest.mark.parametrize("text, message", [
    ("1 0 0\n0 one 0\n0 0 1\n", "not a readable matrix of numbers"),
    ("1 0 0\n0 nan 0\n0 0 1\n", "holds non-finite values"),
    ("1 2 3\n2 4 6\n0 0 1\n", r"the matrix is singular \(cannot be inverted\)"),
])
def test_bad_homography_file_is_named(tmp_path, text, message):
    path = tmp_path / "eth_H.txt"
    path.write_text(text)
    with pytest.raises(HomographyError, match=rf"^{esc(path)}: {message}"):
        read_homography(path)


def test_missing_homography_file_is_named(tmp_path):
    with pytest.raises(HomographyError, match=rf"^{esc(tmp_path / 'eth_H.txt')}: not a readable matrix"):
        read_homography(tmp_path / "eth_H.txt")


# ---------------------------------------------------------------------------------------------
# Release windows (stages windows, horizon_windows, audit)


def test_release_window_spanning_two_tracks_is_named():
    good = release_rows("gates_2", 1, 0, 0, 0.0, 0.0, 1.0, 0.0, meta_id=0)
    two_tracks = good.assign(trackId=good["trackId"].where(good.index != 5, 2))
    with pytest.raises(ReleaseError, match=r"^test_longterm.pkl: a window spans several tracks or scenes$"):
        validate_release(two_tracks, "test_longterm.pkl", 35, STRIDE)
    two_scenes = good.assign(sceneId=good["sceneId"].where(good.index != 5, "gates_3"))
    with pytest.raises(ReleaseError, match=r"^test_longterm.pkl: a window spans several tracks"):
        validate_release(two_scenes, "test_longterm.pkl", 35, STRIDE)


@pytest.mark.parametrize("change, message", [
    (lambda t: t.assign(x=t["x"].where(t.index != 5)), r"1 row\(s\) with a non-finite x or y, in "
                                                       r"metaId\(s\) \[0\], e.g. row 5$"),
    (lambda t: t.assign(y=t["y"].where(t.index < 30, np.inf)), r"5 row\(s\) with a non-finite x or "
                                                               r"y, in metaId\(s\) \[0\], e.g. row 30$"),
    (lambda t: t.assign(frame=t["frame"] - STRIDE), r"1 row\(s\) with a negative \(or missing\) "
                                                    r"frame, in metaId\(s\) \[0\], e.g. row 0$"),
    (lambda t: t.assign(x=t["x"].astype(str)), r"column\(s\) \['x'\] not numeric$"),
])
def test_release_values_are_checked(change, message):
    """Frames still step by the stride, windows stay whole: only the value check can catch these."""
    good = release_rows("gates_2", 1, 0, 0, 0.0, 0.0, 1.0, 0.0, meta_id=0)
    validate_release(good, "test_longterm.pkl", 35, STRIDE)
    with pytest.raises(ReleaseError, match=rf"^test_longterm.pkl: {message}"):
        validate_release(change(good), "test_longterm.pkl", 35, STRIDE)


@pytest.fixture
def mirror(tmp_path):
    """The fixture mirror, its tracks parquet and a params.yaml; cwd is tmp_path."""
    write_mirror(tmp_path / "mirror", tmp_path / "manifests")
    build_tracks(tmp_path / "mirror" / "sdd").to_parquet(tmp_path / "tracks.parquet", index=False)
    (tmp_path / "params.yaml").write_text(WINDOWS_YAML + "compat: {drop_first_row: false}\n"
                                          "data: {ind: {}, sdd: {path: ''}}\n")
    return tmp_path


def run_windows_stage(root: Path) -> None:
    windows_stage.main(["--tracks", "tracks.parquet", "--release", str(root / "mirror/ynet-release"),
                        "--release-manifest", "manifests/ynet-release.sha256", "--out", "out/windows",
                        "--stats", "out/windows.json", "--scene-stats", "out/scenes.json"])


def test_windows_stage_stops_on_release_scenes_outside_their_split(mirror, monkeypatch):
    pickle = mirror / "mirror/ynet-release/data/SDD/train_longterm.pkl"
    pd.read_pickle(pickle).assign(sceneId="gates_2").to_pickle(pickle)  # a test video in train
    write_manifest(mirror / "mirror/ynet-release", mirror / "manifests/ynet-release.sha256")
    monkeypatch.chdir(mirror)
    with pytest.raises(SystemExit, match=rf"^windows: {esc(pickle)}: scenes outside its split: "
                                         r"\['gates_2'\]$"):
        run_windows_stage(mirror)
    assert nothing_written(mirror, "out")


def test_windows_stage_stops_on_a_non_finite_release_position(mirror, monkeypatch):
    pickle = mirror / "mirror/ynet-release/data/SDD/train_longterm.pkl"
    table = pd.read_pickle(pickle)
    table.assign(y=table["y"].where(table.index != 3)).to_pickle(pickle)
    write_manifest(mirror / "mirror/ynet-release", mirror / "manifests/ynet-release.sha256")
    monkeypatch.chdir(mirror)
    with pytest.raises(SystemExit, match=rf"^windows: {esc(pickle)}: 1 row\(s\) with a non-finite x "
                                         rf"or y, in metaId\(s\) \[{table.loc[3, 'metaId']}\], e.g. "
                                         r"row 3$"):
        run_windows_stage(mirror)
    assert nothing_written(mirror, "out")


def test_windows_stage_stops_on_a_tampered_release_pickle(mirror, monkeypatch):
    pickle = mirror / "mirror/ynet-release/data/SDD/test_longterm.pkl"
    pd.read_pickle(pickle).assign(x=0.0).to_pickle(pickle)  # manifest not updated
    monkeypatch.chdir(mirror)
    with pytest.raises(SystemExit, match=rf"^windows: {esc(pickle)}: SHA-256 [0-9a-f]{{64}} does "
                                         r"not match the manifest's [0-9a-f]{64}$"):
        run_windows_stage(mirror)
    assert nothing_written(mirror, "out")


def test_horizon_windows_stage_stops_on_a_short_release_window(tmp_path, monkeypatch):
    windows = tmp_path / "windows"
    windows.mkdir()
    frames = STRIDE * np.arange(35)
    table = pd.DataFrame({"window_id": np.r_[np.zeros(35), np.ones(34)].astype(int),
                          "scene_id": "coupa_3", "track_id": np.r_[np.ones(35), np.full(34, 2)],
                          "step": np.r_[np.arange(35), np.arange(34)],
                          "frame": np.r_[frames, frames[:34]], "x": 0.0, "y": 0.0,
                          "split": "train", "t_f": 30, "source": "release"})
    conform(table).to_parquet(windows / "release_tf30.parquet", index=False)
    pd.DataFrame({"scene_id": ["gates_2"]}).to_parquet(tmp_path / "tracks.parquet")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(WINDOWS_YAML)
    with pytest.raises(SystemExit, match=rf"^horizon_windows: {esc(windows)}/release_tf30.parquet: "
                                         r"1 window\(s\) not 35 steps, e.g. window 1 has 34$"):
        horizon_windows_stage.main(["--tracks", "tracks.parquet", "--windows", str(windows),
                                    "--out", "out/horizon_windows", "--stats", "out/stats.json"])
    assert nothing_written(tmp_path, "out")


def test_audit_stage_fails_on_windows_no_known_cause_explains(mirror, monkeypatch):
    """The release's gates_2 windows moved by a pixel: no compat setting reproduces them."""
    params = WindowParams(horizons=[30])
    raw, _ = raw_windows(build_tracks(mirror / "mirror/sdd"), params, set())[30]
    windows = mirror / "windows"
    windows.mkdir()
    raw.to_parquet(windows / "raw_tf30.parquet", index=False)
    moved = raw["scene_id"] == "gates_2"
    raw.assign(x=raw["x"].where(~moved, raw["x"] + 1), source="release").to_parquet(
        windows / "release_tf30.parquet", index=False)
    monkeypatch.chdir(mirror)
    with pytest.raises(SystemExit, match=r"^audit: unexplained mismatches between our windows and "
                                         r"the release:\n  gates_2 track 1 frames 100-1120\n  "
                                         r"gates_2 track 1 frames 1150-2170$"):
        audit_stage.main(["--sdd", "mirror/sdd", "--manifest", "manifests/sdd.sha256",
                          "--windows", str(windows), "--out", "out/audit.json"])
    assert not (mirror / "out" / "audit.json").exists()


# ---------------------------------------------------------------------------------------------
# Window tables (every stage that reads one)


def test_window_table_checks():
    table = pd.DataFrame({"window_id": [0, 0, 0, 1, 1], "scene_id": "gates_2", "track_id": 1,
                          "step": [0, 1, 2, 0, 1], "frame": 0, "x": 0.0, "y": 0.0, "split": "test",
                          "t_f": 1, "source": "raw"})
    with pytest.raises(ValueError, match=r"^window table lacks column\(s\) \['source', 'split'\]$"):
        conform(table.drop(columns=["split", "source"]))
    # (the lengths print as numpy scalars under numpy 2: `[np.int64(2), np.int64(3)]`)
    with pytest.raises(ValueError, match=r"^windows of several lengths in one table: \[(np\.int64\()?2\)?, (np\.int64\()?3\)?\]$"):
        to_arrays(table, n_past=1)
    with pytest.raises(ValueError, match=r"^windows of 3 steps cannot hold 3 observed steps$"):
        to_arrays(table.iloc[:3], n_past=3)


# ---------------------------------------------------------------------------------------------
# TrajNet SDD and SGAN ETH/UCY files (stage short_term_windows)


def trajnet_lines(track: int, first_frame: int, n_windows: int = 1) -> list[str]:
    return [f"{first_frame + 12 * k + 240 * w} {track} {0.1 * k:.2f} {0.2 * k:.2f}"
            for w in range(n_windows) for k in range(20)]


def trajnet_root(root: Path, files: dict[str, list[str]], ratios: str | None = None) -> Path:
    for name, lines in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text("\n".join(lines) + "\n")
    (root / "H_SDD.txt").write_text(ratios if ratios is not None else
                                    "File\tVersion\tRatio\ngates_0.jpg\tA\t0.04\ngates_2.jpg\tA\t0.04\n")
    return root


def test_empty_file_and_incomplete_trajnet_windows(tmp_path):
    empty = tmp_path / "empty.txt"
    empty.write_text("\n\n")
    with pytest.raises(ShortTermInputError, match=rf"^{esc(empty)}: no rows$"):
        read_rows(empty, "frame track x y")
    rows = np.array([[12 * k, 1, 0, 0] for k in range(5)], dtype=float)
    with pytest.raises(ShortTermInputError, match=rf"^{esc(tmp_path / 'f.txt')}: 5 rows are not whole "
                                                  r"windows of 4 \(TrajNet files hold fixed"):
        fixed_windows(rows, length=4, frame_step=12, path=tmp_path / "f.txt")


@pytest.mark.parametrize("table, message", [
    (None, r"cannot be read as a tab-separated table"),
    ("File\tVersion\ngates_0.jpg\tA\n", r"lacks column\(s\) \['Ratio'\]"),
    ("File\tVersion\tRatio\ngates_0.jpg\tA\t0.04\ngates_0.jpg\tA\t0.05\n",
     r"several version-A rows for \['gates_0'\]"),
    ("File\tVersion\tRatio\ngates_0.jpg\tA\tabc\n", r"no positive ratio for \['gates_0'\]"),
])
def test_bad_ratio_table_is_named(tmp_path, table, message):
    path = tmp_path / "H_SDD.txt"
    if table is not None:
        path.write_text(table)
    with pytest.raises(ShortTermInputError, match=rf"^{esc(path)}: {message}"):
        read_sdd_ratios(path, "A")


@pytest.mark.parametrize("files, ratios, val, message", [
    ({"test/gates_2.txt": trajnet_lines(1, 0)}, None, [], r"{root}/train: no TrajNet files"),
    ({"train/gates_2.txt": trajnet_lines(1, 0), "test/gates_2.txt": trajnet_lines(1, 0)}, None, [],
     r"{root}/train/gates_2.txt: gates_2 is not a TrajNet train video \(expected one of "),
    ({"train/gates_1.txt": trajnet_lines(1, 0), "test/gates_2.txt": trajnet_lines(1, 0)}, None, [],
     r"{root}/H_SDD.txt: no ratio for gates_1 \({root}/train/gates_1.txt\)"),
    ({"train/gates_0.txt": trajnet_lines(1, 0), "test/gates_2.txt": trajnet_lines(1, 0)}, None,
     ["gates_1"], r"{root}/train: no file for validation video\(s\) \['gates_1'\]"),
])
def test_trajnet_folder_problems_are_named(tmp_path, files, ratios, val, message):
    root = trajnet_root(tmp_path / "trajnet-sdd", files, ratios)
    params = ShortTermParams(sdd_val_videos=val)
    with pytest.raises(ShortTermInputError, match="^" + message.format(root=esc(root))):
        sdd_trajnet_windows(root, params)


def test_short_term_stage_stops_on_a_bad_trajnet_line_and_writes_nothing(tmp_path, monkeypatch):
    lines = trajnet_lines(1, 0)
    lines[2] = "24 1 0.2"
    root = trajnet_root(tmp_path / "trajnet-sdd", {"train/gates_0.txt": lines,
                                                   "test/gates_2.txt": trajnet_lines(1, 0)})
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text("short_term: {}\n")
    with pytest.raises(SystemExit, match=rf"^short_term_windows: {esc(root / 'train/gates_0.txt')}:3: "
                                         r"expected 'frame track x y' \(4 numbers, whole frame and "
                                         r"id\), got '24 1 0.2'$"):
        short_term_stage.main(["--trajnet-sdd", str(root), "--sgan", "sgan", "--ynet-release", "rel",
                               "--ethucy-scenes", "scenes", "--out", "out/short_term",
                               "--stats", "out/stats.json"])
    assert nothing_written(tmp_path, "out")


def test_sgan_pedestrian_twice_in_a_frame_and_unknown_file_names(tmp_path):
    rows = np.array([[0, 1, 0.0, 0.0], [0, 2, 1.0, 1.0], [10, 1, 0.1, 0.0], [10, 1, 0.2, 0.0]])
    with pytest.raises(ShortTermInputError, match=rf"^{esc(tmp_path / 'x.txt')}: pedestrian 1 appears "
                                                  r"twice in frame 10$"):
        sgan_window_rows(rows, length=2, min_agents=1, path=tmp_path / "x.txt")
    for name, split in (("kitti_train.txt", "train"), ("biwi_eth.txt", "val"), ("biwi_eth_val.txt", "test")):
        with pytest.raises(ShortTermInputError, match=rf"^{esc(tmp_path / name)}: not an SGAN {split} "
                                                      r"file `<recording>"):
            sgan_file_scene(tmp_path / name, split)


SGAN_ROWS = ["0\t1\t1.0\t2.0", "10\t1\t1.1\t2.0", "10\t2\t3.0\t3.0"]


@pytest.mark.parametrize("files, message", [
    ({"train/biwi_hotel_train.txt", "test/biwi_eth.txt"}, r"{fold}/val: no SGAN files$"),
    ({"train/biwi_hotel_train.txt", "val/biwi_hotel_val.txt", "test/biwi_hotel.txt"},
     r"{fold}/test: tests \['hotel'\], expected \['eth'\]$"),
    ({"train/biwi_eth_train.txt", "val/biwi_hotel_val.txt", "test/biwi_eth.txt"},
     r"{fold}: test scene\(s\) \['eth'\] also in train/val: not a leave-one-out fold$"),
])
def test_sgan_fold_problems_are_named(tmp_path, files, message):
    fold = tmp_path / "sgan" / "datasets" / "eth"
    for name in files:
        (fold / name).parent.mkdir(parents=True, exist_ok=True)
        (fold / name).write_text("\n".join(SGAN_ROWS) + "\n")
    homographies = {name: np.eye(3) for name in SCENES}
    with pytest.raises(ShortTermInputError, match="^" + message.format(fold=esc(fold))):
        ethucy_fold_windows(tmp_path / "sgan", tmp_path / "eth_ucy", "eth", ShortTermParams(),
                            homographies)


def test_oracle_and_scene_image_problems_are_named(tmp_path):
    oracle = tmp_path / "oracle.png"
    with pytest.raises(ShortTermInputError, match=rf"^{esc(oracle)}: missing or not an image$"):
        read_oracle(oracle)
    cv2.imwrite(str(oracle), np.ones((4, 5, 3), np.uint8))
    with pytest.raises(ShortTermInputError, match=rf"^{esc(oracle)}: expected a single-channel 8-bit "
                                                  r"mask, got \(4, 5, 3\) uint8$"):
        read_oracle(oracle)
    release = tmp_path / "release"
    (release / "data/eth_ucy/eth").mkdir(parents=True)
    cv2.imwrite(str(release / "data/eth_ucy/eth/oracle.png"), np.ones((4, 5), np.uint8))
    (tmp_path / "out").mkdir()
    image = tmp_path / "scenes" / "eth" / "reference.png"
    with pytest.raises(ShortTermInputError, match=rf"^{esc(image)}: missing or not an image$"):
        write_ethucy_maps(tmp_path / "out", release, tmp_path / "scenes", ["eth"], {"eth": np.eye(3)}, 1.0)


# ---------------------------------------------------------------------------------------------
# inD (stage ind_windows)


def break_csv(path: Path, change) -> None:
    change(pd.read_csv(path)).to_csv(path, index=False)


@pytest.mark.parametrize("how, message", [
    (lambda d: (d / "08_tracksMeta.csv").write_text(""), r"08_tracksMeta\.csv: cannot be read as a CSV file"),
    (lambda d: break_csv(d / "00_recordingMeta.csv", lambda t: pd.concat([t, t])),
     r"00_recordingMeta\.csv: expected one row, found 2$"),
    (lambda d: break_csv(d / "07_recordingMeta.csv", lambda t: t.assign(recordingId=5)),
     r"07_recordingMeta\.csv: recordingId 5(\.0)? differs from the file name$"),  # 5.0: read as float
    (lambda d: break_csv(d / "07_recordingMeta.csv", lambda t: t.assign(orthoPxToMeter=0.0)),
     r"07_recordingMeta\.csv: orthoPxToMeter must be a positive number, got 0.0$"),
    (lambda d: (d / "00_background.png").write_bytes(b"\x89PNG broken"),
     r"00_background\.png: cannot be read as an image$"),
    (lambda d: break_csv(d / "08_tracksMeta.csv", lambda t: pd.concat([t, t])),
     r"08_tracksMeta\.csv: trackId\(s\) listed twice, e.g. 0$"),
    (lambda d: break_csv(d / "08_tracks.csv", lambda t: t.assign(recordingId=9)),
     r"08_tracks\.csv: rows of another recording than 08$"),
    (lambda d: break_csv(d / "08_tracks.csv", lambda t: t.assign(xCenter=t["xCenter"].where(t.index != 3))),
     r"08_tracks\.csv: 1 row\(s\) with a non-finite xCenter or yCenter, on line\(s\) \[5\]$"),
    (lambda d: break_csv(d / "07_tracks.csv", lambda t: t.assign(yCenter=t["yCenter"].where(t.index > 1, np.inf))),
     r"07_tracks\.csv: 2 row\(s\) with a non-finite xCenter or yCenter, on line\(s\) \[2, 3\]$"),
    (lambda d: break_csv(d / "08_tracks.csv", lambda t: pd.concat([t, t.iloc[[4]]])),
     r"08_tracks\.csv: 2 row\(s\) repeat a \(trackId, frame\), e.g. trackId 0 frame 54 on lines "
     r"\[6, 1002\]$"),
])
def test_bad_ind_file_is_named(tmp_path, how, message):
    root = write_ind_copy(tmp_path / "copy")
    how(root / "data")
    with pytest.raises(IndError, match=rf"^{esc(root / 'data')}/{message}"):
        ind.build(IndParams(path=str(root), val_recordings=VAL), WindowParams())


@pytest.mark.parametrize("how, message", [
    (lambda m: None, r"data.ind.labels = {m}/nowhere: not a folder$"),
    (lambda m: write_png(m / "7_background_mask.png", np.ones((3, 3), np.uint8)),
     r"{m}/7_background_mask.png: not named XX_background_mask.png$"),
    (lambda m: write_png(m / "42_background_mask.png", np.ones((3, 3), np.uint8)),
     r"{m}/42_background_mask.png: no recording 42 in the inD copy$"),
    (lambda m: [p.unlink() for p in m.glob("*.png")], r"data.ind.labels = {m}: no XX_background_mask.png$"),
    (lambda m: [p.unlink() for p in m.glob("0[78]_*.png")],
     r"data.ind.labels = {m}: no mask of a train location \(fine-tuning"),
])
def test_bad_ind_labels_are_named(tmp_path, how, message):
    masks = tmp_path / "masks"
    root = write_ind_copy(tmp_path / "copy", labels=masks)
    how(masks)
    labels = masks / "nowhere" if "nowhere" in message else masks
    with pytest.raises(IndError, match="^" + message.format(m=esc(masks))):
        ind.build(IndParams(path=str(root), labels=str(labels), val_recordings=VAL), WindowParams())


def test_ind_windows_stage_stops_on_a_bad_recording_and_writes_nothing(tmp_path, monkeypatch):
    root = write_ind_copy(tmp_path / "copy")
    meta = root / "data" / "07_recordingMeta.csv"
    break_csv(meta, lambda t: t.assign(recordingId=5))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(
        f"data: {{ind: {{path: '{root}', labels: '', val_recordings: {VAL}}}}}\nwindows: {{}}\n")
    with pytest.raises(SystemExit, match=rf"^ind_windows: {esc(meta)}: recordingId 5(\.0)? differs from "
                                         r"the file name$"):
        ind_windows_stage.main(["--out", "out/ind", "--metrics", "out/ind.json"])
    assert nothing_written(tmp_path, "out")


# ---------------------------------------------------------------------------------------------
# Files one stage writes for another: scene maps (`index.json` + `maps.npz`), the ETH/UCY scene
# index, the labels index, the inD index and the inD maps kept for scoring


def sdd_maps(folder: Path) -> Path:
    """A scene-map folder as stage semantic_maps writes it: gates_1 and gates_2, (6, 8, 10) each."""
    maps = {name: np.full((len(CLASS_NAMES), 8, 10), 42, np.uint8) for name in ("gates_1", "gates_2")}
    return write_maps_folder(folder, maps, CLASS_NAMES)


def edit_json(path: Path, change) -> None:
    value = json.loads(path.read_text())
    change(value)
    path.write_text(json.dumps(value))


def rewrite_npz(path: Path, **arrays) -> None:
    with np.load(path) as stored:
        kept = {name: stored[name] for name in stored.files}
    np.savez_compressed(path, **{**kept, **arrays})


@pytest.mark.parametrize("how, message", [
    (lambda f: (f / "index.json").unlink(), r"{f}/index.json: missing \(re-run the stage that writes it\)$"),
    (lambda f: (f / "index.json").write_text("{"), r"{f}/index.json: not readable as JSON \("),
    (lambda f: (f / "index.json").write_text("[]"), r"{f}/index.json: expected a JSON object, got list$"),
    (lambda f: edit_json(f / "index.json", lambda i: i.pop("classes")), r"{f}/index.json: classes: missing$"),
    (lambda f: edit_json(f / "index.json", lambda i: i.update(classes=[])),
     r"{f}/index.json: classes: expected a non-empty list of names, got \[\]$"),
    (lambda f: edit_json(f / "index.json", lambda i: i.update(resize="0.25")),
     r"{f}/index.json: resize: expected float, got str '0.25'$"),
    (lambda f: edit_json(f / "index.json", lambda i: i["videos"].update(gates_1="x")),
     r"{f}/index.json: videos.gates_1: expected dict, got str$"),
    (lambda f: edit_json(f / "index.json", lambda i: i["videos"]["gates_1"].update(shape=[6, 8])),
     r"{f}/index.json: videos.gates_1.shape: expected \[C, H, W\] of positive integers with C = 6 "
     r"classes, got \[6, 8\]$"),
    (lambda f: np.savez_compressed(f / "maps.npz", gates_1=np.zeros((6, 8, 10), np.uint8)),
     r"{f}/maps.npz: no entry for \['gates_2'\], listed in {f}/index.json$"),
    (lambda f: edit_json(f / "index.json", lambda i: i["videos"].pop("gates_2")),
     r"{f}/maps.npz: \['gates_2'\] not listed in {f}/index.json$"),
    (lambda f: rewrite_npz(f / "maps.npz", gates_1=np.zeros((6, 8, 10), np.float32)),
     r"{f}/maps.npz: gates_1: dtype float32, expected uint8$"),
    (lambda f: edit_json(f / "index.json", lambda i: i["videos"]["gates_2"].update(shape=[6, 9, 10])),
     r"{f}/maps.npz: gates_2: shape \(6, 8, 10\), expected \(6, 9, 10\)$"),
    (lambda f: (f / "maps.npz").write_bytes(b"not a zip archive"), r"{f}/maps.npz: not a readable npz archive \("),
])
def test_bad_scene_maps_are_named(tmp_path, how, message):
    folder = sdd_maps(tmp_path / "semantic_maps")
    assert set(load_semantic_maps(folder)) == {"gates_1", "gates_2"}
    how(folder)
    with pytest.raises(IntermediateError, match="^" + message.format(f=esc(folder))):
        load_semantic_maps(folder)


def ethucy_scenes(folder: Path) -> Path:
    """The ETH/UCY scene folder stage short_term_windows writes, for scene eth."""
    maps = {"eth": np.zeros((len(MAP_CLASSES), 8, 10), np.uint8)}
    entry = {"image_hw": [480, 640], "homography": np.eye(3).tolist(), "swap": True}
    return write_maps_folder(folder, maps, MAP_CLASSES, "scenes", {"eth": entry})


def nan_homography(index: dict) -> None:
    index["scenes"]["eth"]["homography"][1][1] = float("nan")  # json writes it as NaN


@pytest.mark.parametrize("change, message", [
    (lambda i: i.pop("scenes"), r"scenes: missing$"),
    (lambda i: i["scenes"]["eth"].update(image_hw=[480]),
     r"scenes.eth.image_hw: expected \[height, width\] of positive integers, got \[480\]$"),
    (nan_homography, r"scenes.eth.homography: expected a 3 x 3 matrix of finite numbers, got "
                     r"\[\[1.0, 0.0, 0.0\], \[0.0, nan, 0.0\]"),
    (lambda i: i["scenes"]["eth"].update(homography=[[1, 0, 0], [0, 1, 0]]),
     r"scenes.eth.homography: expected a 3 x 3 matrix of finite numbers, got \[\[1, 0, 0\], \[0, 1, 0\]\]$"),
    (lambda i: i["scenes"]["eth"].update(swap="yes"), r"scenes.eth.swap: expected bool, got str 'yes'$"),
])
def test_bad_ethucy_scene_index_is_named(tmp_path, change, message):
    folder = ethucy_scenes(tmp_path / "ethucy_semantic")
    assert load_ethucy_scenes(folder)["eth"].swap is True
    edit_json(folder / "index.json", change)
    with pytest.raises(IntermediateError, match=rf"^{esc(folder / 'index.json')}: {message}"):
        load_ethucy_scenes(folder)


@pytest.mark.parametrize("how, message", [
    (lambda l: edit_json(l / "index.json", lambda i: i.update(pad_class="0")),
     r"{l}/index.json: pad_class: expected int, got str '0'$"),
    (lambda l: edit_json(l / "index.json", lambda i: i["videos"]["gates_1"].update(split="dev")),
     r"{l}/index.json: videos.gates_1.split: expected one of \['train', 'test', 'none'\], got 'dev'$"),
    (lambda l: edit_json(l / "index.json", lambda i: i["videos"]["gates_2"].update(height=0)),
     r"{l}/index.json: videos.gates_2.height: expected a positive size, got 0$"),
    (lambda l: (l / "maps" / "gates_1.png").unlink(), r"{l}/maps: no entry for \['gates_1'\], listed in {l}/index.json$"),
    (lambda l: write_png(l / "maps" / "gates_9.png", np.ones((4, 6), np.uint8)),
     r"{l}/maps: \['gates_9'\] not listed in {l}/index.json$"),
])
def test_bad_labels_index_is_named(tmp_path, how, message):
    labels = write_labels_folder(tmp_path / "labels", {"gates_1": "train", "gates_2": "test"})
    assert set(read_index(labels)["videos"]) == {"gates_1", "gates_2"}
    how(labels)
    with pytest.raises(IntermediateError, match="^" + message.format(l=esc(labels))):
        read_index(labels)


@pytest.fixture(scope="module")
def ind_out(tmp_path_factory) -> Path:
    """The output of stage ind_windows on the inD fixture (provided, with labels)."""
    tmp = tmp_path_factory.mktemp("ind_out")
    root = write_ind_copy(tmp / "copy", labels=tmp / "masks")
    params = IndParams(path=str(root), labels=str(tmp / "masks"), val_recordings=VAL)
    ind.write(ind.build(params, WindowParams()), tmp / "ind", tmp / "ind.json")
    return tmp / "ind"


@pytest.mark.parametrize("change, message", [
    (lambda i: i.update(provided="yes"), r"provided: expected bool, got str 'yes'$"),
    (lambda i: i.update(n_past=5.0), r"n_past: expected int, got float 5.0$"),
    (lambda i: i["tables"].update({"30": "tf31.parquet"}), r"tables.30: 'tf31.parquet' not a file in {d}$"),
    (lambda i: i["scenes"]["ind_loc1_rec07"].update(split="dev"),
     r"scenes.ind_loc1_rec07.split: expected one of \['train', 'val', 'test'\], got 'dev'$"),
    (lambda i: i["scenes"]["ind_loc1_rec07"].pop("location"), r"scenes.ind_loc1_rec07.location: missing$"),
    (lambda i: i["scenes"]["ind_loc1_rec08"].update(width=0),
     r"scenes.ind_loc1_rec08.height, width: expected positive sizes, got 300, 0$"),
    (lambda i: i["scenes"]["ind_loc4_rec00"].update(labels="labels/absent.png"),
     r"scenes.ind_loc4_rec00.labels: labels/absent.png not in {d}$"),
])
def test_bad_ind_index_is_named(ind_out, tmp_path, change, message):
    shutil.copytree(ind_out, tmp_path / "ind")
    folder = tmp_path / "ind"
    assert ind.read_index(folder)["provided"] is True
    edit_json(folder / "index.json", change)
    with pytest.raises(IntermediateError, match=rf"^{esc(folder / 'index.json')}: "
                                                + message.format(d=esc(folder))):
        ind.read_index(folder)


@pytest.mark.parametrize("arrays, message", [
    ({"ind_loc1_rec07": np.zeros((6, 4, 5), np.float32)},
     r"no entry for \['ind_loc1_rec08'\], listed in {d}/index.json$"),
    ({**{s: np.zeros((6, 4, 5), np.float32) for s in ("ind_loc1_rec07", "ind_loc1_rec08")},
      "ind_loc4_rec00": np.full((6, 4, 5), np.nan, np.float32)}, r"ind_loc4_rec00: 120 non-finite value\(s\)$"),
    ({s: np.zeros((3, 4, 5), np.float32) for s in ("ind_loc4_rec00", "ind_loc1_rec07", "ind_loc1_rec08")},
     r"ind_loc4_rec00: shape \(3, 4, 5\), expected \(6, any, any\)$"),
])
def test_bad_ind_maps_are_named(ind_out, tmp_path, arrays, message):
    index = ind.read_index(ind_out)
    path = tmp_path / long_term_benchmark.MAPS
    path.parent.mkdir(parents=True)
    good = {name: np.full((6, 4, 5), 1 / 6, np.float32) for name in index["scenes"]}
    np.savez_compressed(path, **good)
    assert set(long_term_benchmark.read_maps(path, index["scenes"], ind_out / "index.json")) == set(good)
    np.savez_compressed(path, **({"ind_loc4_rec00": good["ind_loc4_rec00"]} | arrays))
    with pytest.raises(IntermediateError, match=rf"^{esc(path)}: " + message.format(d=esc(ind_out))):
        long_term_benchmark.read_maps(path, index["scenes"], ind_out / "index.json")


def window_rows(steps: int) -> pd.DataFrame:
    """One window of `steps` steps per split (train, val, test) on gates_1."""
    return conform(pd.DataFrame([
        {"window_id": w, "scene_id": "gates_1", "track_id": w, "step": k, "frame": 30 * k,
         "x": float(k), "y": 1.0, "split": split, "t_f": steps - 5, "source": "release"}
        for w, split in enumerate(("train", "val", "test")) for k in range(steps)]))


@pytest.fixture
def bad_intermediates(tmp_path, monkeypatch):
    """In tmp_path (the cwd): the real params.yaml on the CPU, window tables, training records, and
    one broken intermediate of each kind."""
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params["runtime"]["device"] = "cpu"
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    window_rows(35).to_parquet(tmp_path / "tf30.parquet", index=False)
    window_rows(15).to_parquet(tmp_path / "tf10.parquet", index=False)
    (tmp_path / "trained.json").write_text(json.dumps({"trained": True, "train": {}}))
    rewrite_npz(sdd_maps(tmp_path / "semantic_maps") / "maps.npz", gates_9=np.zeros((6, 8, 10), np.uint8))
    edit_json(ethucy_scenes(tmp_path / "windows" / "ethucy_semantic") / "index.json", nan_homography)
    window_rows(20).to_parquet(tmp_path / "windows" / "ethucy_eth.parquet", index=False)  # no metres
    (tmp_path / "ind").mkdir()
    (tmp_path / "ind" / "index.json").write_text(json.dumps({"provided": "yes"}))
    edit_json(write_labels_folder(tmp_path / "labels", {"gates_1": "train"}) / "index.json",
              lambda i: i["videos"]["gates_1"].update(split="dev"))
    monkeypatch.chdir(tmp_path)
    ynet_slot_scoring.main(["--out", "slots"])  # for t_f = 10, which the cpu profile scores
    return tmp_path


SDD_MAPS = r"semantic_maps/maps.npz: \['gates_9'\] not listed in semantic_maps/index.json$"
ETH_INDEX = r"windows/ethucy_semantic/index.json: scenes.eth.homography: expected a 3 x 3 matrix"
ETH_METRES = r"windows/ethucy_eth.parquet: eth: the window table has no metre columns \['x_m', 'y_m'\]$"
IND_INDEX = r"ind/index.json: provided: expected bool, got str 'yes'$"
LABELS_INDEX = r"labels/index.json: videos.gates_1.split: expected one of \['train', 'test', 'none'\]"


STAGE_CASES = [
    (train_ynet, ["--windows", "tf30.parquet", "--semantic-maps", "semantic_maps", "--sdd", "sdd",
                  "--checkpoint-dir", "out/ck", "--model", "out/model.pt", "--history", "out/h.csv",
                  "--metrics", "out/m.json"], SDD_MAPS),
    (evaluate_ynet, ["--windows", "tf30.parquet", "--model", "model.pt", "--semantic-maps", "semantic_maps",
                     "--sdd", "sdd", "--metrics", "out/m.json", "--qualitative", "out/q.npz",
                     "--predictions", "out/p.parquet"], SDD_MAPS),
    (train_ynet_horizon, ["--horizon", "10", "--table", "tf10.parquet", "--semantic-maps", "semantic_maps",
                          "--sdd", "sdd", "--main-model", "model.pt", "--checkpoint-dir", "out/ck",
                          "--metrics", "out/m.json"], SDD_MAPS),
    (evaluate_ynet_horizon, ["--horizon", "10", "--table", "tf10.parquet", "--semantic-maps",
                             "semantic_maps", "--sdd", "sdd", "--checkpoint-dir", "ck", "--scoring",
                             "slots/tf10.json", "--train-metrics", "trained.json", "--metrics",
                             "out/m.json", "--predictions", "out/p.parquet"], SDD_MAPS),
    (train_short_term_ynet, ["--dataset", "eth", "--windows", "windows", "--maps", "windows/ethucy_semantic",
                             "--checkpoint-dir", "out/ck", "--metrics", "out/m.json"], ETH_INDEX),
    (evaluate_short_term_ynet, ["--dataset", "eth", "--windows", "windows", "--maps",
                                "windows/ethucy_semantic", "--ethucy-scenes", "ethucy-scenes",
                                "--checkpoint-dir", "ck", "--train-metrics", "trained.json",
                                "--metrics", "out/m.json", "--predictions", "out/p.parquet",
                                "--qualitative", "out/q.npz"], ETH_INDEX),
    (train_short_term_baseline, ["--dataset", "eth", "--model", "sgan", "--windows", "windows",
                                 "--checkpoint-dir", "out/ck", "--metrics", "out/m.json"], ETH_METRES),
    (evaluate_short_term_baseline, ["--dataset", "eth", "--model", "sgan", "--windows", "windows",
                                    "--checkpoint-dir", "ck", "--train-metrics", "trained.json",
                                    "--metrics", "out/m.json", "--predictions", "out/p.parquet"],
     ETH_METRES),
    (train_ind, ["--ind", "ind", "--segmentation-model", "unet.pt", "--checkpoint-dir", "out/ck",
                 "--metrics", "out/m.json"], IND_INDEX),
    (evaluate_ind, ["--ind", "ind", "--checkpoint-dir", "ck", "--train-metrics", "trained.json",
                    "--metrics", "out/m.json", "--predictions", "out/predictions"], IND_INDEX),
    (segmentation_stage, ["--sdd", "sdd", "--labels", "labels", "--checkpoint", "out/last.pt", "--model",
                          "out/model.pt", "--log", "out/log.csv"], LABELS_INDEX),
    (semantic_maps_stage, ["--sdd", "sdd", "--labels", "labels", "--model", "none.pt", "--out", "out/maps",
                           "--metrics", "out/m.json", "--figures", "out/figures"], LABELS_INDEX),
]


@pytest.mark.parametrize("stage, argv, message", STAGE_CASES,
                         ids=[stage.__name__.rsplit(".", 1)[-1] for stage, _, _ in STAGE_CASES])
def test_a_stage_reading_a_bad_intermediate_stops_naming_it_and_writes_nothing(bad_intermediates, stage,
                                                                               argv, message):
    name = stage.__name__.rsplit(".", 1)[-1]
    with pytest.raises(SystemExit, match=rf"^{name}: {message}"):
        stage.main(argv)
    assert nothing_written(bad_intermediates, "out")
