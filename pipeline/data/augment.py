"""Random training crops with the paper's augmentations, in OpenCV.

The geometric part (crop position, rotation, flip, scale, perspective) is one homography applied
with `cv2.warpPerspective` to the image (bilinear) and to the mask (nearest neighbour, so no
invented classes), which keeps the two aligned by construction and costs one warp per crop. Pixels
that fall outside the scene become black in the image and the padding class in the mask, exactly
like the padding added to reach a multiple of 32. Photometric changes touch only the image.
"""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.config.segmentation import AugmentParams


NO_AUGMENT = AugmentParams(
    rotate_deg=0, flip=False, scale_min=1, scale_max=1, perspective=0, noise_std=0,
    blur_prob=0, brightness=0, contrast=0, colour=0,
)


def crop_centre(rng: np.random.Generator, image_hw: tuple[int, int], crop: int) -> np.ndarray:
    """A uniform whole-pixel crop centre (x, y) such that the unrotated crop lies inside the image
    (centred on an axis where the image is smaller than the crop)."""
    half = crop // 2
    return np.array([rng.integers(half, size - half + 1) if size >= crop else size / 2
                     for size in (image_hw[1], image_hw[0])], np.float64)


def sample_warp(
    rng: np.random.Generator, params: AugmentParams, centre: np.ndarray, crop: int
) -> np.ndarray:
    """Homography (3, 3) mapping crop pixels (x, y) to source pixels: rotate, flip, scale, tilt."""
    angle = np.deg2rad(rng.uniform(-params.rotate_deg, params.rotate_deg))
    scale = np.exp(rng.uniform(np.log(params.scale_min), np.log(params.scale_max)))
    mirror = -1.0 if params.flip and rng.random() < 0.5 else 1.0
    cos, sin = np.cos(angle), np.sin(angle)
    linear = scale * np.array([[cos, -sin], [sin, cos]]) @ np.diag([mirror, 1.0])  # (2, 2)
    half = crop / 2
    corners = np.array([[0, 0], [crop, 0], [crop, crop], [0, crop]], np.float64)  # (4, 2) crop
    source = (corners - half) @ linear.T + centre  # (4, 2) where the corners land in the source
    jitter = rng.uniform(-params.perspective, params.perspective, size=(4, 2)) * crop * scale
    return cv2.getPerspectiveTransform(corners.astype(np.float32), (source + jitter).astype(np.float32))


def warp_pair(
    image: np.ndarray, mask: np.ndarray, warp: np.ndarray, crop: int, pad_class: int
) -> tuple[np.ndarray, np.ndarray]:
    """Resample image (H, W, 3) and mask (H, W) through `warp` (crop -> source) into crop x crop."""
    flags = cv2.WARP_INVERSE_MAP
    out_image = cv2.warpPerspective(
        image, warp, (crop, crop), flags=flags | cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0),
    )
    out_mask = cv2.warpPerspective(
        mask, warp, (crop, crop), flags=flags | cv2.INTER_NEAREST,
        borderMode=cv2.BORDER_CONSTANT, borderValue=pad_class,
    )
    return out_image, out_mask


def photometric(image: np.ndarray, rng: np.random.Generator, params: AugmentParams) -> np.ndarray:
    """Colour cast, contrast, brightness, blur and noise on a float image (H, W, 3) in [0, 1]."""
    image = image * rng.uniform(1 - params.colour, 1 + params.colour, size=3).astype(np.float32)
    mean = image.mean()
    image = (image - mean) * np.float32(rng.uniform(1 - params.contrast, 1 + params.contrast)) + mean
    image = image + np.float32(rng.uniform(-params.brightness, params.brightness))
    if rng.random() < params.blur_prob:
        image = cv2.GaussianBlur(image, (0, 0), sigmaX=rng.uniform(0.3, params.blur_sigma))
    if params.noise_std > 0:
        std = rng.uniform(0, params.noise_std)
        image = image + rng.normal(0, std, size=image.shape).astype(np.float32)
    return np.clip(image, 0, 1)


def random_crop(
    image: np.ndarray,
    mask: np.ndarray,
    rng: np.random.Generator,
    params: AugmentParams,
    crop: int,
    pad_class: int,
) -> tuple[np.ndarray, np.ndarray]:
    """One augmented training crop: image uint8 (H, W, 3), mask (H, W) -> float (crop, crop, 3), mask.

    Padding pixels are black again after the photometric changes, as they are at inference.
    """
    warp = sample_warp(rng, params, crop_centre(rng, image.shape[:2], crop), crop)
    image, mask = warp_pair(image, mask, warp, crop, pad_class)
    image = photometric(image.astype(np.float32) / 255, rng, params)
    image[mask == pad_class] = 0
    return image, mask
