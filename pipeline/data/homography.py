"""World metres <-> image pixels through a scene's 3x3 homography (ETH/UCY).

Convention, checked on the data: the authors' `<scene>_H.txt` maps PIXELS TO METRES,
`[X, Y, w]^T = H @ [a, b, 1]^T`, metres = (X / w, Y / w). Pixels here are always `(x, y)` =
(column, row), as in the window tables and `ynet.heatmaps`. For eth and hotel (the ETH dataset's
own homographies) the pixel input of H is `(row, column)` instead: `swap=True` says so, and the two
pixel coordinates are exchanged on the way in and out. Pure functions, numpy only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


class HomographyError(ValueError):
    """A homography file that is not an invertible 3x3 matrix of finite numbers."""


def read_homography(path: Path | str) -> np.ndarray:
    """The (3, 3) float64 matrix in a whitespace-separated text file; HomographyError names the file."""
    path = Path(path)
    try:
        matrix = np.loadtxt(path, dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as e:
        raise HomographyError(f"{path}: not a readable matrix of numbers ({e})") from e
    if matrix.shape != (3, 3):
        raise HomographyError(f"{path}: expected a 3x3 matrix, got shape {matrix.shape}")
    if not np.isfinite(matrix).all():
        raise HomographyError(f"{path}: holds non-finite values")
    if abs(np.linalg.det(matrix)) < 1e-12 * np.abs(matrix).max() ** 3:
        raise HomographyError(f"{path}: the matrix is singular (cannot be inverted)")
    return matrix


def apply_homography(points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """Points (..., 2) through `matrix` (3, 3) with the projective division -> (..., 2) float64."""
    points = np.asarray(points, dtype=np.float64)
    if points.shape[-1] != 2:
        raise ValueError(f"points must end in a coordinate pair, got shape {points.shape}")
    mapped = points @ matrix[:, :2].T + matrix[:, 2]  # (..., 3) homogeneous
    return mapped[..., :2] / mapped[..., 2:]  # (..., 2)


def metres_to_pixels(points: np.ndarray, matrix: np.ndarray, swap: bool) -> np.ndarray:
    """World metres (..., 2) -> pixels (x, y) (..., 2), with H (3, 3) mapping pixels to metres."""
    pixels = apply_homography(points, np.linalg.inv(matrix))  # (..., 2) in H's pixel order
    return pixels[..., ::-1].copy() if swap else pixels


def pixels_to_metres(points: np.ndarray, matrix: np.ndarray, swap: bool) -> np.ndarray:
    """Pixels (x, y) (..., 2) -> world metres (..., 2); the inverse of `metres_to_pixels`."""
    points = np.asarray(points, dtype=np.float64)
    return apply_homography(points[..., ::-1] if swap else points, matrix)  # (..., 2)
