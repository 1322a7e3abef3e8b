"""The per-class probability map of every video, in the form Y-net consumes (stage `semantic_maps`).

`semantic.source: predicted` runs the trained U-Net (`pipeline.runners.segmentation`) over each
whole scene (train and test videos); `labels` turns the hand labels into one-hot maps instead (the
oracle ablation). Either way every video gets a map in the format of `pipeline.data.semantic_maps`.

Also scores the predicted maps on the test videos against the hand labels (per-class IoU, mIoU),
and draws image | labels | prediction for every test video.

The U-Net runs on `runtime.device` (`pipeline.device`): on the CPU in float32 as always, on CUDA in
bf16 autocast with the softmax in float32.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
import torch

from pipeline.data.labels import read_index, read_label_map, reference_image_path
from pipeline.data.semantic_maps import (QUANT, comparison_figure, iou_summary, one_hot_map,
                                         predicted_labels, quantise, resize_probabilities)
from pipeline.device import autocast, module_device, to_device
from pipeline.io import atomic_dir, write_json
from pipeline.runners.segmentation import load_model, pad_to_multiple, scaled_size
from ynet.segmentation import CLASS_NAMES, N_OUTPUTS, UNet, confusion_matrix

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.semantic import SemanticParams


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
