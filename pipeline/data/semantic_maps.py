"""The per-class probability map of every video, in the form Y-net consumes (stage `semantic_maps`).

`semantic.source: predicted` runs the trained U-Net over each whole scene (train and test videos);
`labels` turns the hand labels into one-hot maps instead (the oracle ablation). Either way every
video gets a (C=6, H, W) map at Y-net's resolution (`resize` of the original image), channel order
`ynet.segmentation.CLASS_NAMES` (channel 0 = padding). Maps are stored uint8-quantised (p * 255) in
one compressed `maps.npz` keyed `<scene>_<k>`; `load_semantic_maps` returns float probabilities.

Also scores the predicted maps on the test videos against the hand labels (per-class IoU, mIoU),
and draws image | labels | prediction for every test video.

The U-Net runs on `runtime.device` (`pipeline.device`): on the CPU in float32 as always, on CUDA in
bf16 autocast with the softmax in float32.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import cv2
import numpy as np
import torch

from pipeline.config import SemanticParams
from pipeline.device import autocast, module_device, to_device
from pipeline.data.labels import (
    colourise,
    legend,
    read_index,
    read_label_map,
    reference_image_path,
)
from pipeline.io import (IntermediateError, atomic_dir, check_array, index_value, positive_ints,
                         read_json_index, read_npz, write_json)
from pipeline.runners.segmentation import load_model, pad_to_multiple, scaled_size
from ynet.segmentation import (
    CLASS_NAMES,
    N_OUTPUTS,
    PAD_CLASS,
    UNet,
    confusion_matrix,
    iou_from_confusion,
)

QUANT = 255  # stored value = round(p * QUANT)


def predict_probabilities(model: UNet, image: np.ndarray, pad_multiple: int) -> np.ndarray:
    """Softmax (C, h, w) float32 of the U-Net over a whole BGR uint8 image (h, w, 3), computed on
    the model's device (bf16 autocast on CUDA; float32 on the CPU)."""
    device = module_device(model)
    h, w = image.shape[:2]
    padded = pad_to_multiple(image, pad_multiple)  # (Hp, Wp, 3)
    x = torch.from_numpy(padded).permute(2, 0, 1)[None]  # (1, 3, Hp, Wp) uint8, channels-last view
    x = to_device(x, device).float() / 255  # uint8 travels: 4x fewer bytes, same values
    with torch.no_grad():
        with autocast(device):
            logits = model(x)  # (1, C, Hp, Wp)
        probs = logits.float().softmax(dim=1)[0, :, :h, :w]  # (C, h, w)
    return probs.cpu().numpy().astype(np.float32)


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
    writers' (SDD videos here, ETH/UCY scenes in `pipeline.data.short_term`) share these keys."""
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


def iou_summary(confusion: np.ndarray) -> dict:
    """Per-class IoU, mIoU and pixel accuracy from a confusion matrix over the scene classes."""
    iou = iou_from_confusion(torch.from_numpy(confusion)).numpy()
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


def build_maps(
    sdd_root: Path, labels_dir: Path, model_path: Path, out: Path, metrics_path: Path,
    figures: Path, params: SemanticParams, device: torch.device | str = "cpu",
) -> dict:
    """Write maps.npz + index.json, the metrics JSON and the test figures; returns the metrics.

    The U-Net (source 'predicted') runs on `device`."""
    index = read_index(labels_dir)
    model, meta = (load_model(model_path, device) if params.source == "predicted"
                   else (None, None))
    maps: dict[str, np.ndarray] = {}
    confusion = np.zeros((N_OUTPUTS, N_OUTPUTS), np.int64)
    per_video: dict[str, float | None] = {}
    with atomic_dir(out) as out_tmp, atomic_dir(figures) as fig_tmp:
        for name, info in sorted(index["videos"].items()):
            image = cv2.imread(str(reference_image_path(sdd_root, name)), cv2.IMREAD_COLOR)
            if image is None:
                raise FileNotFoundError(f"{reference_image_path(sdd_root, name)}: missing or unreadable")
            hw = scaled_size(*image.shape[:2], params.resize)
            labels = cv2.resize(read_label_map(labels_dir, name), (hw[1], hw[0]),
                                interpolation=cv2.INTER_NEAREST)  # (H, W)
            if params.source == "labels":
                probs = one_hot_map(labels)
            else:
                small = scaled_size(*image.shape[:2], 1 / meta["downsample"])
                net_input = cv2.resize(image, (small[1], small[0]), interpolation=cv2.INTER_AREA)
                probs = resize_probabilities(
                    predict_probabilities(model, net_input, meta["pad_multiple"]), hw)
            maps[name] = quantise(probs)  # (C, H, W)
            if info["split"] != "test":
                continue
            predicted = predicted_labels(probs)
            video_confusion = confusion_matrix(torch.from_numpy(predicted), torch.from_numpy(labels),
                                               N_OUTPUTS).numpy()
            confusion += video_confusion
            per_video[name] = iou_summary(video_confusion)["miou"]
            small_image = cv2.resize(image, (hw[1], hw[0]), interpolation=cv2.INTER_AREA)
            title = f"{name} (test)   image | hand labels | {params.source}   mIoU {per_video[name]:.3f}"
            cv2.imwrite(str(fig_tmp / f"{name}.png"),
                        comparison_figure(small_image, labels, predicted, title))
        buffer = io.BytesIO()
        np.savez_compressed(buffer, **maps)
        (out_tmp / "maps.npz").write_bytes(buffer.getvalue())
        (out_tmp / "index.json").write_text(json.dumps({
            "source": params.source,
            "resize": params.resize,
            "classes": list(CLASS_NAMES),
            "encoding": f"uint8, probability = value / {QUANT}; see load_semantic_maps",
            "videos": {n: {"split": index["videos"][n]["split"], "shape": list(m.shape)}
                       for n, m in maps.items()},
        }, indent=1) + "\n")
        metrics = {
            "source": params.source,
            "test_videos": len(per_video),
            **iou_summary(confusion),
            "per_video_miou": per_video,
            "evaluated_at": f"resize {params.resize} of the original image, labels nearest-resized",
        }
        if meta is not None:
            metrics["training"] = {
                "model": f"U-Net from scratch (no pretrained weights), plain PyTorch, {meta['unet']}",
                "pretrained": meta["pretrained"],
                "profile": meta["profile"],
                "train_videos": len(meta["train_videos"]),
                "epochs": meta["epochs"],
                "crops": meta["crops"],
                "train_seconds": meta["train_seconds"],
                "final_dice_loss": round(meta["final_loss"], 4),
            }
        write_json(metrics, metrics_path, indent=1)
    return metrics
