"""The per-class probability map of every video, in the form Y-net consumes (stage `semantic_maps`).

`semantic.source: predicted` runs the trained U-Net (`pipeline.runners.segmentation`) over each
whole scene (train and test videos); `labels` turns the hand labels into one-hot maps instead (the
oracle ablation). Either way every video gets a map in the format of `pipeline.data.semantic_maps`.

Also scores the predicted maps on the test videos against the hand labels (per-class IoU, mIoU),
and draws image | labels | prediction for every test video.

`background_maps` does the same for another long-term benchmark's backgrounds (inD, stage
`train_ind`), the U-Net fine-tuned first on the benchmark's labelled train backgrounds if any.

The U-Net runs on `runtime.device` (`pipeline.device`): on the CPU in float32 as always, on CUDA in
bf16 autocast with the softmax in float32.
"""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
import torch

from pipeline.data.labels import read_index, read_label_map, reference_image_path
from pipeline.data.semantic_maps import (QUANT, comparison_figure, iou_summary, one_hot_map,
                                         predicted_labels, quantise, resize_probabilities)
from pipeline.device import CPU, autocast, module_device, to_device
from pipeline.io import atomic_dir, write_json
from pipeline.runners.segmentation import (downsample_pair, export_model, finetune, load_model,
                                           pad_to_multiple, scaled_size)
from ynet.segmentation import CLASS_NAMES, N_OUTPUTS, PAD_CLASS, UNet, confusion_matrix

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.benchmarks.long_term import LongTermData
    from pipeline.config.segmentation import SegmentationParams
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


def predict_map(model: UNet, image: np.ndarray, downsample: int, pad_multiple: int,
                hw: tuple[int, int]) -> np.ndarray:
    """Class probabilities (C, H, W) float32 at size `hw` of a whole BGR image (h, w, 3): the U-Net
    sees it downsampled by `downsample` (area averaging), as it was trained."""
    small = scaled_size(*image.shape[:2], 1 / downsample)
    net_input = cv2.resize(image, (small[1], small[0]), interpolation=cv2.INTER_AREA)
    return resize_probabilities(predict_probabilities(model, net_input, pad_multiple), hw)


def read_image(path: Path, flags: int = cv2.IMREAD_COLOR) -> np.ndarray:
    """An image (BGR), or with IMREAD_UNCHANGED a label mask; an error naming `path` if absent."""
    image = cv2.imread(str(path), flags)
    if image is None:
        raise FileNotFoundError(f"{path}: missing or unreadable")
    return image


def background_maps(data: LongTermData, segmentation_model: Path, params: SegmentationParams,
                    freeze_epochs: int, resize: float, profile: str, work_dir: Path,
                    device: torch.device = CPU) -> tuple[dict[str, np.ndarray], dict]:
    """scene -> (C, H, W) class probabilities at `resize` of its background, and what was done.

    With labelled train backgrounds (`data.finetune_scenes`) the SDD-trained U-Net is fine-tuned on
    them first (`finetune`, `params`' schedule at its `downsample`; exported to
    `work_dir/model.pt`), else it segments unchanged. The maps of `data.scored_scenes` are scored
    against their labels. The U-Net fine-tunes and segments on `device`; its fine-tuning takes
    minutes and keeps no checkpoint of its own, so a stop request is only honoured after it."""
    model, meta = load_model(segmentation_model, device)
    downsample = params.downsample
    facts: dict[str, Any] = {"segmentation_downsample": downsample,
                             "sdd_model": {"unet": meta["unet"], "epochs": meta["epochs"]}}
    backgrounds = data.backgrounds
    if data.finetune_scenes:
        params = replace(params, base_channels=meta["unet"]["base_channels"],
                         depth=meta["unet"]["depth"], pad_multiple=meta["pad_multiple"])
        names = data.finetune_scenes
        pairs = []
        for name in names:
            image, labels = downsample_pair(read_image(backgrounds[name].image),
                                            read_image(backgrounds[name].labels,
                                                       cv2.IMREAD_UNCHANGED), downsample)
            pairs.append((pad_to_multiple(image, params.pad_multiple),
                          pad_to_multiple(labels, params.pad_multiple, PAD_CLASS)))
        log = finetune(model, pairs, params, freeze_epochs)
        export_model(work_dir / "model.pt", model, params, profile, names, log)
        facts |= {"source": "finetuned", "train_scenes": names, "epochs": len(log),
                  "freeze_encoder_epochs": min(freeze_epochs, len(log)),
                  "final_dice_loss": log[-1]["loss"] if log else None,
                  "train_seconds": round(sum(row["seconds"] for row in log), 1)}
    else:
        facts |= {"source": "sdd_unet", "note": data.unlabelled_note}

    maps = {}
    scored = data.scored_scenes
    confusion = np.zeros((N_OUTPUTS, N_OUTPUTS), np.int64)
    for name, background in sorted(backgrounds.items()):
        image = read_image(background.image)
        hw = scaled_size(*image.shape[:2], resize)
        maps[name] = predict_map(model, image, downsample, meta["pad_multiple"], hw)  # (C, H, W)
        if name in scored:  # a labelled test background: how good are the maps Y-net is given?
            labels = cv2.resize(read_image(background.labels, cv2.IMREAD_UNCHANGED),
                                (hw[1], hw[0]), interpolation=cv2.INTER_NEAREST)  # (H, W)
            confusion += confusion_matrix(torch.from_numpy(predicted_labels(maps[name])),
                                          torch.from_numpy(labels), N_OUTPUTS).numpy()
    if scored:
        facts["test"] = {"scenes": scored, **iou_summary(confusion)}
    return maps, facts


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
                probs = predict_map(model, image, meta["downsample"], meta["pad_multiple"], hw)
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
