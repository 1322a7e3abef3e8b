"""Segmentation: Dice loss and IoU on known inputs, the U-Net overfitting one image, training resume,
and stage `semantic_maps` on a tiny fixture (labels and predicted sources)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from pipeline.data.labels import import_labels
from pipeline.config.labels import LabelsParams
from pipeline.config.loading import ParamsError, load_profile, load_section, read_params
from pipeline.config.segmentation import SegmentationParams
from pipeline.config.semantic import SemanticParams
from pipeline import checkpoints
from pipeline.runners.segmentation import downsample_pair, encoder_parameters, export_model, finetune, fingerprint, learning_rate, load_model, pad_to_multiple, scaled_size, train
from pipeline.data.semantic_maps import dequantise, iou_from_confusion, iou_summary, load_semantic_maps, one_hot_map, predicted_labels, quantise
from pipeline.runners.semantic_maps import build_maps, predict_map, predict_probabilities
from ynet.segmentation import (
    N_OUTPUTS,
    PAD_CLASS,
    UNet,
    UNetConfig,
    confusion_matrix,
    dice_loss,
)

torch.set_num_threads(1)
TINY = dict(base_channels=4, depth=2, epochs=2, crops_per_image=2, lr_drop_epoch=1, bf16=False,
            crop=32, pad_multiple=32, downsample=2, lr=1e-3)


def logits_of(probs: list) -> torch.Tensor:
    """Logits whose softmax over dim 1 is `probs` (C, H, W) -> (1, C, H, W)."""
    return torch.tensor(probs, dtype=torch.float64).log()[None]


def test_dice_loss_known_value():
    # 3 classes on a 1x2 image; target = [0, 1], class 2 absent (left out of the mean).
    logits = logits_of([[[0.7, 0.2]], [[0.2, 0.7]], [[0.1, 0.1]]])
    target = torch.tensor([[[0, 1]]])
    # class 0: 2 * 0.7 / ((0.7 + 0.2) + 1) ; class 1 the same.
    expected = 1 - (2 * 0.7) / 1.9
    torch.testing.assert_close(dice_loss(logits, target, eps=0.0),
                               torch.tensor(expected, dtype=torch.float64))


def test_dice_loss_two_classes_unequal():
    logits = logits_of([[[0.8, 0.3]], [[0.2, 0.7]]])
    target = torch.tensor([[[0, 1]]])
    expected = 1 - (1.6 / 2.1 + 1.4 / 1.9) / 2
    torch.testing.assert_close(dice_loss(logits, target, eps=0.0),
                               torch.tensor(expected, dtype=torch.float64))


def test_dice_loss_perfect_and_wrong():
    target = torch.randint(0, 3, (2, 8, 8))
    onehot = torch.nn.functional.one_hot(target, 3).permute(0, 3, 1, 2).double()
    assert dice_loss(onehot * 50, target) < 1e-6
    assert dice_loss(onehot.roll(1, dims=1) * 50, target) > 1 - 1e-6


def test_confusion_and_iou():
    target = torch.tensor([1, 1, 2, 2, 3])
    pred = torch.tensor([1, 2, 2, 2, 1])
    confusion = confusion_matrix(pred, target, 4)
    assert confusion[1, 2] == 1 and confusion[2, 2] == 2 and confusion[3, 1] == 1
    iou = iou_from_confusion(confusion.numpy())
    assert math.isnan(iou[0])  # absent everywhere
    np.testing.assert_allclose(iou[1:], [1 / 3, 2 / 3, 0.0])
    summary = iou_summary(confusion_matrix(pred, target, N_OUTPUTS).numpy())
    assert summary["iou"]["pavement"] == round(1 / 3, 4) and summary["iou"]["tree"] is None
    assert summary["miou"] == round((1 / 3 + 2 / 3 + 0) / 3, 4)
    assert summary["pixel_accuracy"] == 0.6


def test_unet_shapes():
    model = UNet(UNetConfig(base_channels=4, depth=3))
    assert model(torch.rand(2, 3, 32, 48)).shape == (2, N_OUTPUTS, 32, 48)
    with pytest.raises(ValueError, match="multiples of 8"):
        model(torch.rand(1, 3, 30, 48))


def synthetic_scene(size: int = 64, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Textured scene: image (size, size, 3) uint8 BGR and labels (size, size) in 1..5."""
    rng = np.random.default_rng(seed)
    labels = np.ones((size, size), np.uint8)
    labels[: size // 2, size // 3:] = 2
    labels[size // 2:, : size // 2] = 3
    cv2.circle(labels, (3 * size // 4, 3 * size // 4), size // 6, 5, -1)
    labels[size // 8: size // 4, : size // 4] = 4
    colours = np.array([(0, 0, 0), (200, 200, 200), (90, 60, 60), (40, 40, 200), (120, 180, 200),
                        (40, 150, 40)], np.uint8)
    image = colours[labels].astype(np.int16) + rng.integers(-20, 20, (size, size, 3))
    return np.clip(image, 0, 255).astype(np.uint8), labels


def test_tiny_unet_overfits_one_image():
    torch.manual_seed(0)
    image, labels = synthetic_scene(32)
    x = torch.from_numpy(image).permute(2, 0, 1)[None].float() / 255  # (1, 3, 32, 32)
    y = torch.from_numpy(labels).long()[None]  # (1, 32, 32)
    model = UNet(UNetConfig(base_channels=8, depth=2))
    optimiser = torch.optim.Adam(model.parameters(), lr=1e-2)
    for _ in range(150):
        loss = dice_loss(model(x), y)
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
    model.eval()
    with torch.no_grad():
        pred = model(x).argmax(1)
    assert loss.item() < 0.1
    assert (pred == y).float().mean() > 0.97


def tiny_params(**changes) -> SegmentationParams:
    return dataclasses.replace(SegmentationParams(**TINY), **changes)


def tiny_scenes() -> list[tuple[np.ndarray, np.ndarray]]:
    scenes = []
    for seed in (0, 1):
        image, labels = synthetic_scene(60, seed)
        image, labels = downsample_pair(image, labels, 2)
        scenes.append((pad_to_multiple(image, 32), pad_to_multiple(labels, 32, PAD_CLASS)))
    return scenes


def weights(parameters) -> list[torch.Tensor]:
    return [p.detach().clone() for p in parameters]


def test_finetune_freezes_the_encoder_for_the_first_epochs():
    """Frozen epochs leave the encoder's weights and BatchNorm statistics as they were and train
    the decoder; after them the encoder trains too, and every parameter takes gradients again."""
    torch.manual_seed(0)
    model = UNet(UNetConfig(base_channels=4, depth=2))
    encoder = {id(p) for p in encoder_parameters(model)}
    decoder = [p for p in model.parameters() if id(p) not in encoder]
    encoder_before, decoder_before = weights(encoder_parameters(model)), weights(decoder)
    encoder_buffers = weights([*model.stem.buffers(), *model.downs.buffers()])
    log = finetune(model, tiny_scenes(), tiny_params(epochs=1), freeze_epochs=1)
    assert [row["encoder_frozen"] for row in log] == [True]
    assert all(torch.equal(a, b) for a, b in zip(encoder_before, encoder_parameters(model)))
    assert all(torch.equal(a, b) for a, b in zip(encoder_buffers, [*model.stem.buffers(),
                                                                   *model.downs.buffers()]))
    assert any(not torch.equal(a, b) for a, b in zip(decoder_before, decoder))

    torch.manual_seed(0)
    model = UNet(UNetConfig(base_channels=4, depth=2))
    log = finetune(model, tiny_scenes(), tiny_params(epochs=2), freeze_epochs=1)
    assert [row["encoder_frozen"] for row in log] == [True, False]
    assert any(not torch.equal(a, b) for a, b in zip(encoder_before, encoder_parameters(model)))
    assert all(p.requires_grad for p in model.parameters()) and not model.training


def test_predict_map_sees_the_downsampled_image_and_returns_the_asked_size():
    torch.manual_seed(0)
    model = UNet(UNetConfig(base_channels=4, depth=2)).eval()
    image, _ = synthetic_scene(60)
    probs = predict_map(model, image, 2, 32, (45, 45))
    assert probs.shape == (N_OUTPUTS, 45, 45) and probs.dtype == np.float32
    np.testing.assert_allclose(probs.sum(axis=0), 1, atol=1e-4)
    same_size = predict_map(model, image, 2, 32, (30, 30))  # the U-Net's own output, unresized
    small = cv2.resize(image, (30, 30), interpolation=cv2.INTER_AREA)
    np.testing.assert_allclose(same_size, predict_probabilities(model, small, 32), atol=1e-6)


def test_resume_after_interruption_equals_uninterrupted_run(tmp_path):
    params, scenes = tiny_params(), tiny_scenes()
    run_id = fingerprint(params, ["a", "b"], scenes)
    straight, log = train(scenes, params, tmp_path / "a.pt", run_id, progress=False)
    train(scenes, params, tmp_path / "b.pt", run_id, stop_after=1, progress=False)  # "killed"
    assert len(checkpoints.read(tmp_path / "b.pt").state["log"]) == 1
    resumed, resumed_log = train(scenes, params, tmp_path / "b.pt", run_id, progress=False)
    assert [r["loss"] for r in resumed_log] == [r["loss"] for r in log]
    for (name, a), b in zip(straight.state_dict().items(), resumed.state_dict().values()):
        torch.testing.assert_close(a, b, rtol=0, atol=0, msg=name)


def test_checkpoint_of_another_run_is_not_resumed(tmp_path):
    params, scenes = tiny_params(epochs=1), tiny_scenes()
    train(scenes, params, tmp_path / "c.pt", fingerprint(params, ["a", "b"], scenes), progress=False)
    changed = tiny_params(epochs=1, lr=5e-4)
    other_id = fingerprint(changed, ["a", "b"], scenes)
    assert other_id != fingerprint(params, ["a", "b"], scenes)
    _, log = train(scenes, changed, tmp_path / "c.pt", other_id, progress=False)
    assert len(log) == 1 and log[0]["lr"] == 5e-4  # trained afresh, not "already done"


def test_learning_rate_schedule():
    params = tiny_params(epochs=10, lr_drop_epoch=6, lr=1e-4)
    assert [learning_rate(params, e) for e in (0, 5, 6, 9)] == pytest.approx([1e-4, 1e-4, 1e-5, 1e-5])


def test_downsample_and_pad():
    image = np.zeros((1973, 1325, 3), np.uint8)
    assert scaled_size(1973, 1325, 0.25) == cv2.resize(image, None, fx=0.25, fy=0.25).shape[:2]
    small, labels = downsample_pair(image, np.full((1973, 1325), 3, np.uint8), 4)
    assert small.shape == (493, 331, 3) and set(np.unique(labels)) == {3}
    padded = pad_to_multiple(labels, 32, PAD_CLASS)
    assert padded.shape == (512, 352) and (padded[493:] == PAD_CLASS).all()


def test_segmentation_params_profiles_and_checks():
    section = {"cpu": {**TINY}, "paper": {**TINY, "epochs": 2000}}
    assert load_profile(SegmentationParams, "segmentation",
                        {"profile": "paper", "segmentation": section}).epochs == 2000
    with pytest.raises(ParamsError, match="unknown key"):
        load_profile(SegmentationParams, "segmentation",
                     {"profile": "cpu", "segmentation": {"cpu": {**TINY, "epoch": 3}}})
    with pytest.raises(ParamsError, match="divisible by 2\\*\\*depth"):
        load_profile(SegmentationParams, "segmentation",
                     {"profile": "cpu", "segmentation": {"cpu": {**TINY, "depth": 6}}})
    with pytest.raises(ParamsError, match="source"):
        load_section(SemanticParams, "semantic", {"semantic": {"source": "oracle"}})


def test_params_yaml_sections_validate():
    path = Path(__file__).parents[1] / "params.yaml"
    params = read_params(path)
    for profile in params["segmentation"]:
        load_profile(SegmentationParams, "segmentation", {**params, "profile": profile})
    load_section(SemanticParams, "semantic", params)


def test_quantised_maps_round_trip():
    probs = torch.rand(N_OUTPUTS, 5, 7).softmax(0).numpy()
    stored = quantise(probs)
    assert stored.dtype == np.uint8
    back = dequantise(stored)
    np.testing.assert_allclose(back, probs, atol=3 / 255)
    np.testing.assert_allclose(back.sum(0), 1, atol=1e-5)
    onehot = one_hot_map(np.array([[1, 5], [0, 3]], np.uint8))
    assert onehot.shape == (N_OUTPUTS, 2, 2) and (onehot.sum(0) == 1).all() and onehot[5, 0, 1] == 1
    np.testing.assert_array_equal(dequantise(quantise(onehot)), onehot)


def test_padding_channel_never_wins_inside_an_image():
    probs = np.zeros((N_OUTPUTS, 1, 2), np.float32)
    probs[PAD_CLASS] = 0.9
    probs[2, 0, 0], probs[4, 0, 1] = 0.1, 0.1
    np.testing.assert_array_equal(predicted_labels(probs), [[2, 4]])


def write_scene_fixture(root: Path) -> tuple[Path, Path]:
    """SDD + release roots with one train video (gates_1) and one test video (gates_2)."""
    sdd, release = root / "sdd", root / "release"
    for name, folder, seed in (("gates_1", "train_masks", 0), ("gates_2", "test_masks", 1)):
        image, labels = synthetic_scene(64, seed)
        video_dir = sdd / "annotations" / "gates" / f"video{name[-1]}"
        video_dir.mkdir(parents=True)
        cv2.imwrite(str(video_dir / "reference.jpg"), image)
        mask_dir = release / "data/SDD_semantic_maps" / folder
        mask_dir.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(mask_dir / f"{name}_mask.png"), labels)
    return sdd, release


@pytest.mark.parametrize("source", ["labels", "predicted"])
def test_semantic_maps_stage_on_fixture(tmp_path, source):
    sdd, release = write_scene_fixture(tmp_path)
    labels_dir = tmp_path / "labels"
    import_labels(sdd, release, labels_dir, tmp_path / "overlays", LabelsParams())
    model_path = tmp_path / "model.pt"
    model = UNet(UNetConfig(base_channels=4, depth=2))
    export_model(model_path, model, tiny_params(), "cpu", ["gates_1"],
                 [{"epoch": 1, "loss": 0.5, "lr": 1e-3, "crops": 4, "seconds": 0.1}])
    params = SemanticParams(source=source, resize=0.25)
    metrics = build_maps(sdd, labels_dir, model_path, tmp_path / "maps", tmp_path / "m.json",
                         tmp_path / "figures", params)
    maps = load_semantic_maps(tmp_path / "maps")
    assert sorted(maps) == ["gates_1", "gates_2"]
    assert maps["gates_2"].shape == (N_OUTPUTS, 16, 16) and maps["gates_2"].dtype == np.float32
    np.testing.assert_allclose(maps["gates_2"].sum(0), 1, atol=1e-5)
    assert json.loads((tmp_path / "m.json").read_text()) == metrics
    assert metrics["test_videos"] == 1 and sorted(metrics["iou"]) == [
        "pavement", "road", "structure", "terrain", "tree"]
    assert [p.name for p in (tmp_path / "figures").iterdir()] == ["gates_2.png"]
    if source == "labels":
        assert metrics["miou"] == 1.0 and "training" not in metrics
    else:
        assert metrics["training"]["pretrained"] is False
    index = json.loads((tmp_path / "maps" / "index.json").read_text())
    assert index["source"] == source and index["videos"]["gates_1"]["split"] == "train"


def test_exported_model_loads_without_pickled_modules(tmp_path):
    model = UNet(UNetConfig(base_channels=4, depth=2))
    export_model(tmp_path / "m.pt", model, tiny_params(), "cpu", ["x"], [])
    loaded, meta = load_model(tmp_path / "m.pt")  # torch.load(weights_only=True) inside
    assert meta["unet"] == dataclasses.asdict(model.cfg) and meta["downsample"] == 2
    x = torch.rand(1, 3, 32, 32)
    model.eval()
    torch.testing.assert_close(loaded(x), model(x))
