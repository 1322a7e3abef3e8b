"""The per-class probability maps Y-net consumes: their stored form, and how they score.

Every video's (C=6, H, W) map is at Y-net's resolution (`resize` of the original image), channel
order `ynet.classes.CLASS_NAMES` (channel 0 = padding), stored uint8-quantised (p * 255) in
one compressed `maps.npz` keyed `<scene>_<k>`; `load_semantic_maps` returns float probabilities.
Stage `semantic_maps` writes them (`pipeline.runners.semantic_maps`: the U-Net's inference, or the
hand labels one-hot); the ETH/UCY scenes' maps (`pipeline.benchmarks.ethucy`) share the format.
`iou_summary` and `comparison_figure` score and draw a map against the hand labels.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from pipeline.data.labels import colourise, legend
from pipeline.io import (IntermediateError, check_array, index_value, positive_ints,
                         read_json_index, read_npz)
from ynet.classes import CLASS_NAMES, N_OUTPUTS, PAD_CLASS

QUANT = 255  # stored value = round(p * QUANT)


def resize_probabilities(probs: np.ndarray, hw: tuple[int, int]) -> np.ndarray:
    """Bilinear resize of every channel of (C, h, w) to (C, H, W), renormalised to sum to 1."""
    if probs.shape[1:] == tuple(hw):
        return probs
    resized = np.stack([cv2.resize(p, (hw[1], hw[0]), interpolation=cv2.INTER_LINEAR) for p in probs])
    return resized / resized.sum(axis=0, keepdims=True)


def one_hot_map(labels: np.ndarray, n_classes: int = N_OUTPUTS) -> np.ndarray:
    """Class indices (H, W) -> one-hot float32 (C, H, W)."""
    return (labels[None] == np.arange(n_classes)[:, None, None]).astype(np.float32)


def quantise(probs: np.ndarray) -> np.ndarray:
    """Probabilities (C, H, W) in [0, 1] -> uint8 (C, H, W); error at most 1/510 per value."""
    return np.rint(np.clip(probs, 0, 1) * QUANT).astype(np.uint8)


def dequantise(stored: np.ndarray) -> np.ndarray:
    """uint8 (C, H, W) as written by `quantise` -> float32 probabilities, renormalised per pixel."""
    probs = stored.astype(np.float32) / QUANT
    return probs / np.maximum(probs.sum(axis=0, keepdims=True), 1e-6)


def maps_index_shapes(index: dict, path: Path) -> dict[str, tuple[int, int, int]]:
    """Name -> (C, H, W) of every map the `index.json` at `path` lists, its schema checked: both
    writers' (SDD videos: `pipeline.runners.semantic_maps`, ETH/UCY scenes:
    `pipeline.benchmarks.ethucy`) share these keys."""
    classes = index_value(index, "classes", list, path)
    if not classes or not all(isinstance(c, str) for c in classes):
        raise IntermediateError(f"{path}: classes: expected a non-empty list of names, got {classes}")
    index_value(index, "resize", float, path)
    index_value(index, "encoding", str, path)
    key = "videos" if "videos" in index else "scenes"
    shapes = {}
    for name in index_value(index, key, dict, path):
        entry = index_value(index[key], name, dict, path, f"{key}.")
        shape = index_value(entry, "shape", list, path, f"{key}.{name}.")
        if not (positive_ints(shape, 3) and shape[0] == len(classes)):
            raise IntermediateError(f"{path}: {key}.{name}.shape: expected [C, H, W] of positive "
                                    f"integers with C = {len(classes)} classes, got {shape}")
        shapes[name] = tuple(shape)
    return shapes


def load_semantic_maps(path: Path) -> dict[str, np.ndarray]:
    """Every video's float32 probability map (C=6, H, W), keyed `<scene>_<k>` (Y-net's input).

    `path`: the stage's output folder or its `maps.npz`, with `index.json` beside it. The index
    and the archive are checked against each other (same names, each map uint8 of the listed
    shape): an IntermediateError names the file and what is wrong.
    """
    path = Path(path)
    archive = path / "maps.npz" if path.is_dir() else path
    index_path = archive.parent / "index.json"
    shapes = maps_index_shapes(read_json_index(index_path), index_path)
    stored = read_npz(archive, shapes, index_path)
    return {name: dequantise(check_array(array, np.uint8, shapes[name], archive, name))
            for name, array in stored.items()}


def predicted_labels(probs: np.ndarray) -> np.ndarray:
    """The most likely scene class (1..5) per pixel of (C, H, W): padding is never an answer inside
    an image, so the padding channel is left out of the argmax."""
    scene = np.delete(probs, PAD_CLASS, axis=0)  # (C - 1, H, W)
    classes = np.delete(np.arange(probs.shape[0]), PAD_CLASS)
    return classes[scene.argmax(axis=0)].astype(np.uint8)


def iou_from_confusion(confusion: np.ndarray) -> np.ndarray:
    """Per-class IoU = TP / (TP + FP + FN) from a (C, C) confusion matrix; NaN for a class absent
    from both target and prediction."""
    confusion = confusion.astype(np.float64)
    tp = np.diag(confusion)
    union = confusion.sum(0) + confusion.sum(1) - tp
    return np.where(union > 0, tp / np.maximum(union, 1), np.nan)


def iou_summary(confusion: np.ndarray) -> dict:
    """Per-class IoU, mIoU and pixel accuracy from a confusion matrix over the scene classes."""
    iou = iou_from_confusion(confusion)
    scene = [k for k in range(len(CLASS_NAMES)) if k != PAD_CLASS]
    per_class = {CLASS_NAMES[k]: None if np.isnan(iou[k]) else round(float(iou[k]), 4) for k in scene}
    valid = [v for v in per_class.values() if v is not None]
    total = confusion.sum()
    return {
        "miou": round(float(np.mean(valid)), 4) if valid else None,
        "pixel_accuracy": round(float(np.trace(confusion) / total), 4) if total else None,
        "iou": per_class,
    }


def comparison_figure(image: np.ndarray, labels: np.ndarray, predicted: np.ndarray,
                      title: str) -> np.ndarray:
    """image | hand labels | prediction side by side (BGR), with a title and a class legend."""
    gap = np.full((image.shape[0], 6, 3), 255, np.uint8)
    row = np.concatenate([image, gap, colourise(labels), gap, colourise(predicted)], axis=1)
    header = np.full((26, row.shape[1], 3), 255, np.uint8)
    cv2.putText(header, title, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    return np.concatenate([header, row, legend(row.shape[1])], axis=0)
