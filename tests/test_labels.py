"""Stage `labels`: mask validation, the class table, the split, and the stage on a tiny fixture."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.data.labels import CLASS_COLOURS_BGR, LABEL_VALUES, TEST_VIDEOS, TRAIN_VIDEOS, MaskError, find_masks, import_labels, legend, pair_videos, read_index, read_label_map, split_of, validate_mask
from pipeline.config.labels import LabelsParams
from pipeline.config.loading import ParamsError, load_section, read_params
from ynet.segmentation import CLASS_NAMES, N_OUTPUTS, N_SCENE_CLASSES, PAD_CLASS

H, W = 12, 16


def write_png(path: Path, array: np.ndarray) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), array)
    return path


def good_mask() -> np.ndarray:
    mask = np.ones((H, W), np.uint8)
    mask[:, 4:8], mask[:, 8:11], mask[:6, 11:], mask[6:, 11:] = 2, 3, 4, 5
    return mask  # (H, W) values 1-5


def make_fixture(root: Path, masks: dict[str, tuple[str, np.ndarray]]) -> tuple[Path, Path]:
    """A mirror-shaped SDD root (reference images) and release root (masks) under `root`."""
    sdd, release = root / "sdd", root / "ynet-release"
    rng = np.random.default_rng(0)
    for name, (folder, mask) in masks.items():
        scene, video = name.rsplit("_", 1)
        image = rng.integers(0, 255, (H, W, 3), dtype=np.uint8)
        write_png(sdd / "annotations" / scene / f"video{video}" / "reference.jpg", image)
        write_png(release / "data/SDD_semantic_maps" / folder / f"{name}_mask.png", mask)
    return sdd, release


def test_class_table_maps_mask_values_to_paper_classes():
    assert CLASS_NAMES == ("padding", "pavement", "road", "structure", "terrain", "tree")
    assert PAD_CLASS == 0 and N_SCENE_CLASSES == 5 and N_OUTPUTS == 6
    assert LABEL_VALUES == (1, 2, 3, 4, 5)
    assert sorted(CLASS_NAMES[v] for v in LABEL_VALUES) == sorted(
        ["pavement", "terrain", "structure", "tree", "road"])  # the paper's N_c = 5 classes
    assert len({tuple(c) for c in CLASS_COLOURS_BGR}) == len(CLASS_NAMES)


def test_trajnet_split_sizes_and_disjoint():
    assert len(TRAIN_VIDEOS) == 30 and len(TEST_VIDEOS) == 17
    assert not set(TRAIN_VIDEOS) & set(TEST_VIDEOS)
    assert split_of("gates_2") == "test" and split_of("gates_1") == "train"
    assert split_of("bookstore_5") == "none"


def test_validate_accepts_good_mask():
    mask = good_mask()
    assert validate_mask(mask, (H, W), Path("x_mask.png")) is mask


@pytest.mark.parametrize(
    ("mask", "message"),
    [
        (None, "cannot be read"),
        (np.ones((H, W, 3), np.uint8), "single-channel"),
        (np.ones((H, W), np.uint16), "8-bit"),
        (np.ones((H + 1, W), np.uint8), "differs from its image"),
        (np.where(np.eye(H, W, dtype=bool), 0, 1).astype(np.uint8), r"unknown class value\(s\) \[0\]"),
        (np.full((H, W), 7, np.uint8), r"unknown class value\(s\) \[7\]"),
    ],
)
def test_validate_rejects_bad_mask_naming_the_file(mask, message):
    with pytest.raises(MaskError, match=message) as info:
        validate_mask(mask, (H, W), Path("masks/gates_1_mask.png"))
    assert "gates_1_mask.png" in str(info.value)


def test_stage_writes_maps_index_and_overlays(tmp_path):
    sdd, release = make_fixture(tmp_path, {
        "gates_1": ("train_masks", good_mask()),
        "bookstore_5": ("train_masks", good_mask()[::-1].copy()),
        "gates_2": ("test_masks", good_mask()),
    })
    out, figures = tmp_path / "labels", tmp_path / "figures"
    import_labels(sdd, release, out, figures, LabelsParams(overlay_scale=1.0))
    index = read_index(out)
    assert index["classes"] == list(CLASS_NAMES)
    assert {n: v["split"] for n, v in index["videos"].items()} == {
        "bookstore_5": "none", "gates_1": "train", "gates_2": "test"}
    np.testing.assert_array_equal(read_label_map(out, "gates_1"), good_mask())
    assert index["videos"]["gates_1"]["pixels"]["road"] == int((good_mask() == 2).sum())
    assert sorted(p.name for p in figures.iterdir()) == ["bookstore_5.png", "gates_1.png", "gates_2.png"]
    assert not list(tmp_path.glob(".*"))  # no temporary folders left


def test_stage_stops_on_bad_mask_and_writes_nothing(tmp_path):
    bad = good_mask()
    bad[0, 0] = 9
    sdd, release = make_fixture(tmp_path, {"gates_1": ("train_masks", good_mask()),
                                           "gates_3": ("train_masks", bad)})
    with pytest.raises(MaskError, match=r"gates_3_mask\.png: unknown class value\(s\) \[9\] in 1 pixels"):
        import_labels(sdd, release, tmp_path / "labels", tmp_path / "figures", LabelsParams())
    assert not (tmp_path / "labels").exists() and not (tmp_path / "figures").exists()


def test_mask_in_wrong_split_folder_or_badly_named_is_an_error(tmp_path):
    _, release = make_fixture(tmp_path, {"gates_2": ("train_masks", good_mask())})
    with pytest.raises(MaskError, match="gates_2 is a test video but lies in train_masks"):
        find_masks(release)
    _, release = make_fixture(tmp_path / "b", {"gates_1": ("train_masks", good_mask())})
    write_png(release / "data/SDD_semantic_maps/train_masks/gates1.png", good_mask())
    with pytest.raises(MaskError, match="not named"):
        find_masks(release)


def test_every_image_needs_a_mask_and_vice_versa():
    with pytest.raises(MaskError, match=r"no mask for video\(s\) \['quad_0'\]"):
        pair_videos({"quad_0": Path("a"), "quad_1": Path("b")}, {"quad_1": Path("m")})
    with pytest.raises(MaskError, match="without a reference image"):
        pair_videos({}, {"quad_1": Path("m")})


def test_legend_wraps_to_width():
    assert legend(2000).shape[0] < legend(120).shape[0]
    assert legend(300).shape[1] == 300


def test_params_unknown_key_fails():
    with pytest.raises(ParamsError, match="unknown key"):
        load_section(LabelsParams, "labels", {"labels": {"overlay_scale": 0.5, "alpha": 1}})
    with pytest.raises(ParamsError, match="overlay_scale"):
        load_section(LabelsParams, "labels", {"labels": {"overlay_scale": 2.0, "overlay_alpha": 0.5}})


def test_labels_section_of_params_yaml_is_valid():
    params = read_params(Path(__file__).parents[1] / "params.yaml")
    load_section(LabelsParams, "labels", params)
