"""The hand-labelled semantic masks of all SDD videos: validation, label maps, overlays (stage `labels`).

The masks are the Y-net authors' release (`SDD_semantic_maps/{train,test}_masks/<scene>_<k>_mask.png`,
values 1-5, one per video, the size of the video's `reference.jpg`). A mask that does not fit its
image or holds an unknown value stops the stage with a message naming the file, because every later
number (segmentation training, the oracle ablation, Y-net's inputs) silently depends on it.

Outputs: one label map per video (`maps/<scene>_<k>.png`, values = `ynet.segmentation.CLASS_NAMES`
indices), `index.json` (split, size and class pixel counts per video), colour overlays for the report.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from pipeline.io import IntermediateError, atomic_dir, index_value, read_json_index, same_names
from pipeline.splits import TEST_VIDEOS, TRAIN_VIDEOS
from ynet.classes import CLASS_NAMES, N_SCENE_CLASSES, PAD_CLASS

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.labels import LabelsParams

LABEL_VALUES = tuple(range(1, N_SCENE_CLASSES + 1))  # values a hand mask may hold
MASK_DIR = Path("data/SDD_semantic_maps")  # inside the ynet-release folder
MASK_NAME = re.compile(r"^(?P<scene>[A-Za-z]+)_(?P<video>\d+)_mask\.png$")

# Overlay colours (BGR), chosen to read at a glance: trees green, terrain tan, structure red.
CLASS_COLOURS_BGR = np.array(
    [
        (0, 0, 0),  # padding
        (0, 200, 255),  # pavement: amber
        (200, 80, 160),  # road: purple
        (50, 50, 230),  # structure: red
        (90, 170, 230),  # terrain: tan
        (40, 160, 40),  # tree: green
    ],
    np.uint8,
)


class MaskError(ValueError):
    """A hand-labelled mask that cannot be used as it is."""


def split_of(name: str) -> str:
    """'train', 'test' (TrajNet, `pipeline.splits`) or 'none' (the 13 videos outside the split).

    The segmentation net trains on all TrajNet train videos; Y-net's validation videos are among them.
    """
    return "train" if name in TRAIN_VIDEOS else "test" if name in TEST_VIDEOS else "none"


def reference_image_path(sdd_root: Path, name: str) -> Path:
    """`<sdd>/annotations/<scene>/video<k>/reference.jpg` for video `<scene>_<k>`."""
    scene, video = name.rsplit("_", 1)
    return Path(sdd_root) / "annotations" / scene / f"video{video}" / "reference.jpg"


def sdd_scene_image(sdd_root: Path, scene_id: str) -> np.ndarray:
    """(H, W, 3) uint8 BGR: the `reference.jpg` of SDD video `scene_id` (`<scene>_<k>`)."""
    path = reference_image_path(sdd_root, scene_id)
    image = cv2.imread(str(path))
    if image is None:
        raise FileNotFoundError(f"{path}: cannot read the scene image")
    return image


def image_sizes(sdd_root: Path, scene_ids) -> dict[str, tuple[int, int]]:
    """Original (height, width) of each video's reference image."""
    sizes = {}
    for scene_id in scene_ids:
        path = reference_image_path(sdd_root, scene_id)
        image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise FileNotFoundError(f"{path}: cannot read the scene image")
        sizes[scene_id] = image.shape[:2]
    return sizes


def find_images(sdd_root: Path) -> dict[str, Path]:
    """Every video's reference image, keyed `<scene>_<k>`."""
    found = {}
    for path in sorted((Path(sdd_root) / "annotations").glob("*/video*/reference.jpg")):
        scene, video = path.parent.parent.name, path.parent.name.removeprefix("video")
        found[f"{scene}_{video}"] = path
    return found


def find_masks(release_root: Path) -> dict[str, Path]:
    """Every mask file, keyed `<scene>_<k>`; a badly named file or a test/train mix-up is an error."""
    found: dict[str, Path] = {}
    for folder in ("train_masks", "test_masks"):
        for path in sorted((Path(release_root) / MASK_DIR / folder).glob("*")):
            match = MASK_NAME.match(path.name)
            if match is None:
                raise MaskError(f"{path}: not named <scene>_<video>_mask.png")
            name = f"{match['scene']}_{match['video']}"
            if name in found:
                raise MaskError(f"{path}: a second mask for {name} (first: {found[name]})")
            if (folder == "test_masks") != (split_of(name) == "test"):
                raise MaskError(f"{path}: {name} is a {split_of(name)} video but lies in {folder}/")
            found[name] = path
    return found


def validate_mask(mask: np.ndarray | None, image_hw: tuple[int, int], path: Path) -> np.ndarray:
    """The mask (H, W) uint8 if it is one class value in 1-5 per image pixel; else MaskError."""
    if mask is None:
        raise MaskError(f"{path}: cannot be read as an image")
    if mask.ndim != 2:
        raise MaskError(f"{path}: expected a single-channel mask, got shape {mask.shape}")
    if mask.dtype != np.uint8:
        raise MaskError(f"{path}: expected 8-bit values, got {mask.dtype}")
    if mask.shape != tuple(image_hw):
        raise MaskError(f"{path}: size {mask.shape} (H, W) differs from its image {tuple(image_hw)}")
    unknown = sorted(set(np.unique(mask).tolist()) - set(LABEL_VALUES))
    if unknown:
        count = int(np.isin(mask, unknown).sum())
        raise MaskError(
            f"{path}: unknown class value(s) {unknown} in {count} pixels; allowed {list(LABEL_VALUES)}"
        )
    return mask


def pair_videos(images: dict[str, Path], masks: dict[str, Path]) -> list[str]:
    """Video names that have both an image and a mask; any video with only one of them is an error."""
    no_mask = sorted(set(images) - set(masks))
    no_image = sorted(set(masks) - set(images))
    if no_mask:
        raise MaskError(f"no mask for video(s) {no_mask}")
    if no_image:
        raise MaskError(f"mask(s) without a reference image: {[str(masks[n]) for n in no_image]}")
    return sorted(images)


def colourise(labels: np.ndarray) -> np.ndarray:
    """Class indices (H, W) -> BGR colours (H, W, 3)."""
    return CLASS_COLOURS_BGR[labels]


def overlay(image: np.ndarray, labels: np.ndarray, alpha: float) -> np.ndarray:
    """Class colours blended over the BGR image (H, W, 3), with class borders drawn in white."""
    blended = cv2.addWeighted(image, 1 - alpha, colourise(labels), alpha, 0)
    edges = cv2.morphologyEx(labels, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
    blended[edges] = 255
    return blended


def legend(width: int, line: int = 22) -> np.ndarray:
    """A white strip (h, width, 3) naming the colour of every class, wrapped onto more lines if narrow."""
    font, size = cv2.FONT_HERSHEY_SIMPLEX, 0.4
    entries = [(k, name, 26 + cv2.getTextSize(name, font, size, 1)[0][0]) for k, name in
               enumerate(CLASS_NAMES)]
    rows: list[list[tuple[int, str, int]]] = [[]]
    for entry in entries:
        if rows[-1] and sum(e[2] for e in rows[-1]) + entry[2] + 8 > width:
            rows.append([])
        rows[-1].append(entry)
    strip = np.full((line * len(rows) + 4, width, 3), 255, np.uint8)
    for r, row in enumerate(rows):
        x, y = 4, r * line + 4
        for k, name, entry_width in row:
            cv2.rectangle(strip, (x, y + 3), (x + 16, y + line - 5), CLASS_COLOURS_BGR[k].tolist(), -1)
            cv2.rectangle(strip, (x, y + 3), (x + 16, y + line - 5), (0, 0, 0), 1)
            cv2.putText(strip, name, (x + 20, y + line - 7), font, size, (0, 0, 0), 1, cv2.LINE_AA)
            x += entry_width
    return strip


def class_counts(labels: np.ndarray) -> dict[str, int]:
    """Pixels per class name."""
    counts = np.bincount(labels.ravel(), minlength=len(CLASS_NAMES))
    return {name: int(counts[k]) for k, name in enumerate(CLASS_NAMES)}


SPLITS = ("train", "test", "none")  # the values `split_of` gives


def read_index(labels_dir: Path) -> dict:
    """The `index.json` the stage writes: classes and, per video, split, size and pixel counts.

    Checked, with one label map in `maps/` per listed video and none other: segmentation training
    picks its videos by the listed split. An IntermediateError names the file and the key."""
    path = Path(labels_dir) / "index.json"
    index = read_json_index(path)
    index_value(index, "classes", list, path)
    index_value(index, "pad_class", int, path)
    videos = index_value(index, "videos", dict, path)
    for name in videos:
        entry = index_value(videos, name, dict, path, "videos.")
        where = f"videos.{name}."
        index_value(entry, "split", str, path, where, choices=SPLITS)
        for key in ("height", "width"):
            if index_value(entry, key, int, path, where) <= 0:
                raise IntermediateError(f"{path}: {where}{key}: expected a positive size, "
                                        f"got {entry[key]}")
    maps = Path(labels_dir) / "maps"
    same_names(videos, [p.stem for p in maps.glob("*.png")], maps, path)
    return index


def read_label_map(labels_dir: Path, name: str) -> np.ndarray:
    """Label map (H, W) uint8 of a video, at the original image resolution."""
    path = Path(labels_dir) / "maps" / f"{name}.png"
    labels = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if labels is None:
        raise FileNotFoundError(f"{path}: missing or unreadable")
    return labels


def import_labels(sdd_root: Path, release_root: Path, out: Path, figures: Path,
                  params: LabelsParams) -> dict:
    """Validate every mask against its image and write label maps, index and overlays."""
    images, masks = find_images(sdd_root), find_masks(release_root)
    names = pair_videos(images, masks)
    index = {"classes": list(CLASS_NAMES), "pad_class": PAD_CLASS, "videos": {}}
    with atomic_dir(out) as out_tmp, atomic_dir(figures) as fig_tmp:
        (out_tmp / "maps").mkdir()
        for name in names:
            image = cv2.imread(str(images[name]), cv2.IMREAD_COLOR)
            if image is None:
                raise MaskError(f"{images[name]}: cannot be read as an image")
            labels = validate_mask(
                cv2.imread(str(masks[name]), cv2.IMREAD_UNCHANGED), image.shape[:2], masks[name]
            )
            cv2.imwrite(str(out_tmp / "maps" / f"{name}.png"), labels)
            index["videos"][name] = {
                "split": split_of(name),
                "height": int(labels.shape[0]),
                "width": int(labels.shape[1]),
                "pixels": class_counts(labels),
            }
            small = cv2.resize(image, None, fx=params.overlay_scale, fy=params.overlay_scale,
                               interpolation=cv2.INTER_AREA)
            small_labels = cv2.resize(labels, (small.shape[1], small.shape[0]),
                                      interpolation=cv2.INTER_NEAREST)
            figure = overlay(small, small_labels, params.overlay_alpha)
            figure = np.concatenate([figure, legend(figure.shape[1])], axis=0)
            cv2.imwrite(str(fig_tmp / f"{name}.png"), figure)
        (out_tmp / "index.json").write_text(json.dumps(index, indent=1) + "\n")
    return index
