"""A Y-net training step never makes the host wait for a GPU, does the same work at any batch size,
and on the CPU computes bit for bit what it did before: the references below are the step as it
was (rows and waypoints indexed with host data, padding by boolean masks, crops one agent at a
time, every loss read after its step).

The audit (`tests/sync_audit.py`) runs on the CPU: what it counts would each block the host on
CUDA, and the CPU path must not move a bit, so both are checked here without a GPU.
"""

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from pipeline.data.ynet_data import (TrainingBatch, agent_crops, augment, model_input,
                                     padded_semantic)
from pipeline.preemption import NEVER, Preemption, StopRequested
from pipeline.runners import ynet_training
from pipeline.runners.ynet_training import (concat_batches, epoch_plan, optimizer_groups,
                                            scheduled_learning_rate, train, train_epoch)
from pipeline.config.ynet import YnetSettings
from tests.sync_audit import SyncAudit, host_state
from tests.test_train_batches import MAPS, N_FUTURE, N_PAST, SETTINGS, SIZES, arrays, scenes
from ynet.heatmaps import distance_maps, gaussian_heatmaps, pad_to_multiple
from ynet.loss import ynet_loss
from ynet.model import YNet
from ynet.segmentation import PAD_CLASS

VARIANTS = {
    "whole scenes": dict(crop=0),
    "crops": dict(),
    "crops, cosine, clipped, own trajectory rate": dict(
        lr_schedule="cosine", grad_clip_norm=5.0, trajectory_lr_scale=3.0),
}


@pytest.fixture(params=list(VARIANTS))
def settings(request):
    torch.set_num_threads(1)
    return YnetSettings(**{**SETTINGS, **VARIANTS[request.param]})


def model_and_optimizer(settings: YnetSettings):
    torch.manual_seed(0)
    model = YNet(settings.model_config(N_PAST, N_FUTURE))
    return model, torch.optim.Adam(optimizer_groups(model, settings), lr=settings.learning_rate)


def test_no_step_waits_for_the_device_and_the_losses_are_read_once(settings):
    train_scenes = scenes()
    model, optimizer = model_and_optimizer(settings)
    plan = epoch_plan(train_scenes, settings, np.random.default_rng(0))
    train_epoch(model, optimizer, train_scenes, settings, plan[:1], 1, [])  # Adam's state exists
    losses = []
    with SyncAudit(host_state(optimizer)) as audit:
        train_epoch(model, optimizer, train_scenes, settings, plan, 1, losses)
    assert len(losses) == len(plan) > 3
    assert audit.events == [("tolist", (len(plan),))]  # the epoch's losses, read at its end


def test_a_step_dispatches_the_same_operators_at_batch_2_and_8(settings):
    """The same number of each operator: nothing loops over the windows of a batch."""
    ops = {}
    for batch_size in (2, 8):
        sized = YnetSettings(**{**vars(settings), "batch_size": batch_size})
        train_scenes = scenes({"gates_0": 8, "hyang_1": 8})
        model, optimizer = model_and_optimizer(sized)
        plan = epoch_plan(train_scenes, sized, np.random.default_rng(0))
        train_epoch(model, optimizer, train_scenes, sized, plan[:1], 1, [])  # Adam's state exists
        step = [[(1, 1, True, np.arange(batch_size))]]  # windows of scene 1, turned and flipped
        with SyncAudit(host_state(optimizer)) as audit:
            train_epoch(model, optimizer, train_scenes, sized, step, 1, [])
        ops[batch_size] = audit.ops
    assert ops[2] == ops[8]


# The step as it was.

def reference_padded_semantic(semantic, padding_class):
    padded = pad_to_multiple(semantic)
    height, width = semantic.shape[-2:]
    outside = torch.ones(padded.shape[-2:], dtype=torch.bool)
    outside[:height, :width] = False
    padded[padding_class][outside] = 1.0
    return padded


def reference_agent_crops(semantic, centres, size, padding_class):
    _, height, width = semantic.shape
    half = size // 2
    padded = F.pad(semantic, (half, size, half, size))
    outside = torch.ones(padded.shape[-2:], dtype=torch.bool)
    outside[half:half + height, half:half + width] = False
    padded[padding_class][outside] = 1.0
    origin = torch.round(centres).long() - half
    origin[:, 0].clamp_(-half, width)
    origin[:, 1].clamp_(-half, height)
    crops = torch.stack([padded[:, y + half:y + half + size, x + half:x + half + size]
                         for x, y in origin.tolist()])
    return crops, origin.to(centres.dtype)


@pytest.mark.parametrize("height, width", [(40, 70), (64, 96), (33, 31)])
def test_padding_and_crops_are_bit_for_bit_those_of_the_reference(height, width):
    """Slice writes mark the same pixels as the boolean masks; one gather cuts the same crops as
    the loop, at the borders too (centres beyond the map, crops clamped into the padding)."""
    generator = torch.Generator().manual_seed(height)
    semantic = torch.rand(4, height, width, generator=generator)
    for padding_class in (0, 3):
        assert torch.equal(padded_semantic(semantic, padding_class),
                           reference_padded_semantic(semantic, padding_class))
    assert torch.equal(padded_semantic(semantic, None), pad_to_multiple(semantic))
    centres = torch.rand(9, 2, generator=generator) * torch.tensor([width + 80.0, height + 80.0]) - 40
    for size in (32, 64):
        crops, origin = agent_crops(semantic, centres, size, 2)
        expected_crops, expected_origin = reference_agent_crops(semantic, centres, size, 2)
        assert torch.equal(crops, expected_crops) and torch.equal(origin, expected_origin)
        assert crops.is_contiguous()


def reference_batch(parts, train_scenes, settings, augmented):
    batches = []
    waypoints = list(settings.waypoints)
    for s, turns, flip, rows in parts:
        if (s, turns, flip) not in augmented:
            scene = augment(train_scenes[s], turns, flip)
            augmented[s, turns, flip] = (scene, reference_padded_semantic(scene.semantic, PAD_CLASS))
        scene, semantic = augmented[s, turns, flip]
        past, future = scene.past[rows], scene.future[rows]
        if settings.crop:
            size, lead = settings.crop, settings.crop_lead_steps
            centres = past[:, -1] + lead * (past[:, -1] - past[:, -2])
            crops, origin = reference_agent_crops(scene.semantic, centres, size, PAD_CLASS)
            inputs = torch.cat([crops, distance_maps(past - origin[:, None], size, size,
                                                     settings.max_distance)], dim=1)
            future = future - origin[:, None]
            height = width = size
        else:
            inputs = model_input(semantic, past, settings.max_distance)
            height, width = semantic.shape[-2:]
        batches.append(TrainingBatch(
            inputs, distance_maps(future[:, waypoints], height, width, settings.max_distance),
            gaussian_heatmaps(future, height, width, settings.kernel_size, settings.sigma)))
    return concat_batches(batches)


def reference_train_epoch(model, optimizer, train_scenes, settings, plan, epoch, losses,
                          device=None, preemption=None, save_partial=None, epochs=None):
    model.train()
    epochs = epochs or settings.epochs
    augmented = {}
    for step in range(len(losses), len(plan)):
        batch = reference_batch(plan[step], train_scenes, settings, augmented)
        rate = scheduled_learning_rate(settings, epoch, step, len(plan), epochs)
        for group in optimizer.param_groups:
            group["lr"] = rate * group.get("lr_scale", 1.0)
        goal_logits, trajectory_logits = model(batch.inputs, batch.waypoint_maps)
        loss = ynet_loss(goal_logits.float(), trajectory_logits.float(), batch.target,
                         settings.loss_scale).total
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        if settings.grad_clip_norm:
            torch.nn.utils.clip_grad_norm_(model.parameters(), settings.grad_clip_norm)
        optimizer.step()
        losses.append(loss.item())
    return float(np.mean(losses))


def test_the_cpu_steps_are_bit_for_bit_those_of_the_reference(settings):
    train_scenes = scenes()
    runs = {}
    for name, epoch_fn in (("reference", reference_train_epoch), ("new", train_epoch)):
        model, optimizer = model_and_optimizer(settings)
        rng = np.random.default_rng(0)
        per_epoch = []
        for epoch in (1, 2):
            losses = []
            mean = epoch_fn(model, optimizer, train_scenes, settings,
                            epoch_plan(train_scenes, settings, rng), epoch, losses)
            per_epoch.append((mean, losses))
        runs[name] = per_epoch, model.state_dict(), optimizer.state_dict()["state"]
    (reference, weights, adam), (new, new_weights, new_adam) = runs["reference"], runs["new"]
    assert new == reference and len(reference[0][1]) > 3
    for name, value in weights.items():
        assert torch.equal(new_weights[name], value), name
    for index, state in adam.items():
        for key, value in state.items():
            assert torch.equal(new_adam[index][key], value), (index, key)


def test_the_recorded_history_and_weights_are_those_of_the_reference(settings, tmp_path, monkeypatch):
    """`train`'s history.csv byte for byte but the clock's column, and last.pt's / best.pt's
    weights; also when the run stops in the middle of epoch 2 (its losses so far checkpointed)
    and resumes."""
    def run(folder, preemption=NEVER):
        train(arrays({"gates_0": 5, "hyang_1": 7}, "train", 0),
              arrays({"gates_0": 2, "hyang_1": 2}, "val", 1), MAPS, SIZES, settings, N_PAST,
              folder / "last.pt", folder / "best.pt", folder / "history.csv", preemption=preemption)
        lines = (folder / "history.csv").read_text().splitlines()
        assert lines[0].endswith(",seconds") and len(lines) == settings.epochs + 1
        weights = [torch.load(folder / name, weights_only=True) for name in ("last.pt", "best.pt")]
        return [line.rsplit(",", 1)[0] for line in lines], weights[0]["state"]["model"], weights[1]["model"]

    runs = {"new": run(tmp_path / "new")}
    steps = []
    steps_an_epoch = len(epoch_plan(scenes(), settings, np.random.default_rng(settings.seed)))
    real_loss = ynet_training.ynet_loss
    monkeypatch.setattr(ynet_training, "ynet_loss", lambda *a, **k: steps.append(1) or real_loss(*a, **k))
    budget = Preemption(max_minutes=1, clock=lambda: 120.0 * (len(steps) >= steps_an_epoch + 2))
    with budget, pytest.raises(StopRequested):
        run(tmp_path / "resumed", budget)
    assert len(torch.load(tmp_path / "resumed" / "last.pt", weights_only=True)["position"]["losses"]) == 2
    monkeypatch.undo()
    runs["resumed"] = run(tmp_path / "resumed")
    monkeypatch.setattr(ynet_training, "train_epoch", reference_train_epoch)
    history, last, best = run(tmp_path / "reference")
    for new_history, new_last, new_best in runs.values():
        assert new_history == history
        for name in last:
            assert torch.equal(new_last[name], last[name]) and torch.equal(new_best[name], best[name])
