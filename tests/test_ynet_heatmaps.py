import math

import pytest
import torch
from torch.testing import assert_close

from ynet.config import upstream_max_distance
from ynet.heatmaps import (
    distance_maps,
    gaussian_heatmaps,
    pad_to_multiple,
    padded_size,
    scene_and_past,
)

torch.set_num_threads(1)


def brute_distance(x, y, height, width):
    out = torch.empty(height, width, dtype=torch.float64)
    for i in range(height):
        for j in range(width):
            out[i, j] = math.hypot(j - x, i - y)
    return out


@pytest.mark.parametrize("max_distance", [None, 30.0])
def test_distance_map_matches_definition(max_distance):
    positions = torch.tensor([[[3.0, 5.0], [7.25, 0.5]], [[0.0, 0.0], [9.0, 11.0]]])  # (B=2, T=2, 2)
    maps = distance_maps(positions, 12, 10, max_distance)
    assert maps.shape == (2, 2, 12, 10)
    for b in range(2):
        for t in range(2):
            x, y = positions[b, t].tolist()
            d = brute_distance(x, y, 12, 10)
            norm = d.max() if max_distance is None else max_distance
            assert_close(maps[b, t], (2 * d / norm).float())


def test_distance_map_zero_at_position_and_two_at_farthest_corner():
    maps = distance_maps(torch.tensor([[[4.0, 6.0]]]), 16, 20)  # (1, 1, 16, 20)
    assert maps[0, 0, 6, 4] == 0
    assert maps[0, 0].argmin() == 6 * 20 + 4  # row-major: row y=6, column x=4
    assert_close(maps.max(), torch.tensor(2.0))
    assert_close(maps[0, 0, 15, 19], torch.tensor(2.0))  # corner farthest from (4, 6)


def test_upstream_max_distance():
    # template side int(4200 * 0.25) = 1050, centre 525, corner at sqrt(2) * 525
    assert upstream_max_distance(0.25) == pytest.approx(math.sqrt(2) * 525)
    assert upstream_max_distance(1 / 1.5) == pytest.approx(math.sqrt(2) * 1400)


def test_gaussian_peak_and_sum():
    positions = torch.tensor([[[20.0, 30.0], [41.0, 17.0]]])  # (1, 2, 2)
    maps = gaussian_heatmaps(positions, 64, 64)  # kernel 31, sigma 4
    assert maps.shape == (1, 2, 64, 64)
    for t, (x, y) in enumerate(positions[0].tolist()):
        peak = maps[0, t].argmax()
        assert (peak % 64, peak // 64) == (int(x), int(y))
        assert_close(maps[0, t].sum(), torch.tensor(1.0))
        nonzero = (maps[0, t] > 0).nonzero()
        assert nonzero.amin(0).tolist() == [int(y) - 15, int(x) - 15]  # 31 px window
        assert nonzero.amax(0).tolist() == [int(y) + 15, int(x) + 15]


def test_gaussian_width_and_subpixel_centre():
    pos = torch.tensor([[[30.4, 25.7]]])
    m = gaussian_heatmaps(pos, 64, 64, kernel_size=61, sigma=4.0)[0, 0]  # wide window: ~untruncated
    ys, xs = torch.meshgrid(torch.arange(64.0), torch.arange(64.0), indexing="ij")
    mean = torch.stack([(m * xs).sum(), (m * ys).sum()])
    assert_close(mean, pos[0, 0], atol=1e-3, rtol=0)
    var_x = (m * (xs - mean[0]) ** 2).sum()
    assert var_x == pytest.approx(16.0, rel=1e-3)


def test_gaussian_cut_at_border_keeps_peak_height():
    inside = gaussian_heatmaps(torch.tensor([[[20.0, 20.0]]]), 40, 40)
    corner = gaussian_heatmaps(torch.tensor([[[0.0, 0.0]]]), 40, 40)
    assert_close(corner.max(), inside.max())
    assert corner.sum() < 0.5


def test_padding():
    assert padded_size(500, 410) == (512, 416)
    assert padded_size(512, 416) == (512, 416)
    x = torch.rand(2, 3, 50, 70)
    y = pad_to_multiple(x, 32)
    assert y.shape == (2, 3, 64, 96)
    assert_close(y[..., :50, :70], x)  # coordinates unchanged: padding at bottom/right only
    assert y[..., 50:, :].abs().sum() == 0 and y[..., :, 70:].abs().sum() == 0


def test_scene_and_past():
    semantic = torch.rand(2, 6, 32, 64)
    past = torch.rand(2, 5, 2) * 30
    x = scene_and_past(semantic, past, 100.0)
    assert x.shape == (2, 11, 32, 64)
    assert_close(x[:, :6], semantic)
    assert_close(x[:, 6:], distance_maps(past, 32, 64, 100.0))
