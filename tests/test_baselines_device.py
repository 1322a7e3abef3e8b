"""Baselines and devices / preemption: no tensor is made on a hard-coded device, and training
stopped mid-epoch (SIGTERM, time budget) resumes to exactly the weights of an uninterrupted run.
Tiny configs on synthetic windows, one thread, CPU only (no GPU needed)."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
import signal

import numpy as np
import pytest
import torch
import yaml

from pipeline.stages import train_baseline
from pipeline import checkpoints
from pipeline.runners.baselines import common
from pipeline.runners.baselines import pecnet as pecnet_module
from pipeline.runners.baselines import sgan as sgan_module
from pipeline.runners.baselines.pecnet import Pecnet
from pipeline.runners.baselines.rpecnet import RecurrentPecnet
from pipeline.runners.baselines.sgan import SocialGan
from pipeline.device import generator as seeded_generator
from pipeline.models import window_set
from pipeline.models.constant_velocity import ConstantVelocity
from pipeline.preemption import EXIT_BUDGET, Preemption, StopRequested
from tests.test_baselines import N_PAST, TINY_PECNET, TINY_SGAN, state_of, straight_tracks, window_table

torch.set_num_threads(1)
CPU = torch.device("cpu")


# ---------------------------------------------------------------------------------------------
# No hard-coded device: inside `with torch.device("meta")` every factory call that forgot its
# `device=` makes a meta tensor, and mixing it with the CPU modules and inputs fails loudly.


def all_on_cpu(*modules: torch.nn.Module) -> bool:
    return all(t.device == CPU for m in modules for t in (*m.parameters(), *m.buffers()))


def optimizer_on_cpu(*optimizers: torch.optim.Optimizer) -> bool:
    return all(t.device == CPU for o in optimizers for s in o.state.values() for t in s.values()
               if isinstance(t, torch.Tensor))


def test_sgan_makes_no_tensor_on_the_default_device():
    arrays = straight_tracks(8, 5, seed=1)
    groups = common.co_occurrence_groups(arrays)
    torch.manual_seed(0)
    model = SocialGan(dataclasses.replace(TINY_SGAN, clip_d=1.0), N_PAST, 5, CPU)  # clip_d: both clips run
    opt_g = torch.optim.Adam(model.generator.parameters(), lr=1e-3)
    opt_d = torch.optim.Adam(model.discriminator.parameters(), lr=1e-3)
    rng = checkpoints.seed_everything(0, CPU)
    batch = sgan_module.make_batch(arrays.past, arrays.future, groups, TINY_SGAN.coord_scale, CPU)
    model.train_step(batch, opt_g, opt_d, rng)  # Adam's lazily made `step` tensors, on the CPU
    with torch.device("meta"):
        order = common.group_batches(groups, 4, rng)
        batch = sgan_module.make_batch(arrays.past[order[0]], arrays.future[order[0]], groups[order[0]],
                                       TINY_SGAN.coord_scale, CPU)
        losses = model.train_step(batch, opt_g, opt_d, rng)
        rel = model.generator(batch.past_rel, batch.position, batch.pairs,
                              sgan_module.global_noise(batch, 2, TINY_SGAN.noise_dim, rng), 5)
        pred = model.predict(arrays, 3, seeded_generator(CPU, 1))
    assert rel.device == CPU and torch.isfinite(rel).all()
    assert np.isfinite(losses).all() and pred.shape == (8, 3, 5, 2) and np.isfinite(pred).all()
    assert all_on_cpu(model.generator, model.discriminator) and optimizer_on_cpu(opt_g, opt_d)


def test_pecnet_makes_no_tensor_on_the_default_device():
    arrays = straight_tracks(8, 5, seed=1)
    groups = common.co_occurrence_groups(arrays)
    torch.manual_seed(0)
    model = Pecnet(TINY_PECNET, N_PAST, 5, CPU)
    optimizer = torch.optim.Adam(model.net.parameters(), lr=1e-3)
    rng = checkpoints.seed_everything(0, CPU)
    batch = pecnet_module.make_batch(arrays.past, groups, TINY_PECNET, arrays.future, CPU)
    model.train_step(batch, optimizer, rng)  # Adam's lazily made `step` tensors, on the CPU
    with torch.device("meta"):
        order = common.group_batches(groups, 4, rng)
        batch = pecnet_module.make_batch(arrays.past[order[0]], groups[order[0]], TINY_PECNET,
                                         arrays.future[order[0]], CPU)
        losses = model.train_step(batch, optimizer, rng)
        endpoint, path, mu, _ = model.net(batch.past, batch.position, batch.mask, batch.endpoint)  # global RNG
        pred = model.predict(arrays, 3, seeded_generator(CPU, 1))
    assert all(t.device == CPU and torch.isfinite(t).all() for t in (endpoint, path, mu, batch.mask))
    assert np.isfinite(losses).all() and pred.shape == (8, 3, 5, 2) and np.isfinite(pred).all()
    assert all_on_cpu(model.net) and optimizer_on_cpu(optimizer)


def test_rollout_and_constant_velocity_make_no_tensor_on_the_default_device():
    arrays = straight_tracks(6, 7, seed=2)
    torch.manual_seed(0)
    rpecnet = RecurrentPecnet(Pecnet(TINY_PECNET, N_PAST, 3, CPU))
    with torch.device("meta"):
        rolled = rpecnet.predict(arrays, 2, seeded_generator(CPU, 0))
        constant = ConstantVelocity({}).predict(window_set(arrays, "train", with_future=False), 2,
                                                Path("."), 0)
    assert rolled.shape == constant.shape == (6, 2, 7, 2)
    assert np.isfinite(rolled).all() and np.isfinite(constant).all()
    np.testing.assert_allclose(constant, np.repeat(arrays.future[:, None], 2, axis=1), atol=1e-9)


# ---------------------------------------------------------------------------------------------
# Preemption: stop mid-epoch, resume, same weights


class CountingFit:
    """cls.fit on fixed synthetic windows with train_step wrapped: `steps` counts the optimiser
    steps of the last call (also when it raised), and on_step(n) runs after the n-th one."""

    def __init__(self, cls, config, monkeypatch):
        self.cls, self.config, self.monkeypatch, self.steps = cls, config, monkeypatch, 0
        self.train, self.val = straight_tracks(16, 5, seed=7), straight_tracks(4, 5, seed=8)

    def __call__(self, folder, on_step=None, **kwargs):
        original, self.steps = self.cls.train_step, 0

        def step(model, *args):
            out = original(model, *args)
            self.steps += 1
            if on_step is not None:
                on_step(self.steps)
            return out

        self.monkeypatch.setattr(self.cls, "train_step", step)
        try:
            return self.cls.fit(self.train, self.val, self.config, folder, seed=0, **kwargs)
        finally:
            self.monkeypatch.setattr(self.cls, "train_step", original)


def assert_same_run(a, b):
    assert a.fit_result.history == b.fit_result.history
    assert a.fit_result.best_epoch == b.fit_result.best_epoch
    for (name, x), y in zip(state_of(a).items(), state_of(b).values(), strict=True):
        assert torch.equal(x, y), name


@pytest.mark.parametrize("cls, config", [(SocialGan, dataclasses.replace(TINY_SGAN, epochs=3, batch_size=4)),
                                         (Pecnet, dataclasses.replace(TINY_PECNET, epochs=3))])
def test_sigterm_mid_epoch_then_resume_gives_the_same_weights(cls, config, tmp_path, monkeypatch):
    fit = CountingFit(cls, config, monkeypatch)
    straight = fit(tmp_path / "straight")
    steps = fit.steps
    per_epoch = steps // config.epochs
    assert per_epoch >= 3
    stop_after = per_epoch + 2  # epoch 2 (index 1): SIGTERM during its 2nd optimiser step

    def kill(n):
        if n == stop_after:
            os.kill(os.getpid(), signal.SIGTERM)

    with Preemption() as preemption, pytest.raises(StopRequested) as stopped:
        fit(tmp_path / "resumed", kill, preemption=preemption)
    assert stopped.value.exit_code == 143 and "epoch 1, batch 2" in stopped.value.reason
    assert fit.steps == stop_after  # the step in flight finished, no further one
    saved = checkpoints.load(tmp_path / "resumed" / common.LAST)
    assert saved["format"] == checkpoints.FORMAT and saved["epoch"] == 1 and len(saved["state"]["history"]) == 1
    partial = saved["position"]
    assert partial["epoch"] == 1 and partial["next_batch"] == 2 and len(partial["batches"]) == per_epoch
    assert partial["loss_sums"].dtype == torch.float64 and saved["state"]["rng_device"] == "cpu"

    resumed = fit(tmp_path / "resumed")
    assert fit.steps == steps - stop_after  # continued at exactly the next batch
    assert_same_run(straight, resumed)
    assert checkpoints.load(tmp_path / "resumed" / common.LAST)["position"] is None


def test_time_budget_stops_with_exit_code_75_and_resumes(tmp_path, monkeypatch):
    fit = CountingFit(Pecnet, dataclasses.replace(TINY_PECNET, epochs=2), monkeypatch)
    straight = fit(tmp_path / "straight")
    steps = fit.steps
    now = [1000.0]

    def tick(n):  # each optimiser step takes 10 s of the fake clock
        now[0] += 10.0

    budget = Preemption(max_minutes=0.5, clock=lambda: now[0])  # 30 s: stops after the 3rd step
    with budget, pytest.raises(StopRequested) as stopped:
        fit(tmp_path / "resumed", tick, preemption=budget)
    assert stopped.value.exit_code == EXIT_BUDGET == 75 and "max_minutes" in stopped.value.reason
    assert fit.steps == 3 < steps
    assert checkpoints.load(tmp_path / "resumed" / common.LAST)["position"]["next_batch"] == 3
    resumed = fit(tmp_path / "resumed")
    assert fit.steps == steps - 3
    assert_same_run(straight, resumed)


def test_stage_exits_143_on_sigterm_and_resumes(tmp_path, monkeypatch):
    """train_baseline.main: the signal becomes SystemExit(143) with no metrics written; the next
    call resumes and writes them, with the device it ran on."""
    monkeypatch.chdir(tmp_path)
    window_table(straight_tracks(12, 5, seed=5), ["train"] * 8 + ["val"] * 4).to_parquet("tf5.parquet")
    params = {"profile": "cpu", "windows": {"n_past": N_PAST}, "train_baseline": {"seed": 0, "threads": 1},
              "runtime": {"device": "cpu", "max_minutes": 0},
              "pecnet": {"cpu": dataclasses.asdict(TINY_PECNET), "paper": dataclasses.asdict(TINY_PECNET)}}
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    argv = ["--model", "pecnet", "--horizon", "5", "--table", "tf5.parquet", "--checkpoint-dir", "ck",
            "--metrics", "train.json"]
    original, calls = Pecnet.train_step, [0]

    def step(self, *args):
        out = original(self, *args)
        calls[0] += 1
        if calls[0] == 2:
            os.kill(os.getpid(), signal.SIGTERM)
        return out

    monkeypatch.setattr(Pecnet, "train_step", step)
    handler = signal.getsignal(signal.SIGTERM)
    with pytest.raises(SystemExit) as stopped:
        train_baseline.main(argv)
    assert stopped.value.code == 143 and not (tmp_path / "train.json").exists()
    assert signal.getsignal(signal.SIGTERM) == handler  # the stage's handler is gone again
    assert checkpoints.load(tmp_path / "ck" / common.LAST)["position"]["next_batch"] == 2
    monkeypatch.setattr(Pecnet, "train_step", original)
    train_baseline.main(argv)
    facts = json.loads((tmp_path / "train.json").read_text())
    assert facts["epochs"] == 2 and facts["device"].startswith("cpu")


def as_format_2(saved: dict) -> dict:
    """A `last.pt` in the layout `run_training` wrote before the shared checkpoint scheme (format 2:
    everything at the top level, `epoch` the 0-based index of the last finished one, `partial`)."""
    state = saved["state"]
    return {"format": 2, "config": state["config"], "meta": state["meta"], "epoch": saved["epoch"] - 1,
            "data_fingerprint": saved["identity"]["data_fingerprint"], "best_epoch": state["best_epoch"],
            "best_val": state["best_val"], "history": state["history"],
            "train_seconds": state["train_seconds"], "modules": state["modules"],
            "optimizers": state["optimizers"], "rng": state["rng"], "rng_device": state["rng_device"],
            "partial": saved["position"]}


def test_older_layouts_start_afresh_and_other_device_checkpoints_resume(tmp_path, monkeypatch, capsys):
    """A format-1 / format-2 last.pt (before the shared scheme) is refused: training starts afresh
    and ends as a straight run. One whose generator state was written on another kind of device
    carries the weights over with a re-seeded generator."""
    fit = CountingFit(Pecnet, dataclasses.replace(TINY_PECNET, epochs=3), monkeypatch)
    straight = fit(tmp_path / "straight")
    two = CountingFit(Pecnet, dataclasses.replace(TINY_PECNET, epochs=2), monkeypatch)
    format_1 = lambda s: {**{k: v for k, v in as_format_2(s).items() if k not in ("partial", "rng_device")},
                          "format": 1}
    for folder, edit in [("format1", format_1), ("format2", as_format_2),
                         ("other_device", lambda s: {**s, "state": {**s["state"], "rng_device": "cuda"}})]:
        two(tmp_path / folder)
        last = tmp_path / folder / common.LAST
        original = checkpoints.load(last)
        torch.save(edit(original), last)
        capsys.readouterr()
        resumed = fit(tmp_path / folder)
        if folder != "other_device":
            assert fit.steps == 3 * (two.steps // 2)  # afresh
            assert "starting afresh" in capsys.readouterr().out
            assert_same_run(straight, resumed)
        else:
            assert fit.steps == two.steps // 2  # one more epoch, not a fresh start
            assert resumed.fit_result.history[:2] == straight.fit_result.history[:2]
            assert len(resumed.fit_result.history) == 3 and np.isfinite(resumed.fit_result.history[2]["val_ade"])