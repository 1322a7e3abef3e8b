"""How Y-net training batches are drawn and stepped: one scene a batch of agent crops, the cosine
learning-rate schedule, the trajectory decoder's own rate, gradient clipping, and bfloat16 autocast
on the CPU."""

import math

import numpy as np
import pytest
import torch

from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import group_by_scene
from pipeline.preemption import NEVER, Preemption, StopRequested
from pipeline.runners import ynet_training
from pipeline.runners.ynet_training import (epoch_plan, optimizer_groups, scheduled_learning_rate,
                                            train, train_epoch)
from pipeline.config.ynet import YnetSettings
from ynet.model import YNet

N_PAST, N_FUTURE = 3, 4
SETTINGS = dict(resize=0.25, epochs=2, batch_size=4, learning_rate=1e-3, augmentations=2,
                kernel_size=7, sigma=1.5, waypoints=[1, 3], encoder_channels=[4, 4, 8, 8, 8],
                decoder_channels=[8, 8, 8, 4, 4], seed=3, threads=1, head_bias=-5.0, crop=32,
                crop_lead_steps=1.0)
MAPS = {"gates_0": np.full((6, 64, 64), 1 / 6, np.float32),
        "hyang_1": np.tile(np.eye(6, dtype=np.float32)[:, :, None, None], (1, 1, 48, 80))[0]}
SIZES = {"gates_0": (256, 256), "hyang_1": (192, 320)}


def arrays(counts: dict[str, int], split: str, seed: int) -> WindowArrays:
    """Agents walking right at 8 px/step, `counts[scene]` of them in each scene."""
    rng = np.random.default_rng(seed)
    n = sum(counts.values())
    xy = rng.uniform(40, 150, size=(n, 1, 2)) + np.arange(N_PAST + N_FUTURE)[None, :, None] * [8.0, 0.0]
    return WindowArrays(past=xy[:, :N_PAST], future=xy[:, N_PAST:], window_id=np.arange(n),
                        scene_id=np.repeat(list(counts), list(counts.values())),
                        track_id=np.arange(n), first_frame=np.zeros(n), split=np.array([split] * n))


def scenes(counts=None):
    return group_by_scene(arrays(counts or {"gates_0": 5, "hyang_1": 7}, "train", 0), MAPS, SIZES, 0.25)


def test_a_plan_has_one_scene_a_batch_and_every_window_once_per_augmentation():
    train_scenes = scenes()
    one_scene = epoch_plan(train_scenes, YnetSettings(**SETTINGS), np.random.default_rng(0))
    assert all(len(batch) == 1 for batch in one_scene)
    assert sorted(sum(len(b[0][3]) for b in one_scene if b[0][0] == s) for s in (0, 1)) == [10, 14]


def test_the_cosine_schedule_falls_from_the_rate_to_zero_and_the_constant_one_stays():
    cosine = YnetSettings(**SETTINGS, lr_schedule="cosine")
    rates = [scheduled_learning_rate(cosine, epoch, step, 4, 2) for epoch in (1, 2) for step in range(4)]
    assert rates[0] == pytest.approx(1e-3) and rates[4] == pytest.approx(0.5e-3)
    assert all(a > b for a, b in zip(rates, rates[1:])) and rates[-1] == pytest.approx(
        0.5e-3 * (1 + math.cos(math.pi * 7 / 8)))
    constant = YnetSettings(**SETTINGS)
    assert {scheduled_learning_rate(constant, 2, 3, 4, 2)} == {1e-3}

    torch.manual_seed(0)
    model = YNet(cosine.model_config(N_PAST, N_FUTURE))
    optimizer = torch.optim.Adam(model.parameters(), lr=1.0)
    train_scenes = scenes()
    plan = epoch_plan(train_scenes, cosine, np.random.default_rng(0))
    train_epoch(model, optimizer, train_scenes, cosine, plan, 2, [], epochs=2)
    assert optimizer.param_groups[0]["lr"] == pytest.approx(
        scheduled_learning_rate(cosine, 2, len(plan) - 1, len(plan), 2))  # the last step's rate


@pytest.mark.usefixtures("cpu_bf16_hardware")
def test_bf16_autocast_trains_on_the_cpu_close_to_float32():
    train_scenes = scenes()
    losses = {}
    for bf16 in (False, True):
        torch.manual_seed(0)
        settings = YnetSettings(**SETTINGS, bf16=bf16)
        model = YNet(settings.model_config(N_PAST, N_FUTURE))
        optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
        plan = epoch_plan(train_scenes, settings, np.random.default_rng(0))[:1]
        losses[bf16] = train_epoch(model, optimizer, train_scenes, settings, plan, 1, [])
    assert losses[True] != losses[False]  # autocast ran
    assert losses[True] == pytest.approx(losses[False], rel=0.02)


def one_step(settings: YnetSettings) -> tuple[dict[str, torch.Tensor], torch.optim.Adam]:
    """The change of every parameter after one optimiser step from the seeded init, and Adam."""
    torch.manual_seed(0)
    model = YNet(settings.model_config(N_PAST, N_FUTURE))
    before = {name: p.detach().clone() for name, p in model.named_parameters()}
    optimizer = torch.optim.Adam(optimizer_groups(model, settings), lr=settings.learning_rate)
    train_scenes = scenes()
    plan = epoch_plan(train_scenes, settings, np.random.default_rng(0))[:1]
    train_epoch(model, optimizer, train_scenes, settings, plan, 1, [])
    return {name: p.detach() - before[name] for name, p in model.named_parameters()}, optimizer


def test_the_trajectory_decoder_steps_at_its_own_rate_and_the_rest_as_before():
    single, single_adam = one_step(YnetSettings(**SETTINGS))
    scaled, scaled_adam = one_step(YnetSettings(**SETTINGS, trajectory_lr_scale=3.0))
    assert len(single_adam.param_groups) == 1  # as before the setting: old optimiser states load
    assert [g["lr"] for g in scaled_adam.param_groups] == pytest.approx([1e-3, 3e-3])
    trajectory = [name for name in single if name.startswith("trajectory_decoder.")]
    assert trajectory and len(trajectory) < len(single)
    for name, change in single.items():
        if name in trajectory:  # Adam's first step is lr * sign-like: three times as far
            torch.testing.assert_close(scaled[name], 3 * change, rtol=1e-3, atol=2e-7)  # float32 ulps
        else:
            torch.testing.assert_close(scaled[name], change, rtol=0, atol=0)
    assert any(change.abs().max() > 0 for name, change in single.items() if name in trajectory)


@pytest.mark.parametrize("bad, match", [({"lr_schedule": "linear"}, "lr_schedule"),
                                        ({"trajectory_lr_scale": 0.0}, "trajectory_lr_scale"),
                                        ({"grad_clip_norm": -1.0}, "grad_clip_norm")])
def test_settings_that_cannot_work_are_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        YnetSettings(**{**SETTINGS, **bad})


def assert_resumes_to_the_uninterrupted_weights(settings: YnetSettings, tmp_path, monkeypatch):
    """Stopped in the middle of epoch 2 (a spent time budget) and resumed: the same last weights."""
    torch.set_num_threads(1)
    val = arrays({"gates_0": 2, "hyang_1": 2}, "val", 1)

    def run(folder, preemption=NEVER):
        train(arrays({"gates_0": 5, "hyang_1": 7}, "train", 0), val, MAPS, SIZES, settings, N_PAST,
              folder / "last.pt", folder / "best.pt", folder / "history.csv", preemption=preemption)
        return torch.load(folder / "last.pt", weights_only=True)["state"]["model"]

    straight = run(tmp_path / "a")
    steps = []
    steps_an_epoch = len(epoch_plan(scenes(), settings, np.random.default_rng(settings.seed)))
    real_loss = ynet_training.ynet_loss
    monkeypatch.setattr(ynet_training, "ynet_loss", lambda *a, **k: steps.append(1) or real_loss(*a, **k))
    budget = Preemption(max_minutes=1, clock=lambda: 120.0 * (len(steps) >= steps_an_epoch + 2))  # 2 into epoch 2
    with budget, pytest.raises(StopRequested):
        run(tmp_path / "b", budget)
    monkeypatch.undo()
    resumed = run(tmp_path / "b")
    for name in straight:
        torch.testing.assert_close(straight[name], resumed[name], rtol=0, atol=0)


@pytest.mark.usefixtures("cpu_bf16_hardware")
def test_a_resumed_cosine_bf16_run_ends_with_the_uninterrupted_weights(tmp_path, monkeypatch):
    """The schedule and the plan pick up at the step where the run stopped."""
    settings = YnetSettings(**SETTINGS, lr_schedule="cosine", bf16=True)
    assert_resumes_to_the_uninterrupted_weights(settings, tmp_path, monkeypatch)


def test_a_resumed_run_keeps_the_trajectory_decoders_own_rate(tmp_path, monkeypatch):
    settings = YnetSettings(**SETTINGS, lr_schedule="cosine", trajectory_lr_scale=3.0)
    assert_resumes_to_the_uninterrupted_weights(settings, tmp_path, monkeypatch)




def test_clipping_bounds_the_gradient_norm_each_step_takes():
    def step_norms(clip: float) -> list[float]:
        settings = YnetSettings(**SETTINGS, grad_clip_norm=clip)
        torch.manual_seed(0)
        model = YNet(settings.model_config(N_PAST, N_FUTURE))
        norms = []

        class Recording(torch.optim.Adam):
            def step(self, closure=None):
                norms.append(float(torch.linalg.vector_norm(
                    torch.stack([torch.linalg.vector_norm(p.grad) for p in model.parameters()]))))
                return super().step(closure)

        train_scenes = scenes()
        plan = epoch_plan(train_scenes, settings, np.random.default_rng(0))[:3]
        train_epoch(model, Recording(model.parameters(), lr=1e-3), train_scenes, settings, plan, 1, [])
        return norms

    free = step_norms(0.0)
    clip = min(free) / 2  # below every step's norm: each one is clipped to it
    assert max(free) > clip
    assert step_norms(clip) == pytest.approx([clip] * len(free), rel=1e-4)
    assert step_norms(max(free) * 2) == free  # above them all: the same steps as without
