"""Augmentation: image and mask stay aligned, masks keep their classes, photometric stays in range."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pipeline.config.segmentation import AugmentParams
from pipeline.data.augment import NO_AUGMENT, crop_centre, photometric, random_crop, sample_warp, warp_pair

PAD = 0
CROP = 64


def square_scene(size: int = 160) -> tuple[np.ndarray, np.ndarray]:
    """A grey scene (class 1) with a red square (class 3) off centre: image (H, W, 3), mask (H, W)."""
    image = np.full((size, size, 3), 90, np.uint8)
    mask = np.ones((size, size), np.uint8)
    image[60:90, 70:110] = (0, 0, 255)  # BGR red
    mask[60:90, 70:110] = 3
    return image, mask


def red(image: np.ndarray) -> np.ndarray:
    return (image[..., 2] > 170) & (image[..., 1] < 60)


@pytest.mark.parametrize("seed", range(8))
def test_geometric_warp_moves_square_identically_in_image_and_mask(seed):
    image, mask = square_scene()
    rng = np.random.default_rng(seed)
    params = AugmentParams(perspective=0.1)
    warp = sample_warp(rng, params, np.array([90.0, 75.0]), CROP)
    out_image, out_mask = warp_pair(image, mask, warp, CROP, PAD)
    in_image, in_mask = red(out_image), out_mask == 3
    assert in_mask.sum() > 50  # the square is in view
    iou = (in_image & in_mask).sum() / (in_image | in_mask).sum()
    assert iou > 0.9
    assert set(np.unique(out_mask)) <= {PAD, 1, 3}  # nearest neighbour: no invented classes


def test_out_of_scene_pixels_are_black_padding():
    image, mask = square_scene(40)
    params = AugmentParams(rotate_deg=45, scale_min=2.0, scale_max=2.0)
    warp = sample_warp(np.random.default_rng(0), params, np.array([20.0, 20.0]), CROP)
    out_image, out_mask = warp_pair(image, mask, warp, CROP, PAD)
    outside = cv2.erode((out_mask == PAD).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    assert outside.any()  # (the one-pixel rim is a bilinear blend; random_crop blackens it)
    assert (out_image[outside] == 0).all()


def test_no_augment_is_a_plain_crop():
    image, mask = square_scene()
    rng = np.random.default_rng(3)
    centre = crop_centre(np.random.default_rng(3), image.shape[:2], CROP)
    out_image, out_mask = random_crop(image, mask, rng, NO_AUGMENT, CROP, PAD)
    x0, y0 = (centre - CROP / 2).astype(int)
    np.testing.assert_array_equal(out_mask, mask[y0:y0 + CROP, x0:x0 + CROP])
    np.testing.assert_allclose(out_image, image[y0:y0 + CROP, x0:x0 + CROP] / 255, atol=1e-6)


def test_random_crop_is_seeded_and_keeps_padding_black():
    image, mask = square_scene()
    mask[:, :20] = PAD
    image[:, :20] = 0
    first = random_crop(image, mask, np.random.default_rng(5), AugmentParams(), CROP, PAD)
    again = random_crop(image, mask, np.random.default_rng(5), AugmentParams(), CROP, PAD)
    np.testing.assert_array_equal(first[0], again[0])
    np.testing.assert_array_equal(first[1], again[1])
    out_image, out_mask = first
    assert out_image.shape == (CROP, CROP, 3) and out_image.dtype == np.float32
    assert out_mask.shape == (CROP, CROP) and out_mask.dtype == np.uint8
    assert (out_image[out_mask == PAD] == 0).all()


def test_small_scene_is_centred():
    np.testing.assert_array_equal(crop_centre(np.random.default_rng(0), (40, 50), CROP), [25, 20])


def test_photometric_stays_in_range():
    image = np.random.default_rng(0).random((32, 32, 3), dtype=np.float32)
    params = AugmentParams(noise_std=0.2, blur_prob=1.0, brightness=0.5, contrast=0.9, colour=0.5)
    out = photometric(image, np.random.default_rng(1), params)
    assert out.shape == image.shape and out.dtype == np.float32
    assert out.min() >= 0 and out.max() <= 1
    assert not np.allclose(out, image)


@pytest.mark.parametrize("bad", [dict(rotate_deg=200), dict(scale_min=0), dict(scale_min=2.0),
                                 dict(perspective=0.3), dict(blur_prob=1.5), dict(contrast=1.0),
                                 dict(noise_std=-1)])
def test_params_checked(bad):
    with pytest.raises(ValueError):
        AugmentParams(**bad)
