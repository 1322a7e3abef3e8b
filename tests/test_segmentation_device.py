"""Segmentation on a `runtime.device`: no tensor made on a hard-coded device, and training that
survives SIGTERM and a time budget mid-epoch, resuming to the very same weights."""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml

import pipeline.runners.segmentation as segmentation
from pipeline.stages import segmentation as segmentation_stage
from pipeline.stages import semantic_maps as semantic_maps_stage
from pipeline.config.labels import LabelsParams
from pipeline.data.labels import import_labels
from pipeline.io import save_torch
from pipeline.preemption import EXIT_BUDGET, Preemption, StopRequested
from pipeline import checkpoints
from pipeline.runners.segmentation import (
    epoch_batches,
    export_model,
    fingerprint,
    load_model,
    train,
    train_step,
    unet_config,
)
from pipeline.data.semantic_maps import (iou_from_confusion, iou_summary, load_semantic_maps,
                                         predicted_labels)
from pipeline.runners.semantic_maps import predict_probabilities
from tests.test_segmentation import synthetic_scene, tiny_params, tiny_scenes, write_scene_fixture
from ynet.segmentation import N_OUTPUTS, UNet, confusion_matrix, dice_loss

torch.set_num_threads(1)


def small_run(bf16: bool = False):
    """3 epochs of 4 single-crop steps on two tiny scenes (about a second)."""
    params = tiny_params(epochs=3, lr_drop_epoch=2, batch_size=1, bf16=bf16)
    scenes = tiny_scenes()
    return params, scenes, fingerprint(params, ["a", "b"], scenes)


def assert_same_weights(a: torch.nn.Module, b: torch.nn.Module) -> None:
    sa, sb = a.state_dict(), b.state_dict()
    assert sa.keys() == sb.keys()
    for name in sa:
        assert torch.equal(sa[name], sb[name]), name


@pytest.mark.parametrize("bf16", [False, True])
@pytest.mark.usefixtures("cpu_bf16_hardware")
def test_no_hard_coded_device_in_training_step_and_inference(bf16):
    params = tiny_params(bf16=bf16)
    torch.manual_seed(0)
    model = UNet(unet_config(params))
    if bf16:
        model = model.to(memory_format=torch.channels_last)
    optimiser = torch.optim.Adam(model.parameters(), lr=params.lr)
    batches = epoch_batches(tiny_scenes(), params, epoch=0)
    train_step(model, optimiser, *next(batches), bf16)  # Adam's lazy `step` tensors: outside
    images, labels = next(epoch_batches(tiny_scenes(), params, epoch=1))
    image, truth = synthetic_scene(40)
    # Every factory call without device= now makes a meta tensor; mixing it with CPU ones fails.
    with torch.device("meta"):
        loss = train_step(model, optimiser, images, labels, bf16)
        model.eval()
        probs = predict_probabilities(model, image, 32)  # what semantic_maps does per image
        model.train()
        confusion = confusion_matrix(torch.from_numpy(predicted_labels(probs)),
                                     torch.from_numpy(truth), N_OUTPUTS)
        iou = iou_from_confusion(confusion.numpy())  # numpy: no device to go astray
        summary = iou_summary(confusion.numpy())
        direct = dice_loss(torch.randn(2, N_OUTPUTS, 8, 8, device="cpu"),
                           torch.randint(0, N_OUTPUTS, (2, 8, 8), device="cpu"))
    assert np.isfinite(loss)
    assert probs.shape == (N_OUTPUTS, 40, 40) and np.isfinite(probs).all()
    np.testing.assert_allclose(probs.sum(0), 1, atol=1e-5)
    assert iou.shape == (N_OUTPUTS,) and summary["miou"] is not None
    assert direct.device.type == "cpu" and torch.isfinite(direct)
    for name, p in model.state_dict().items():
        assert p.device.type == "cpu" and torch.isfinite(p.float()).all(), name
    for state in optimiser.state.values():
        assert all(v.device.type == "cpu" for v in state.values())


def stop_at(monkeypatch, at_step: int, action) -> list[int]:
    """Run `action()` right after the `at_step`-th optimiser step (1-based) of the whole run."""
    count = [0]
    real = segmentation.step_loss

    def counting(*args, **kwargs):
        loss = real(*args, **kwargs)
        count[0] += 1
        if count[0] == at_step:
            action()
        return loss

    monkeypatch.setattr(segmentation, "step_loss", counting)
    return count


@pytest.mark.parametrize("bf16", [False, True])
@pytest.mark.usefixtures("cpu_bf16_hardware")
def test_sigterm_mid_epoch_then_resume_gives_the_same_weights(tmp_path, monkeypatch, bf16):
    params, scenes, run_id = small_run(bf16)
    straight, log = train(scenes, params, tmp_path / "a.pt", run_id, progress=False)

    # 4 steps per epoch: the 6th step is the 2nd of epoch 2; the signal arrives during it.
    stop_at(monkeypatch, 6, lambda: os.kill(os.getpid(), signal.SIGTERM))
    with Preemption() as preemption, pytest.raises(StopRequested) as stopped:
        train(scenes, params, tmp_path / "b.pt", run_id, progress=False, preemption=preemption)
    assert stopped.value.exit_code == 143 and "SIGTERM" in stopped.value.reason
    assert "epoch 2, step 2" in stopped.value.reason
    saved = checkpoints.load(tmp_path / "b.pt")
    assert saved["format"] == checkpoints.FORMAT and len(saved["state"]["log"]) == saved["epoch"] == 1
    position = saved["position"]
    assert (position["epoch"], position["step"], position["crops"]) == (1, 2, 2)
    assert len(position["losses"]) == 2 and set(saved["state"]["rng"]) == {"torch"}
    monkeypatch.undo()

    resumed, resumed_log = train(scenes, params, tmp_path / "b.pt", run_id, progress=False)
    assert [r["loss"] for r in resumed_log] == [r["loss"] for r in log]
    assert [r["crops"] for r in resumed_log] == [r["crops"] for r in log]
    assert_same_weights(straight, resumed)
    assert checkpoints.load(tmp_path / "b.pt")["position"] is None  # ended at an epoch boundary


def test_time_budget_stops_with_exit_75_and_resumes(tmp_path, monkeypatch):
    params, scenes, run_id = small_run()
    straight, log = train(scenes, params, tmp_path / "a.pt", run_id, progress=False)
    now = [0.0]
    real = segmentation.step_loss

    def ticking(*args, **kwargs):  # 30 s of fake time per step: 1 minute = 2 steps
        now[0] += 30.0
        return real(*args, **kwargs)

    monkeypatch.setattr(segmentation, "step_loss", ticking)
    with Preemption(max_minutes=1, clock=lambda: now[0]) as budget, \
            pytest.raises(StopRequested) as stopped:
        train(scenes, params, tmp_path / "b.pt", run_id, progress=False, preemption=budget)
    assert stopped.value.exit_code == EXIT_BUDGET == 75 and "max_minutes" in stopped.value.reason
    position = checkpoints.load(tmp_path / "b.pt")["position"]
    assert (position["epoch"], position["step"]) == (0, 2)
    monkeypatch.undo()

    # Resumed twice more under fresh budgets (each a new invocation), then to the end.
    for _ in range(2):
        now[0] = 0.0
        monkeypatch.setattr(segmentation, "step_loss", ticking)
        with Preemption(max_minutes=1, clock=lambda: now[0]) as budget, \
                pytest.raises(StopRequested):
            train(scenes, params, tmp_path / "b.pt", run_id, progress=False, preemption=budget)
        monkeypatch.undo()
    position = checkpoints.load(tmp_path / "b.pt")["position"]
    assert (position["epoch"], position["step"]) == (1, 2)
    resumed, resumed_log = train(scenes, params, tmp_path / "b.pt", run_id, progress=False)
    assert [r["loss"] for r in resumed_log] == [r["loss"] for r in log]
    assert_same_weights(straight, resumed)


def test_stop_before_an_epochs_first_step_resumes_there(tmp_path, monkeypatch):
    params, scenes, run_id = small_run()
    straight, _ = train(scenes, params, tmp_path / "a.pt", run_id, progress=False)
    stop_at(monkeypatch, 4, lambda: os.kill(os.getpid(), signal.SIGINT))  # last step of epoch 1
    with Preemption() as preemption, pytest.raises(StopRequested) as stopped:
        train(scenes, params, tmp_path / "b.pt", run_id, progress=False, preemption=preemption)
    assert stopped.value.exit_code == 130
    saved = checkpoints.load(tmp_path / "b.pt")
    position = saved["position"]
    assert len(saved["state"]["log"]) == 1 and (position["epoch"], position["step"]) == (1, 0)
    monkeypatch.undo()
    resumed, _ = train(scenes, params, tmp_path / "b.pt", run_id, progress=False)
    assert_same_weights(straight, resumed)


def test_checkpoint_of_an_unknown_format_starts_afresh(tmp_path, capsys):
    params, scenes = tiny_params(epochs=1, batch_size=1), tiny_scenes()
    run_id = fingerprint(params, ["a", "b"], scenes)
    save_torch(in_memory=True, path=tmp_path / "c.pt",
               payload={"format": 99, "fingerprint": run_id, "log": [{"epoch": 1}]})
    _, log = train(scenes, params, tmp_path / "c.pt", run_id)
    out = capsys.readouterr().out
    assert "checkpoint format 99" in out and "starting afresh" in out
    assert len(log) == 1 and log[0]["crops"] == 4


def test_checkpoint_written_elsewhere_loads_on_the_cpu(tmp_path):
    """Checkpoints and exports load with map_location='cpu' (as a CUDA-written one must)."""
    params, scenes, run_id = small_run()
    model, log = train(scenes, params, tmp_path / "a.pt", run_id, stop_after=1, progress=False)
    export_model(tmp_path / "m.pt", model, params, "cpu", ["a", "b"], log)
    loaded, meta = load_model(tmp_path / "m.pt", torch.device("cpu"))
    assert meta["format"] == 1 and all(p.device.type == "cpu" for p in loaded.parameters())
    assert_same_weights(model, loaded)


def stage_args(tmp_path: Path, monkeypatch, name: str, max_minutes: float) -> Path:
    """Stage `segmentation` on the two-video fixture of test_segmentation, run from `tmp_path`."""
    if not (tmp_path / "labels").exists():
        sdd, release = write_scene_fixture(tmp_path)
        import_labels(sdd, release, tmp_path / "labels", tmp_path / "overlays", LabelsParams())
    stage = dict(tiny_params(epochs=2, lr_drop_epoch=1, crops_per_image=3, batch_size=1).__dict__)
    stage.pop("augment")
    (tmp_path / "params.yaml").write_text(yaml.safe_dump({
        "profile": "cpu", "segmentation": {"cpu": stage},
        "runtime": {"device": "cpu", "max_minutes": max_minutes}}))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [
        "segmentation", "--sdd", "sdd", "--labels", "labels", "--checkpoint", f"{name}.ckpt",
        "--model", f"{name}.pt", "--log", f"{name}.csv"])
    return tmp_path / f"{name}.pt"


def test_stage_main_stops_on_its_budget_with_exit_75_and_resumes_to_the_same_model(
        tmp_path, monkeypatch, capsys):
    straight = stage_args(tmp_path, monkeypatch, "straight", 0)
    segmentation_stage.main()
    pieces = stage_args(tmp_path, monkeypatch, "pieces", 1e-9)  # stops after every step
    stops = 0
    while True:
        try:
            segmentation_stage.main()
            break
        except SystemExit as stop:
            assert stop.code == EXIT_BUDGET
            stops += 1
            assert stops < 10
    assert stops == 5  # 2 epochs x 3 steps, one step per call
    assert "stopped early" in capsys.readouterr().err
    a, _ = load_model(straight)
    b, _ = load_model(pieces)
    assert_same_weights(a, b)
    def losses(name: str) -> list[str]:
        return [line.split(",")[1] for line in (tmp_path / name).read_text().splitlines()]

    assert losses("straight.csv") == losses("pieces.csv")


def test_stage_main_exits_143_on_sigterm_and_resumes_to_the_same_model(tmp_path, monkeypatch):
    straight = stage_args(tmp_path, monkeypatch, "straight", 0)
    segmentation_stage.main()
    killed = stage_args(tmp_path, monkeypatch, "killed", 0)
    real_step, handler = segmentation.step_loss, signal.getsignal(signal.SIGTERM)
    stop_at(monkeypatch, 4, lambda: os.kill(os.getpid(), signal.SIGTERM))  # 1st step of epoch 2
    with pytest.raises(SystemExit) as stopped:
        segmentation_stage.main()
    assert stopped.value.code == 143 and signal.getsignal(signal.SIGTERM) == handler
    position = checkpoints.load(tmp_path / "killed.ckpt")["position"]
    assert (position["epoch"], position["step"]) == (1, 1) and not killed.exists()
    monkeypatch.setattr(segmentation, "step_loss", real_step)
    segmentation_stage.main()
    a, _ = load_model(straight)
    b, _ = load_model(killed)
    assert_same_weights(a, b)


def test_semantic_maps_main_reads_the_runtime_section(tmp_path, monkeypatch, capsys):
    stage_args(tmp_path, monkeypatch, "unused", 0)  # fixture, labels, cwd
    params = tiny_params()
    export_model(tmp_path / "model.pt", UNet(unet_config(params)), params, "cpu", ["gates_1"],
                 [{"epoch": 1, "loss": 0.5, "lr": 1e-3, "crops": 4, "seconds": 0.1}])
    (tmp_path / "params.yaml").write_text(yaml.safe_dump({
        "semantic": {"source": "predicted", "resize": 0.25},
        "runtime": {"device": "cpu", "max_minutes": 0}}))
    monkeypatch.setattr(sys, "argv", [
        "semantic_maps", "--sdd", "sdd", "--labels", "labels", "--model", "model.pt",
        "--out", "maps", "--metrics", "m.json", "--figures", "figures"])
    semantic_maps_stage.main()
    assert "on cpu (" in capsys.readouterr().out
    maps = load_semantic_maps(tmp_path / "maps")
    assert sorted(maps) == ["gates_1", "gates_2"] and maps["gates_1"].shape == (N_OUTPUTS, 16, 16)
