"""Y-net training: the train split trains, the val split selects the epoch (stages `train_ynet`,
`train_ynet_horizon`, `train_short_term_ynet`, `train_ind`).

Each epoch visits every train scene under `augmentations` of the 8 rotation/flip variants (drawn at
random per scene and epoch, seeded), its windows in shuffled batches of one scene each. The
learning rate is constant or follows a cosine over the run (`lr_schedule`). After every epoch: validation ADE/FDE
(deterministic: softargmax goal and waypoints, one path; model selection never sees the test set),
a checkpoint (weights, optimiser, RNG states, history) written atomically, and the best weights
kept. Re-running after an interruption resumes from the last checkpoint; on SIGTERM / SIGINT or
when `runtime.max_minutes` is spent, the epoch's progress is checkpointed too
(`pipeline.preemption`), so the run resumes at the very step it stopped at and ends with the
weights of an uninterrupted run. Runs on `runtime.device`.
"""

from __future__ import annotations

import hashlib
import json
import math
import pickle
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd
import torch
from tqdm import tqdm

from pipeline.config.ynet import AUGMENTATIONS, YnetSettings
from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import (SceneWindows, TrainingBatch, augment,
                                     cropped_training_batch, group_by_scene, padded_semantic,
                                     training_batch, window_inputs)
from pipeline import checkpoints
from pipeline.device import (AUTOCAST_DTYPE, CPU, adam_options, autocast, conv_layout,
                             restore_rng_states, rng_states, to_device)
from pipeline.harness.metrics import ade_fde
from pipeline.io import IntermediateError, copy_file, save_torch, write_csv
from pipeline.preemption import NEVER, Preemption
from ynet.heatmaps import distance_maps, padded_size
from ynet.loss import ynet_loss
from ynet.model import YNet, weights_for_horizon
from ynet.sampling import softargmax
from ynet.segmentation import PAD_CLASS


def scale_waypoints(waypoints: list[int], n_future: int, reference_future: int = 30) -> list[int]:
    """Waypoint steps for another horizon, at the same fractions of it as the 30-s config's."""
    # Half rounds up: at t_f = 5 the 15-s waypoint of the 30-s config becomes step 3 (index 2).
    scaled = sorted({int(np.floor((w + 1) * n_future / reference_future + 0.5)) - 1
                     for w in waypoints})
    return [max(0, w) for w in scaled[:-1]] + [n_future - 1]


@torch.inference_mode()
def deterministic_predict(model: YNet, scene: SceneWindows, settings: YnetSettings,
                          batch_size: int) -> tuple[np.ndarray, np.ndarray]:
    """Softargmax waypoints -> one path per window; returns (paths, goals) in resized pixels."""
    paths, goals = [], []
    for start in range(0, len(scene), batch_size):
        past = scene.past[start:start + batch_size]
        inputs, origin = window_inputs(scene.semantic, past, settings.max_distance, settings.crop,
                                       PAD_CLASS, settings.crop_lead_steps)  # origin (B, 2)
        height, width = inputs.shape[-2:]
        features = model.encode(inputs)
        waypoint_logits = model.predict_goals(features)[:, list(model.config.waypoints)]
        waypoints = softargmax(waypoint_logits)  # (B, n_w, 2)
        maps = distance_maps(waypoints, height, width, settings.max_distance)
        path = softargmax(model.predict_trajectory(features, maps))  # (B, n_f, 2)
        paths.append(path + origin[:, None])
        goals.append(waypoints[:, -1] + origin)
    return torch.cat(paths).cpu().numpy(), torch.cat(goals).cpu().numpy()


def validate(model: YNet, scenes: list[SceneWindows], settings: YnetSettings) -> dict[str, float]:
    """Val ADE / FDE in original pixels (deterministic prediction, K = 1)."""
    model.eval()
    preds, goals, truths = [], [], []
    for scene in scenes:
        path, goal = deterministic_predict(model, scene, settings, settings.batch_size)
        preds.append(path)
        goals.append(goal)
        truths.append(scene.future.cpu().numpy())
    scores = ade_fde(np.concatenate(preds)[:, None] / settings.resize,
                     np.concatenate(truths) / settings.resize,
                     np.concatenate(goals)[:, None] / settings.resize)
    return {"val_ade": scores["ade"], "val_fde": scores["fde"]}


BatchPart = tuple[int, int, bool, np.ndarray | torch.Tensor]
"""(scene index, quarter turns, flip, window rows): windows of one scene under one augmentation.
Rows are numpy in a plan as drawn, tensors on the device once `plan_on_device` has moved them."""


def epoch_plan(scenes: list[SceneWindows], settings: YnetSettings,
               rng: np.random.Generator) -> list[list[BatchPart]]:
    """Every batch of one epoch, shuffled: one part per batch (one scene)."""
    plan = []
    for s, scene in enumerate(scenes):
        variants = rng.choice(len(AUGMENTATIONS), settings.augmentations, replace=False)
        for variant in variants:
            turns, flip = AUGMENTATIONS[variant]
            order = rng.permutation(len(scene))
            for start in range(0, len(order), settings.batch_size):
                plan.append([(s, turns, flip, order[start:start + settings.batch_size])])
    return [plan[i] for i in rng.permutation(len(plan))]


def plan_input_shape(parts: list[BatchPart], scenes: list[SceneWindows], settings: YnetSettings
                     ) -> tuple[int, int, int]:
    """(batch, height, width) of the model input `plan_batch` builds for one plan entry, without
    building it: the padded map of its (rotated) scene, or the crop. For the benchmarks, which
    count a step's FLOPs and warm up on each shape."""
    batch = sum(len(rows) for *_, rows in parts)
    if settings.crop:
        return batch, settings.crop, settings.crop
    s, turns = parts[0][:2]
    height, width = scenes[s].semantic.shape[-2:]
    if turns % 2:
        height, width = width, height
    return (batch, *padded_size(height, width))


def plan_on_device(plan: list[list[BatchPart]], device: torch.device) -> list[list[BatchPart]]:
    """The plan with its window rows as index tensors on `device`, copied in one piece: a numpy
    index would be copied to the GPU at every step, and each such copy waits for the device."""
    rows = [part[3] for parts in plan for part in parts]
    if not rows:
        return plan
    pieces = iter(to_device(torch.from_numpy(np.concatenate(rows)), device).split(
        [len(r) for r in rows]))
    return [[(s, turns, flip, next(pieces)) for s, turns, flip, _ in parts] for parts in plan]


def scheduled_learning_rate(settings: YnetSettings, epoch: int, step: int, steps_in_epoch: int,
                            epochs: int) -> float:
    """The learning rate of step `step` (0-based) of epoch `epoch` (1-based) of an `epochs` run."""
    if settings.lr_schedule == "constant":
        return settings.learning_rate
    progress = (epoch - 1 + step / steps_in_epoch) / epochs  # in [0, 1)
    return settings.learning_rate * 0.5 * (1.0 + math.cos(math.pi * progress))


def optimizer_groups(model: YNet, settings: YnetSettings) -> list[dict]:
    """Adam's parameter groups, each with the factor `lr_scale` on the scheduled rate: one group
    (as ever, so older checkpoints' optimiser states still load) unless the trajectory decoder
    has a rate of its own."""
    if settings.trajectory_lr_scale == 1.0:
        return [{"params": list(model.parameters()), "lr_scale": 1.0}]
    trajectory = {id(p) for p in model.trajectory_decoder.parameters()}
    return [{"params": [p for p in model.parameters() if id(p) not in trajectory], "lr_scale": 1.0},
            {"params": list(model.trajectory_decoder.parameters()),
             "lr_scale": settings.trajectory_lr_scale}]


def ynet_optimizer(model: YNet, settings: YnetSettings, device: torch.device) -> torch.optim.Adam:
    """Training's Adam over `optimizer_groups`, fused where the model is on CUDA
    (`device.adam_options`)."""
    return torch.optim.Adam(optimizer_groups(model, settings), lr=settings.learning_rate,
                            **adam_options(device))


def concat_batches(batches: list[TrainingBatch]) -> TrainingBatch:
    """Batches of the same map size as one: (sum B, ...) each."""
    if len(batches) == 1:
        return batches[0]
    return TrainingBatch(*(torch.cat(parts) for parts in
                           zip(*((b.inputs, b.waypoint_maps, b.target) for b in batches))))


def plan_batch(parts: list[BatchPart], scenes: list[SceneWindows], settings: YnetSettings,
               augmented: dict[tuple[int, int, bool], tuple[SceneWindows, torch.Tensor]]
               ) -> TrainingBatch:
    """The training batch of one plan entry: its parts' windows, in order. `augmented` caches each
    (scene, turns, flip)'s augmented scene and padded map across the steps of an epoch."""
    batches = []
    for s, turns, flip, rows in parts:
        key = (s, turns, flip)
        if key not in augmented:  # the scene's map is prepared once per augmentation
            scene = augment(scenes[s], turns, flip)
            augmented[key] = (scene, padded_semantic(scene.semantic, PAD_CLASS))
        scene, semantic = augmented[key]
        if settings.crop:
            batches.append(cropped_training_batch(
                scene.semantic, scene.past[rows], scene.future[rows], tuple(settings.waypoints),
                settings.max_distance, settings.kernel_size, settings.sigma, settings.crop,
                settings.crop_lead_steps, PAD_CLASS))
        else:
            batches.append(training_batch(semantic, scene.past[rows], scene.future[rows],
                                          tuple(settings.waypoints), settings.max_distance,
                                          settings.kernel_size, settings.sigma))
    return concat_batches(batches)


def train_epoch(model: YNet, optimizer, scenes: list[SceneWindows], settings: YnetSettings,
                plan: list[list[BatchPart]], epoch: int, losses: list[float],
                device: torch.device = CPU, preemption: Preemption = NEVER,
                save_partial=None, epochs: int | None = None) -> float:
    """One epoch's optimiser steps, from step `len(losses)` of `plan` on; returns the mean loss.

    `losses` holds the steps already taken (a resumed epoch) and grows in place: each step's loss
    stays on the device until the epoch ends or stops, then all are read at once (reading one per
    step would make the host wait for the GPU at every step). Before each step the loop asks
    `preemption`; if it says stop, `save_partial(losses)` checkpoints the epoch so far and
    `StopRequested` is raised. `epochs`: the run's length, for the learning-rate schedule (default
    `settings.epochs`).
    """
    model.train()
    if settings.steps_per_epoch:
        plan = plan[:settings.steps_per_epoch]  # shuffled: a random subset of the batches
    plan = plan_on_device(plan, device)
    epochs = epochs or settings.epochs
    augmented: dict[tuple[int, int, bool], tuple[SceneWindows, torch.Tensor]] = {}
    unread: list[torch.Tensor] = []  # the losses of this call's steps, on the device

    def read_losses() -> list[float]:
        if unread:
            losses.extend(torch.stack(unread).tolist())
            unread.clear()
        return losses

    for step in tqdm(range(len(losses), len(plan)), desc=f"epoch {epoch}", leave=False,
                     disable=None, initial=len(losses), total=len(plan)):
        if preemption.stop_reason():
            save_partial(read_losses())
            raise preemption.request(f"epoch {epoch}, step {step} of {len(plan)}")
        batch = plan_batch(plan[step], scenes, settings, augmented)
        inputs, waypoint_maps = batch.inputs, batch.waypoint_maps
        if device.type == "cuda":  # autocast's dtype and layout in one copy, not a copy and casts
            inputs = inputs.to(AUTOCAST_DTYPE, memory_format=torch.channels_last)
            waypoint_maps = waypoint_maps.to(AUTOCAST_DTYPE)
        elif settings.bf16:
            inputs = inputs.contiguous(memory_format=torch.channels_last)
        rate = scheduled_learning_rate(settings, epoch, step, len(plan), epochs)
        for group in optimizer.param_groups:
            group["lr"] = rate * group.get("lr_scale", 1.0)
        with autocast(device, settings.bf16):
            goal_logits, trajectory_logits = model(inputs, waypoint_maps)
        loss = ynet_loss(goal_logits.float(), trajectory_logits.float(), batch.target,
                         settings.loss_scale).total
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        if settings.grad_clip_norm:
            torch.nn.utils.clip_grad_norm_(model.parameters(), settings.grad_clip_norm)
        optimizer.step()
        unread.append(loss.detach())
    return float(np.mean(read_losses()))


RESUMABLE_SETTINGS = ("epochs", "threads")  # may change between an interrupted run and its resumption


def run_fingerprint(settings: YnetSettings, n_past: int, semantic_maps: dict[str, np.ndarray],
                    *arrays: WindowArrays) -> str:
    """SHA-256 of what a training run depends on: settings, windows and scene maps
    (`checkpoints.run_digest`)."""
    kept = {k: v for k, v in asdict(settings).items() if k not in RESUMABLE_SETTINGS}
    return checkpoints.run_digest(json.dumps({"settings": kept, "n_past": n_past}, sort_keys=True),
                                  *arrays, maps=semantic_maps)


def horizon_start(main_model: Path, settings: YnetSettings, n_past: int,
                  n_future: int) -> dict[str, torch.Tensor]:
    """The main Y-net's weights (`train_ynet`'s model file) as the start of a model predicting
    `n_future` steps with `settings` (`ynet.model.weights_for_horizon`). The two models must differ
    in their horizon and waypoints alone, or an IntermediateError names the file."""
    try:
        saved = torch.load(main_model, map_location="cpu", weights_only=True)
        state, config = saved["model"], saved["config"]
    except FileNotFoundError as e:
        raise IntermediateError(f"{main_model}: missing (re-run train_ynet)") from e
    except (OSError, RuntimeError, KeyError, TypeError, pickle.UnpicklingError) as e:
        raise IntermediateError(f"{main_model}: not a Y-net model file as train_ynet writes it ({e})") from e
    wanted = asdict(settings.model_config(n_past, n_future))
    differs = sorted(key for key in wanted if key not in ("pred_len", "waypoints")
                     and list_of(config.get(key)) != list_of(wanted[key]))
    if differs:
        raise IntermediateError(f"{main_model}: its model differs from this horizon's in {differs} "
                                "(a horizon can start from the main model only with the same ynet settings)")
    return weights_for_horizon(state, n_future)


def list_of(value):
    """Tuples (a config) and lists (its JSON-like copy in a checkpoint) compare equal."""
    return list(value) if isinstance(value, (list, tuple)) else value


def state_digest(state: dict[str, torch.Tensor]) -> str:
    """SHA-256 of a state dict's names and values."""
    digest = hashlib.sha256()
    for name in sorted(state):
        digest.update(name.encode())
        digest.update(state[name].detach().cpu().contiguous().numpy().tobytes())
    return digest.hexdigest()


def train(train_arrays: WindowArrays, val_arrays: WindowArrays, semantic_maps, sizes,
          settings: YnetSettings, n_past: int, checkpoint: Path, best_path: Path,
          history_path: Path, epochs: int | None = None, device: torch.device = CPU,
          preemption: Preemption = NEVER,
          initial_weights: dict[str, torch.Tensor] | None = None) -> dict:
    """Train (resuming from `checkpoint` if present); returns the training summary.

    `initial_weights` (a state dict of this model's shapes) replace the seeded random init: a
    horizon model starting from the main one (`ynet.model.weights_for_horizon`).
    Checkpoint (`pipeline.checkpoints`; identity: `run_fingerprint`, and the initial weights'
    digest if given) = weights, optimiser, the plan RNG's state at the start of the next epoch (or of the current one, with the position's
    `losses` of the steps already taken in it), torch's RNG, history.
    """
    torch.set_num_threads(settings.threads)
    torch.set_flush_denormal(True)  # otherwise Adam crawls through denormal numbers on CPU
    checkpoints.seed_everything(settings.seed)
    total_epochs = epochs or settings.epochs  # the run's length (the lr schedule spans it)
    n_future = train_arrays.future.shape[1]
    model = YNet(settings.model_config(n_past, n_future))  # seeded init on CPU
    if initial_weights is not None:
        model.load_state_dict(initial_weights)
    model = conv_layout(model, device)
    optimizer = ynet_optimizer(model, settings, device)
    rng = np.random.default_rng(settings.seed)
    train_scenes = group_by_scene(train_arrays, semantic_maps, sizes, settings.resize, device)
    val_scenes = group_by_scene(val_arrays, semantic_maps, sizes, settings.resize, device)

    state = {"epoch": 0, "history": [], "best": None, "seconds": 0.0}
    partial_losses: list[float] = []
    identity = {"run": run_fingerprint(settings, n_past, semantic_maps, train_arrays, val_arrays)}
    if initial_weights is not None:
        identity["initial_weights"] = state_digest(initial_weights)
    kept_best = checkpoint.with_name(checkpoints.BEST)  # the best weights, beside the checkpoint
    resumed = checkpoints.resume(checkpoint, identity, total_epochs, "train_ynet")
    if resumed is not None:
        model.load_state_dict(resumed.state["model"])
        optimizer.load_state_dict(resumed.state["optimizer"])
        rng.bit_generator.state = resumed.state["rng"]["numpy_plan"]
        restore_rng_states(resumed.state["rng"], device)
        state = {"epoch": resumed.epoch, **resumed.state["progress"]}
        partial_losses = list(resumed.position["losses"]) if resumed.position else []
        print(f"train_ynet: resuming after epoch {state['epoch']}"
              + (f", step {len(partial_losses)}" if resumed.position else ""))

    def save_checkpoint(plan_state: dict, losses: list[float] | None) -> None:
        """`losses`: the steps taken in the epoch under way (None at the end of an epoch)."""
        progress = {key: state[key] for key in ("history", "best", "seconds")}
        if losses is not None:  # mid-epoch: keep the epoch's time so far, or a resumed run loses it
            progress["seconds"] += time.perf_counter() - start
        checkpoints.save(checkpoint, identity, state["epoch"],
                         {"model": model.state_dict(), "optimizer": optimizer.state_dict(),
                          "rng": {"numpy_plan": plan_state, **rng_states(device)},
                          "progress": progress},
                         None if losses is None else {"losses": list(losses)})

    for epoch in range(state["epoch"] + 1, total_epochs + 1):
        if preemption.stop_reason():  # the last epoch's checkpoint is already on disk
            raise preemption.request(f"the end of epoch {epoch - 1}")
        start = time.perf_counter()
        plan_state = rng.bit_generator.state  # regenerates this epoch's plan on resumption
        plan = epoch_plan(train_scenes, settings, rng)
        loss = train_epoch(model, optimizer, train_scenes, settings, plan, epoch, partial_losses,
                           device, preemption, lambda losses: save_checkpoint(plan_state, losses),
                           total_epochs)
        partial_losses = []
        scores = validate(model, val_scenes, settings)
        state["seconds"] += time.perf_counter() - start
        state["history"].append({"epoch": epoch, "train_loss": loss, **scores,
                                 "seconds": state["seconds"]})
        print(f"epoch {epoch}: loss {loss:.3f}  val ADE {scores['val_ade']:.2f}  "
              f"FDE {scores['val_fde']:.2f}  ({state['seconds']:.0f} s)")
        if state["best"] is None or scores["val_ade"] < state["best"]["val_ade"]:
            state["best"] = {"epoch": epoch, **scores}
            save_torch({"model": model.state_dict(), "config": asdict(model.config),
                         "settings": asdict(settings), "epoch": epoch}, kept_best)
        state["epoch"] = epoch
        save_checkpoint(rng.bit_generator.state, None)
        write_csv(pd.DataFrame(state["history"]), history_path)
    # DVC deletes the stage's outputs before a re-run, so a run resumed after its last epoch (or
    # after the best epoch) must still deliver them: both come from the checkpoint folder.
    if kept_best != best_path:
        copy_file(kept_best, best_path)
    write_csv(pd.DataFrame(state["history"]), history_path)
    return {"epochs": state["epoch"], "best_epoch": state["best"]["epoch"],
            "best_val_ade": state["best"]["val_ade"], "best_val_fde": state["best"]["val_fde"],
            "train_seconds": state["seconds"], "train_windows": len(train_arrays),
            "val_windows": len(val_arrays)}
