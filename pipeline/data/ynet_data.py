"""Y-net's inputs and targets, built per scene from window arrays and a semantic map.

Batches hold one scene only (scene images differ in size), so the semantic map is prepared once per
scene and shared by every window of the batch. Coordinates follow `ynet.heatmaps`: (x, y) = (column,
row) in pixels of the resized map; windows arrive in original pixels and are multiplied by `resize`.
The 8x augmentation (rotations by 0/90/180/270 degrees, each with and without a horizontal flip:
`pipeline.config.ynet.AUGMENTATIONS`, beside the setting that counts them) transforms the map and the
coordinates together. A scene's size is its video's reference image's
(`pipeline.data.labels.image_sizes`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np
import torch
import torch.nn.functional as F

from pipeline.device import CPU, to_device
from pipeline.data.window_table import WindowArrays
from ynet.heatmaps import distance_maps, gaussian_heatmaps, pad_to_multiple


@dataclass(frozen=True)
class SceneWindows:
    """All windows of one scene, on that scene's resized semantic map."""

    scene_id: str
    semantic: torch.Tensor  # (C, H, W) class probabilities, unpadded
    past: torch.Tensor  # (N, n_p, 2) resized pixels
    future: torch.Tensor  # (N, n_f, 2) resized pixels
    index: np.ndarray  # (N,) row of each window in the WindowArrays it came from

    def __len__(self) -> int:
        return len(self.index)

    def subset(self, rows) -> SceneWindows:
        return replace(self, past=self.past[rows], future=self.future[rows], index=self.index[rows])

    def to(self, device: torch.device) -> SceneWindows:
        """The scene's tensors on `device` (the very same object on the device it is on)."""
        if self.semantic.device == device:
            return self
        return replace(self, semantic=to_device(self.semantic, device),
                       past=to_device(self.past, device), future=to_device(self.future, device))


def resize_semantic(semantic: np.ndarray, height: int, width: int) -> np.ndarray:
    """(C, h, w) probabilities -> (C, height, width) by area averaging (stays a distribution)."""
    if semantic.shape[1:] == (height, width):
        return semantic.astype(np.float32)
    channels = [cv2.resize(c.astype(np.float32), (width, height), interpolation=cv2.INTER_AREA)
                for c in semantic]
    return np.stack(channels)


def group_by_scene(arrays: WindowArrays, semantic_maps: dict[str, np.ndarray],
                   image_sizes: dict[str, tuple[int, int]], resize: float,
                   device: torch.device = CPU) -> list[SceneWindows]:
    """One SceneWindows per scene of `arrays`, in sorted scene order, its tensors on `device`.

    semantic_maps: scene_id -> (C, h, w) probabilities at any resolution; image_sizes: scene_id ->
    original (height, width), so the map is brought to round(size * resize) exactly. Scenes are
    moved once here, not per batch or evaluation round.
    """
    scenes = []
    for scene_id in sorted(set(arrays.scene_id)):
        if scene_id not in semantic_maps:
            raise KeyError(f"no semantic map for scene {scene_id}")
        height, width = (round(s * resize) for s in image_sizes[scene_id])
        rows = np.flatnonzero(arrays.scene_id == scene_id)
        scenes.append(SceneWindows(
            scene_id=scene_id,
            semantic=torch.from_numpy(resize_semantic(semantic_maps[scene_id], height, width)),
            past=torch.from_numpy(arrays.past[rows] * resize).float(),
            future=torch.from_numpy(arrays.future[rows] * resize).float(),
            index=rows,
        ).to(device))
    return scenes


def rotate_points(points: torch.Tensor, turns: int, height: int, width: int) -> torch.Tensor:
    """Where points (..., 2) land when their (height, width) map is rotated by `turns` x 90 degrees
    counter-clockwise (as `torch.rot90(map, turns, dims=(-2, -1))`)."""
    x, y = points[..., 0], points[..., 1]
    for _ in range(turns % 4):
        # rot90 by one turn: out[i, j] = in[j, W - 1 - i], so (x, y) -> (y, W - 1 - x).
        x, y = y, (width - 1) - x
        height, width = width, height
    return torch.stack([x, y], dim=-1)


def augment(scene: SceneWindows, turns: int, flip: bool) -> SceneWindows:
    """The scene rotated by `turns` quarter turns, then mirrored left-right if `flip`."""
    height, width = scene.semantic.shape[-2:]
    semantic = torch.rot90(scene.semantic, turns, dims=(-2, -1))
    past = rotate_points(scene.past, turns, height, width)
    future = rotate_points(scene.future, turns, height, width)
    if flip:
        new_width = semantic.shape[-1]
        semantic = torch.flip(semantic, dims=(-1,))
        past = torch.stack([(new_width - 1) - past[..., 0], past[..., 1]], dim=-1)
        future = torch.stack([(new_width - 1) - future[..., 0], future[..., 1]], dim=-1)
    return replace(scene, semantic=semantic.contiguous(), past=past, future=future)


def mark_outside(padded: torch.Tensor, top: int, left: int, height: int, width: int,
                 padding_class: int | None) -> torch.Tensor:
    """`padded` (C, H', W') with every pixel outside the map's (height, width) block at (top, left)
    set to 1 in channel `padding_class` (None: none), in place. Slices, not a boolean mask: a mask
    write on a GPU waits for the device to count the mask's pixels."""
    if padding_class is not None:
        channel = padded[padding_class]  # (H', W')
        channel[:top] = 1.0
        channel[top + height:] = 1.0
        channel[top:top + height, :left] = 1.0
        channel[top:top + height, left + width:] = 1.0
    return padded


def padded_semantic(semantic: torch.Tensor, padding_class: int | None) -> torch.Tensor:
    """(C, H, W) -> (C, H', W') padded to multiples of 32; padded pixels belong to `padding_class`."""
    height, width = semantic.shape[-2:]
    return mark_outside(pad_to_multiple(semantic), 0, 0, height, width, padding_class)


def model_input(semantic_padded: torch.Tensor, past: torch.Tensor,
                max_distance: float | None) -> torch.Tensor:
    """(C, H, W) padded map and (B, n_p, 2) past positions -> (B, C + n_p, H, W)."""
    height, width = semantic_padded.shape[-2:]
    past_maps = distance_maps(past, height, width, max_distance)  # (B, n_p, H, W)
    scene = semantic_padded.unsqueeze(0).expand(len(past), -1, -1, -1)  # (B, C, H, W)
    return torch.cat([scene, past_maps], dim=1)


def agent_crops(semantic: torch.Tensor, centres: torch.Tensor, size: int,
                padding_class: int | None) -> tuple[torch.Tensor, torch.Tensor]:
    """Square windows of an unpadded map centred on each agent: why evaluation can skip most pixels.

    semantic (C, H, W), centres (B, 2) as (x, y) -> crops (B, C, size, size) and origins (B, 2), the
    (x, y) of each crop's pixel [0, 0] in the map (crop position = map position - origin). Pixels
    beyond the map belong to `padding_class`, as in `padded_semantic`.
    """
    channels, height, width = semantic.shape
    half = size // 2
    padded = F.pad(semantic, (half, size, half, size))  # (C, H + half + size, W + half + size)
    mark_outside(padded, half, half, height, width, padding_class)
    origin = torch.round(centres).long() - half  # (B, 2)
    origin[:, 0].clamp_(-half, width)  # every crop stays inside the padded map
    origin[:, 1].clamp_(-half, height)
    # One gather for the whole batch, indices on the map's device: no per-agent loop reading
    # the origins on the host.
    offsets = torch.arange(size, device=padded.device)
    channel = torch.arange(channels, device=padded.device)[None, :, None, None]  # (1, C, 1, 1)
    row = (origin[:, 1, None] + half + offsets)[:, None, :, None]  # (B, 1, S, 1)
    column = (origin[:, 0, None] + half + offsets)[:, None, None, :]  # (B, 1, 1, S)
    crops = padded[channel, row, column]  # (B, C, S, S)
    return crops, origin.to(centres.dtype)


def window_inputs(semantic: torch.Tensor, past: torch.Tensor, max_distance: float | None,
                  crop: int, padding_class: int | None,
                  lead_steps: float = 0.0) -> tuple[torch.Tensor, torch.Tensor]:
    """Model inputs (B, C + n_p, H', W') for windows of one scene and the origin (B, 2) to add back.

    crop = 0: the whole map padded to multiples of 32, origin 0. crop > 0 (a multiple of 32): a
    crop x crop window centred `lead_steps` steps of the last observed velocity ahead of each agent
    (where its future lies; past positions off the crop still shape its distance maps). The
    distance maps equal the whole map's, cut the same way, which needs a fixed `max_distance`.
    """
    if crop == 0:
        inputs = model_input(padded_semantic(semantic, padding_class), past, max_distance)
        return inputs, torch.zeros(len(past), 2, dtype=past.dtype, device=past.device)
    if crop % 32 or max_distance is None:
        raise ValueError(f"crops need a side that is a multiple of 32 and a fixed max_distance, got "
                         f"crop {crop} and max_distance {max_distance}")
    centres = past[:, -1] + lead_steps * (past[:, -1] - past[:, -2])  # (B, 2)
    crops, origin = agent_crops(semantic, centres, crop, padding_class)
    past_maps = distance_maps(past - origin[:, None], crop, crop, max_distance)  # (B, n_p, S, S)
    return torch.cat([crops, past_maps], dim=1), origin


@dataclass(frozen=True)
class TrainingBatch:
    inputs: torch.Tensor  # (B, C + n_p, H, W)
    waypoint_maps: torch.Tensor  # (B, n_w, H, W) distance maps of the ground-truth waypoints
    target: torch.Tensor  # (B, n_f, H, W) Gaussian heatmaps of the ground-truth future

    def to(self, device: torch.device | str) -> TrainingBatch:
        return TrainingBatch(*(t.to(device, non_blocking=True) for t in
                               (self.inputs, self.waypoint_maps, self.target)))


def at_steps(positions: torch.Tensor, indices: tuple[int, ...]) -> torch.Tensor:
    """positions (B, T, 2) at the given steps: (B, len(indices), 2). Selected one by one: a list
    index would be copied from the host to the GPU on every call, which waits for the device."""
    return torch.stack([positions[:, i] for i in indices], dim=1)


def training_batch(semantic_padded: torch.Tensor, past: torch.Tensor, future: torch.Tensor,
                   waypoints: tuple[int, ...], max_distance: float | None, kernel_size: int,
                   sigma: float) -> TrainingBatch:
    height, width = semantic_padded.shape[-2:]
    return TrainingBatch(
        inputs=model_input(semantic_padded, past, max_distance),
        waypoint_maps=distance_maps(at_steps(future, waypoints), height, width, max_distance),
        target=gaussian_heatmaps(future, height, width, kernel_size, sigma),
    )


def cropped_training_batch(semantic: torch.Tensor, past: torch.Tensor, future: torch.Tensor,
                           waypoints: tuple[int, ...], max_distance: float, kernel_size: int,
                           sigma: float, crop: int, lead_steps: float,
                           padding_class: int | None) -> TrainingBatch:
    """`training_batch` on a crop x crop window per agent (`window_inputs`) of the unpadded map.

    Future positions are moved into each crop; a Gaussian target reaching beyond it is cut off
    there, as at the map's border.
    """
    inputs, origin = window_inputs(semantic, past, max_distance, crop, padding_class, lead_steps)
    future = future - origin[:, None]  # (B, n_f, 2) crop pixels
    return TrainingBatch(
        inputs=inputs,
        waypoint_maps=distance_maps(at_steps(future, waypoints), crop, crop, max_distance),
        target=gaussian_heatmaps(future, crop, crop, kernel_size, sigma),
    )
