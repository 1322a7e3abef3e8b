"""Positions on the scene grid: distance maps (inputs), Gaussian heatmaps (targets), padding.

Coordinate convention, used everywhere in `ynet`: a position is `(x, y)` in pixels of the (resized,
padded) map, `x` the column and `y` the row; the centre of pixel `[row i, column j]` is `(x=j, y=i)`.
Positions are real-valued: nothing here rounds them to whole pixels except where a kernel window has to
be placed.

All functions are vectorised over a batch of positions `(B, T, 2)` and return `(B, T, H, W)`.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F


def _grid(height: int, width: int, like: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Pixel-centre coordinates: rows `(H,)` and columns `(W,)` in `like`'s dtype and device."""
    ys = torch.arange(height, dtype=like.dtype, device=like.device)
    xs = torch.arange(width, dtype=like.dtype, device=like.device)
    return ys, xs


def distance_maps(
    positions: torch.Tensor, height: int, width: int, max_distance: float | None = None
) -> torch.Tensor:
    """`2 * ||(x, y) - u|| / max_distance` for every pixel and every position `u`: (B, T, H, W).

    Y-net feeds past positions (and, to the trajectory decoder, goal and waypoints) as these maps, not as
    Gaussians: a distance map gives every pixel a gradient towards the agent.

    max_distance: None normalises each map by its own maximum over the `H x W` grid (the distance to
    the farthest corner, the paper's equation, values exactly 0..2); a number divides every map by
    that constant, which is what the authors' code does (`ynet.config.upstream_max_distance(resize)`, values 0..<2).
    """
    if positions.shape[-1] != 2:
        raise ValueError(f"positions must end in (x, y), got shape {tuple(positions.shape)}")
    if not positions.is_floating_point():
        positions = positions.float()
    ys, xs = _grid(height, width, positions)
    px = positions[..., 0, None, None]  # (B, T, 1, 1)
    py = positions[..., 1, None, None]
    dx2 = (xs.view(1, width) - px) ** 2  # (B, T, 1, W)
    dy2 = (ys.view(height, 1) - py) ** 2  # (B, T, H, 1)
    dist = torch.sqrt(dy2 + dx2)  # (B, T, H, W)
    if max_distance is None:
        # farthest pixel from u is one of the four corners
        far_x = torch.maximum(px, (width - 1) - px)
        far_y = torch.maximum(py, (height - 1) - py)
        norm = torch.sqrt(far_x**2 + far_y**2).clamp_min(1e-6)  # (B, T, 1, 1)
    else:
        if max_distance <= 0:
            raise ValueError(f"max_distance must be positive, got {max_distance}")
        norm = max_distance
    return 2.0 * dist / norm


def gaussian_heatmaps(
    positions: torch.Tensor,
    height: int,
    width: int,
    kernel_size: int = 31,
    sigma: float = 4.0,
) -> torch.Tensor:
    """Ground-truth heatmaps: a Gaussian (std `sigma` px) around each position, (B, T, H, W).

    The Gaussian is truncated to a `kernel_size` square window centred on the pixel nearest to the
    position and normalised so that the whole window sums to 1; where the window sticks out of the map,
    the part outside is cut off (the map then sums to less than 1, as in the authors' template crop), so
    the target value at the agent never depends on how close it is to the border. The peak sits at the
    exact sub-pixel position.
    """
    if kernel_size % 2 != 1:
        raise ValueError(f"kernel_size must be odd, got {kernel_size}")
    if not positions.is_floating_point():
        positions = positions.float()
    radius = kernel_size // 2
    ys, xs = _grid(height, width, positions)
    offsets = torch.arange(-radius, radius + 1, dtype=positions.dtype, device=positions.device)

    def axis(coords: torch.Tensor, centre: torch.Tensor) -> torch.Tensor:
        """1-D truncated Gaussian along one axis, normalised over its full window: (B, T, L)."""
        nearest = torch.round(centre)[..., None]  # (B, T, 1)
        centre = centre[..., None]
        g = torch.exp(-0.5 * ((coords - centre) / sigma) ** 2)  # (B, T, L)
        g = torch.where((coords - nearest).abs() <= radius, g, torch.zeros_like(g))
        window = torch.exp(-0.5 * ((nearest + offsets - centre) / sigma) ** 2).sum(-1, keepdim=True)
        return g / window

    gx = axis(xs, positions[..., 0])  # (B, T, W)
    gy = axis(ys, positions[..., 1])  # (B, T, H)
    return gy[..., :, None] * gx[..., None, :]  # (B, T, H, W)


def padded_size(height: int, width: int, multiple: int = 32) -> tuple[int, int]:
    """The smallest `(H, W)` at least as large as the input with both sides a multiple of `multiple`."""
    return -(-height // multiple) * multiple, -(-width // multiple) * multiple


def pad_to_multiple(x: torch.Tensor, multiple: int = 32, value: float = 0.0) -> torch.Tensor:
    """Pad the last two dims (H, W) at the bottom and right up to a multiple of `multiple`.

    The encoder halves the map five times, so sides must be divisible by 32. Padding only at the bottom
    and right leaves every pixel coordinate unchanged.
    """
    height, width = x.shape[-2:]
    new_h, new_w = padded_size(height, width, multiple)
    return F.pad(x, (0, new_w - width, 0, new_h - height), value=value)


def scene_and_past(
    semantic: torch.Tensor, past: torch.Tensor, max_distance: float | None = None
) -> torch.Tensor:
    """The encoder input: semantic map (B, C, H, W), past positions (B, n_p, 2) -> (B, C + n_p, H, W)."""
    height, width = semantic.shape[-2:]
    past_maps = distance_maps(past.to(semantic.dtype), height, width, max_distance)  # (B, n_p, H, W)
    return torch.cat([semantic, past_maps], dim=1)
