import numpy as np
import pytest
import torch

from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import (SceneWindows, agent_crops, augment, cropped_training_batch,
                                     group_by_scene, model_input, padded_semantic, training_batch,
                                     window_inputs)
from pipeline.config.ynet import AUGMENTATIONS


def scene_with_marker(x: int, y: int, height: int = 5, width: int = 7) -> SceneWindows:
    semantic = torch.zeros(2, height, width)
    semantic[0, y, x] = 1.0
    point = torch.tensor([[[float(x), float(y)]]])  # (1, 1, 2)
    return SceneWindows("s", semantic, past=point, future=point.clone(), index=np.array([0]))


@pytest.mark.parametrize("turns, flip", AUGMENTATIONS)
def test_augmentation_moves_map_and_points_together(turns, flip):
    scene = augment(scene_with_marker(x=5, y=1), turns, flip)
    row, col = np.argwhere(scene.semantic[0].numpy() == 1.0)[0]
    assert scene.past[0, 0].tolist() == [col, row]
    assert scene.future[0, 0].tolist() == [col, row]
    expected_shape = (5, 7) if turns % 2 == 0 else (7, 5)
    assert tuple(scene.semantic.shape[-2:]) == expected_shape


def test_augmentations_are_distinct():
    positions = {tuple(augment(scene_with_marker(5, 1), t, f).past[0, 0].tolist()) + (t % 2,)
                 for t, f in AUGMENTATIONS}
    assert len(positions) == 8


def test_group_by_scene_resizes_maps_and_coordinates():
    arrays = WindowArrays(
        past=np.full((3, 2, 2), 40.0), future=np.full((3, 3, 2), 80.0), window_id=np.arange(3),
        scene_id=np.array(["b", "a", "b"]), track_id=np.arange(3), first_frame=np.zeros(3),
        split=np.array(["train"] * 3))
    maps = {"a": np.ones((2, 10, 20), np.float32) / 2, "b": np.ones((2, 30, 40), np.float32) / 2}
    scenes = group_by_scene(arrays, maps, {"a": (40, 80), "b": (120, 160)}, resize=0.25)
    assert [s.scene_id for s in scenes] == ["a", "b"]
    assert scenes[1].index.tolist() == [0, 2]
    assert tuple(scenes[1].semantic.shape) == (2, 30, 40)
    torch.testing.assert_close(scenes[0].semantic.sum(0), torch.ones(10, 20))
    assert scenes[1].past[0, 0].tolist() == [10.0, 10.0]


def test_padding_class_fills_padded_pixels_and_batch_shapes():
    semantic = torch.zeros(3, 40, 50)
    semantic[0] = 1.0
    padded = padded_semantic(semantic, padding_class=2)
    assert tuple(padded.shape) == (3, 64, 64)
    assert padded[2, :40, :50].sum() == 0 and padded[2, 40:, :].min() == 1.0
    past = torch.tensor([[[10.0, 10.0], [12.0, 11.0]]])
    future = torch.tensor([[[14.0, 12.0], [16.0, 13.0], [18.0, 14.0]]])
    batch = training_batch(padded, past, future, waypoints=(1, 2), max_distance=None,
                           kernel_size=31, sigma=4.0)
    assert tuple(batch.inputs.shape) == (1, 5, 64, 64)
    assert tuple(batch.waypoint_maps.shape) == (1, 2, 64, 64)
    assert tuple(batch.target.shape) == (1, 3, 64, 64)
    assert batch.waypoint_maps[0, 1, 14, 18] == 0.0  # goal (18, 14): zero distance at its pixel


def test_agent_crops_cut_the_map_around_each_centre_and_pad_outside():
    semantic = torch.zeros(2, 40, 50)
    semantic[1] = torch.arange(40 * 50, dtype=torch.float32).view(40, 50)
    crops, origin = agent_crops(semantic, torch.tensor([[20.0, 10.0], [1.0, 38.6]]), 32,
                                padding_class=0)
    assert tuple(crops.shape) == (2, 2, 32, 32)
    assert origin.tolist() == [[4.0, -6.0], [-15.0, 23.0]]
    # map pixel (row y, column x) sits at crop pixel (y - origin_y, x - origin_x)
    torch.testing.assert_close(crops[0, 1, 6:, :], semantic[1, :26, 4:36])
    assert crops[0, 0, :6].min() == 1.0 and crops[0, 0, 6:].max() == 0.0  # rows above the map
    assert crops[1, 0, :17, 15:].max() == 0.0 and crops[1, 0, 17:].min() == 1.0  # below the map
    assert crops[1, 0, :, :15].min() == 1.0  # left of the map


def test_cropped_inputs_equal_the_whole_maps_cut_the_same_way():
    semantic = torch.rand(3, 70, 90)
    past = torch.tensor([[[30.0, 40.0], [33.0, 41.0]], [[80.0, 5.0], [86.0, 2.0]]])
    whole = model_input(padded_semantic(semantic, 0), past, max_distance=50.0)
    cropped, origin = window_inputs(semantic, past, 50.0, crop=32, padding_class=0, lead_steps=2)
    assert origin[0].tolist() == [23.0, 27.0]  # centre (33, 41) + 2 * (3, 1), minus 16
    for b, (x0, y0) in enumerate(origin.long().tolist()):
        rows, cols = slice(max(y0, 0), y0 + 32), slice(max(x0, 0), min(x0 + 32, 90))
        inside = cropped[b][:, rows.start - y0:rows.stop - y0, cols.start - x0:cols.stop - x0]
        torch.testing.assert_close(inside, whole[b][:, rows, cols])
    with pytest.raises(ValueError, match="multiple of 32"):
        window_inputs(semantic, past, None, crop=32, padding_class=0)


def test_cropped_training_batch_is_the_whole_batch_cut_around_the_agent():
    semantic = torch.rand(3, 70, 90)
    past = torch.tensor([[[30.0, 40.0], [33.0, 41.0]]])
    future = torch.tensor([[[36.0, 42.0], [39.0, 43.0], [42.0, 44.0]]])
    whole = training_batch(padded_semantic(semantic, 0), past, future, (1, 2), 50.0, 7, 1.0)
    cropped = cropped_training_batch(semantic, past, future, (1, 2), 50.0, 7, 1.0, crop=32,
                                     lead_steps=2.0, padding_class=0)
    cut = (slice(None), slice(None), slice(27, 59), slice(23, 55))  # origin (23, 27)
    for name in ("inputs", "waypoint_maps", "target"):
        torch.testing.assert_close(getattr(cropped, name), getattr(whole, name)[cut])
