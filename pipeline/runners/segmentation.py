"""Training the scene U-Net on the TRAIN videos' hand labels, from scratch (stage `segmentation`).

Follows the paper's recipe (images downsampled by 4, padded to a multiple of 32, random 256x256
crops, spatial + photometric augmentation, Dice loss, Adam 1e-4 dropped 10x late in training) with
two documented departures: no ImageNet-pretrained ResNet101 encoder exists here, so the U-Net is
trained from scratch, and the default `cpu` profile is a smaller net and a shorter schedule that
trains in minutes on two CPU cores. The `paper` profile holds the paper's schedule.

Seeded; one checkpoint per epoch (`pipeline.checkpoints`, state_dicts only) whose identity is a
fingerprint of the settings and the training data, so an interrupted run resumes where it stopped
and a changed run starts afresh.
On SIGTERM / SIGINT or when `runtime.max_minutes` runs out (`pipeline.preemption`) the loop also
saves a mid-epoch checkpoint between two optimiser steps and stops (exit 143 / 130 / 75); resuming
from it ends with the very same weights as an uninterrupted run. Runs on `runtime.device`
(`pipeline.device`): on the CPU the numbers are those of the CPU-only code; on CUDA in bf16
autocast and channels-last.

Beside `train`: `finetune`, a trained U-Net fine-tuned on another benchmark's labelled backgrounds
(inD: `pipeline.runners.semantic_maps.background_maps`) with the same crops, loss and schedule, its
encoder frozen at first; and the parts `bench/bench_segmentation.py` times: `load_training_scenes`,
`unet_config`, `epoch_batches` (an epoch's augmented crops, drawn as `train` draws them) and
`train_step` (one optimiser step, its loss read at once; `train` reads the losses one step late).
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
import torch
from tqdm import tqdm

from pipeline.data.augment import random_crop
from pipeline.data.labels import read_label_map, reference_image_path
from pipeline import checkpoints
from pipeline.device import (autocast, conv_layout, module_device,
                             restore_rng_states, rng_states, synchronize, to_device)
from pipeline.io import save_torch, write_bytes
from pipeline.preemption import NEVER, Preemption
from ynet.segmentation import CLASS_NAMES, PAD_CLASS, UNet, UNetConfig, dice_loss

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.segmentation import SegmentationParams

MODEL_FORMAT = 1
"""The exported weights (`export_model`)."""


def scaled_size(height: int, width: int, scale: float) -> tuple[int, int]:
    """(H, W) after resizing by `scale`, rounded like `cv2.resize(fx=scale, fy=scale)`."""
    return max(1, round(height * scale)), max(1, round(width * scale))


def downsample_pair(image: np.ndarray, labels: np.ndarray, factor: int) -> tuple[np.ndarray, np.ndarray]:
    """Image (H, W, 3) by area averaging, labels (H, W) by nearest neighbour, both by `factor`."""
    h, w = scaled_size(*labels.shape, 1 / factor)
    image = cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA)
    labels = cv2.resize(labels, (w, h), interpolation=cv2.INTER_NEAREST)
    return image, labels


def pad_to_multiple(array: np.ndarray, multiple: int, value: int = 0) -> np.ndarray:
    """Pad bottom and right of (H, W, ...) with `value` so H and W are multiples of `multiple`."""
    h, w = array.shape[:2]
    pad_h, pad_w = -h % multiple, -w % multiple
    return cv2.copyMakeBorder(array, 0, pad_h, 0, pad_w, cv2.BORDER_CONSTANT, value=value)


def load_training_scenes(
    sdd_root: Path, labels_dir: Path, names: list[str], factor: int, multiple: int
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Downsampled, padded (image (Hp, Wp, 3) uint8 BGR, labels (Hp, Wp) uint8) per video."""
    scenes = []
    for name in names:
        image = cv2.imread(str(reference_image_path(sdd_root, name)), cv2.IMREAD_COLOR)
        if image is None:
            raise FileNotFoundError(f"{reference_image_path(sdd_root, name)}: missing or unreadable")
        image, labels = downsample_pair(image, read_label_map(labels_dir, name), factor)
        scenes.append((pad_to_multiple(image, multiple), pad_to_multiple(labels, multiple, PAD_CLASS)))
    return scenes


def fingerprint(params: SegmentationParams, names: list[str],
                scenes: list[tuple[np.ndarray, np.ndarray]]) -> str:
    """Hash of everything a checkpoint depends on: resume only into the very same run."""
    digest = hashlib.sha256()
    settings = dataclasses.asdict(params)
    digest.update(json.dumps({"settings": settings, "videos": names}, sort_keys=True).encode())
    for image, labels in scenes:
        digest.update(image.tobytes())
        digest.update(labels.tobytes())
    return digest.hexdigest()[:16]


def epoch_order(params: SegmentationParams, n_scenes: int, epoch: int
                ) -> tuple[np.random.Generator, np.ndarray]:
    """The epoch's random stream, already past the scene order it drew first, and that order
    (scene index per crop). Depends only on (seed, epoch), so a resumed run draws the same crops."""
    rng = np.random.default_rng([params.seed, epoch])
    order = rng.permutation(np.repeat(np.arange(n_scenes), params.crops_per_image))
    return rng, order


def make_batch(
    scenes: list[tuple[np.ndarray, np.ndarray]], params: SegmentationParams,
    rng: np.random.Generator, indices: np.ndarray,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Augmented crops of `scenes[indices]`, drawn from `rng`: images (B, 3, crop, crop) float in
    [0, 1] (a channels-last view of the crops), labels (B, crop, crop) int64; CPU tensors."""
    crops = [random_crop(*scenes[i], rng, params.augment, params.crop, PAD_CLASS) for i in indices]
    images = torch.from_numpy(np.stack([c[0] for c in crops])).permute(0, 3, 1, 2)  # (B, 3, h, w)
    labels = torch.from_numpy(np.stack([c[1] for c in crops])).long()  # (B, h, w)
    return images, labels


def epoch_batches(
    scenes: list[tuple[np.ndarray, np.ndarray]], params: SegmentationParams, epoch: int
) -> Iterator[tuple[torch.Tensor, torch.Tensor]]:
    """The epoch's augmented crops in batches: images (B, 3, crop, crop) float, labels (B, crop, crop).

    The random stream depends only on (seed, epoch), so a resumed run draws the same crops.
    """
    rng, order = epoch_order(params, len(scenes), epoch)
    for start in range(0, len(order), params.batch_size):
        yield make_batch(scenes, params, rng, order[start:start + params.batch_size])


def learning_rate(params: SegmentationParams, epoch: int) -> float:
    """The paper's step schedule: `lr`, then `lr * lr_drop_factor` from `lr_drop_epoch` on."""
    return params.lr * (params.lr_drop_factor if epoch >= params.lr_drop_epoch else 1.0)


def unet_config(params: SegmentationParams) -> UNetConfig:
    return UNetConfig(base_channels=params.base_channels, depth=params.depth)


def step_loss(model: UNet, optimiser: torch.optim.Optimizer, images: torch.Tensor,
              labels: torch.Tensor, bf16: bool) -> torch.Tensor:
    """One Adam step on the Dice loss, on the model's device; returns the detached loss (0-d, on that
    device, so the caller decides when to wait for it).

    `bf16`: the profile's CPU bf16 autocast + channels-last; on CUDA both are always on.
    """
    device = module_device(model)
    images, labels = to_device(images, device), to_device(labels, device)
    if bf16 or device.type == "cuda":
        images = images.contiguous(memory_format=torch.channels_last)
    with autocast(device, cpu_bf16=bf16):
        logits = model(images)  # (B, C, h, w)
    loss = dice_loss(logits.float(), labels)
    optimiser.zero_grad(set_to_none=True)
    loss.backward()
    optimiser.step()
    return loss.detach()


def train_step(model: UNet, optimiser: torch.optim.Optimizer, images: torch.Tensor,
               labels: torch.Tensor, bf16: bool) -> float:
    """One Adam step on the Dice loss (on the model's device; inputs may be CPU tensors); returns
    the loss."""
    return step_loss(model, optimiser, images, labels, bf16).item()


def train(
    scenes: list[tuple[np.ndarray, np.ndarray]],
    params: SegmentationParams,
    checkpoint: Path,
    run_id: str,
    stop_after: int | None = None,
    progress: bool = True,
    device: torch.device | str = "cpu",
    preemption: Preemption = NEVER,
) -> tuple[UNet, list[dict]]:
    """Train (or resume) the U-Net on `device`; checkpoint after every epoch. Returns the model and
    epoch log.

    `stop_after` ends the call after that many epochs, as an interruption would (tests, benchmarks).
    `preemption` is polled between optimiser steps (from the second step of this call on, so every
    call advances however small the time budget): once it asks to stop, a mid-epoch checkpoint is
    saved (see `checkpoint_payload`) and its `StopRequested` raised; the next call resumes at that
    very step and ends with the same weights as an uninterrupted run on the same device.
    """
    device = torch.device(device)
    torch.manual_seed(params.seed)
    model = UNet(unet_config(params))  # initialised on the CPU: the same start on every device
    if params.bf16:
        model = model.to(memory_format=torch.channels_last)
    model = conv_layout(model, device)
    optimiser = torch.optim.Adam(model.parameters(), lr=params.lr)
    log: list[dict] = []
    position: dict | None = None  # where in an epoch a mid-epoch checkpoint stopped
    resumed = checkpoints.resume(checkpoint, {"run": run_id}, params.epochs,
                                 "segmentation" if progress else "")
    if resumed is not None:
        model.load_state_dict(resumed.state["model"])
        optimiser.load_state_dict(resumed.state["optimiser"])
        log = list(resumed.state["log"])
        restore_rng_states(resumed.state["rng"], device)
        position = resumed.position
        if progress and position is not None:
            print(f"segmentation: resuming at epoch {position['epoch'] + 1}, step "
                  f"{position['step']} from {checkpoint}")
        elif progress and log:
            print(f"segmentation: resuming after epoch {len(log)} from {checkpoint}")
    first = len(log)
    last = params.epochs if stop_after is None else min(params.epochs, first + stop_after)
    n_steps = -(-len(scenes) * params.crops_per_image // params.batch_size)
    bar = tqdm(total=(params.epochs - first) * n_steps - (position["step"] if position else 0),
               disable=not progress, unit="step", desc="segmentation")
    model.train()
    steps_taken = 0  # in this call
    try:
        for epoch in range(first, last):
            start = time.perf_counter()
            for group in optimiser.param_groups:
                group["lr"] = learning_rate(params, epoch)
            rng, order = epoch_order(params, len(scenes), epoch)
            first_step, losses, n_crops, seconds_before = 0, [], 0, 0.0
            if position is not None:
                if position["epoch"] != epoch:
                    raise ValueError(f"{checkpoint}: mid-epoch position {position} after "
                                     f"{len(log)} logged epochs")
                rng.bit_generator.state = position["batch_rng"]
                first_step, losses = position["step"], list(position["losses"])
                n_crops, seconds_before = position["crops"], position["seconds"]
                position = None
            pending = None  # the last step's loss, read after the next batch is made (GPU overlap)
            for step in range(first_step, n_steps):
                if steps_taken and preemption.stop_reason() is not None:
                    if pending is not None:
                        losses.append(pending.item())
                    save_checkpoint(checkpoint, run_id, model, optimiser, log, device, position={
                        "epoch": epoch, "step": step, "batch_rng": rng.bit_generator.state,
                        "losses": losses, "crops": n_crops,
                        "seconds": seconds_before + time.perf_counter() - start})
                    raise preemption.request(f"epoch {epoch + 1}, step {step}")
                batch = order[step * params.batch_size:(step + 1) * params.batch_size]
                images, labels = make_batch(scenes, params, rng, batch)
                loss = step_loss(model, optimiser, images, labels, params.bf16)
                n_crops += len(images)
                steps_taken += 1
                if pending is not None:
                    losses.append(pending.item())
                pending = loss
                bar.update()
                bar.set_postfix(epoch=epoch + 1, loss=f"{losses[-1]:.3f}" if losses else "...")
            if pending is not None:
                losses.append(pending.item())
            synchronize(device)
            seconds = seconds_before + time.perf_counter() - start
            log.append({"epoch": epoch + 1, "loss": float(np.mean(losses)),
                        "lr": learning_rate(params, epoch), "crops": n_crops,
                        "seconds": round(seconds, 3)})
            save_checkpoint(checkpoint, run_id, model, optimiser, log, device)
    finally:
        bar.close()
    return model, log


def encoder_parameters(model: UNet) -> list[torch.nn.Parameter]:
    """The stem's and the down blocks' parameters: what `finetune` freezes at first."""
    return [*model.stem.parameters(), *model.downs.parameters()]


def finetune(model: UNet, scenes: list[tuple[np.ndarray, np.ndarray]], params: SegmentationParams,
             freeze_epochs: int) -> list[dict]:
    """Fine-tune `model` in place on downsampled, padded (image (Hp, Wp, 3), labels (Hp, Wp))
    pairs; returns the epoch log.

    The encoder (stem and down blocks) gets no gradient and keeps its BatchNorm statistics for the
    first `freeze_epochs` epochs; crops, augmentation, loss and schedule are `train`'s. Minutes
    long, so no checkpoint: a rerun fine-tunes afresh (seeded).
    """
    torch.manual_seed(params.seed)
    if params.bf16:
        model = model.to(memory_format=torch.channels_last)
    optimiser = torch.optim.Adam(model.parameters(), lr=params.lr)
    log = []
    for epoch in range(params.epochs):
        frozen = epoch < freeze_epochs
        model.train()
        for p in encoder_parameters(model):
            p.requires_grad_(not frozen)
        if frozen:
            model.stem.eval()
            model.downs.eval()
        for group in optimiser.param_groups:
            group["lr"] = learning_rate(params, epoch)
        start = time.perf_counter()
        losses = [train_step(model, optimiser, images, labels, params.bf16)
                  for images, labels in epoch_batches(scenes, params, epoch)]
        log.append({"epoch": epoch + 1, "loss": float(np.mean(losses)), "lr": learning_rate(params, epoch),
                    "crops": len(scenes) * params.crops_per_image, "encoder_frozen": frozen,
                    "seconds": round(time.perf_counter() - start, 3)})
    for p in encoder_parameters(model):
        p.requires_grad_(True)
    model.eval()
    return log


def save_checkpoint(path: Path, run_id: str, model: UNet, optimiser: torch.optim.Optimizer,
                    log: list[dict], device: torch.device, position: dict | None = None) -> None:
    """`last.pt` (`pipeline.checkpoints`, identity {"run": run_id}): state_dicts, log, RNG states;
    `position` (mid-epoch only): epoch (0-based), step (the next one to take), batch_rng (the
    epoch's numpy stream before that step's crops), losses (the epoch's step losses so far), crops,
    seconds (spent in the epoch)."""
    checkpoints.save(path, {"run": run_id}, len(log),
                     {"model": model.state_dict(), "optimiser": optimiser.state_dict(), "log": log,
                      "rng": rng_states(device)}, position)


def export_model(path: Path, model: UNet, params: SegmentationParams, profile: str,
                 names: list[str], log: list[dict]) -> None:
    """The trained weights with everything needed to rebuild and use them (no pickled modules)."""
    save_torch(path=path, in_memory=True, payload={
        "format": MODEL_FORMAT,
        "model": {name: value.cpu() for name, value in model.state_dict().items()},
        "unet": dataclasses.asdict(model.cfg),
        "classes": list(CLASS_NAMES),
        "downsample": params.downsample,
        "pad_multiple": params.pad_multiple,
        "profile": profile,
        "train_videos": names,
        "pretrained": False,
        "epochs": len(log),
        "crops": int(sum(row["crops"] for row in log)),
        "train_seconds": round(sum(row["seconds"] for row in log), 1),
        "final_loss": log[-1]["loss"] if log else None,
    })


def load_model(path: Path, device: torch.device | str = "cpu") -> tuple[UNet, dict]:
    """Rebuild the exported U-Net in eval mode on `device` (channels-last on CUDA); returns it and
    the export's metadata."""
    if not Path(path).exists():
        raise FileNotFoundError(f"{path}: no trained segmentation model")
    # weights_only: tensors and plain data only; on the CPU whatever device wrote them
    state = torch.load(path, map_location="cpu", weights_only=True)
    model = UNet(UNetConfig(**state["unet"]))
    model.load_state_dict(state["model"])
    model = conv_layout(model, torch.device(device))
    model.eval()
    return model, {k: v for k, v in state.items() if k != "model"}


def write_log(path: Path, log: list[dict]) -> None:
    """Per-epoch loss, learning rate and time as CSV (a DVC plot)."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=["epoch", "loss", "lr", "crops", "seconds"])
    writer.writeheader()
    writer.writerows(log)
    write_bytes(path, buffer.getvalue().encode())
