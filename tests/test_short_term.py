"""Stage `short_term_windows` on the real mirror (`../shared/data`) and on small malformed fixtures.

Expected counts are computed here from the raw text files by a plain reading (sets of pedestrians
per frame), not by the code under test; the SDD test windows are compared with the authors'
`test_trajnet.pkl` and the ETH/UCY test windows with their `<scene>_test.pkl` (pickles unpickled only
after their checksum matched the committed manifest).
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

from pipeline.benchmarks.ethucy import (MAP_CLASSES, SCENES, load_ethucy_scenes, read_oracle,
                                        sgan_window_rows)
from pipeline.benchmarks.short_term import ShortTermInputError, read_rows
from pipeline.benchmarks.short_term_windows import build
from pipeline.benchmarks.trajnet_sdd import fixed_windows, read_sdd_ratios
from pipeline.data.checksums import load_verified_pickle, read_manifest
from pipeline.data.homography import HomographyError, metres_to_pixels, pixels_to_metres, read_homography
from pipeline.config.loading import load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.window_table import COLUMNS, to_arrays
from pipeline.splits import FOLD_TEST_SCENES

REPO = Path(__file__).resolve().parents[1]
MIRROR = REPO.parent / "shared" / "data"
TRAJNET, SGAN, RELEASE = MIRROR / "trajnet-sdd", MIRROR / "sgan", MIRROR / "ynet-release"
ETHUCY = RELEASE / "data" / "eth_ucy"
PARAMS = ShortTermParams()  # the defaults are params.yaml's values (checked below)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The stage's output on the real mirror: (folder, stats)."""
    out = tmp_path_factory.mktemp("short_term") / "short_term"
    stats = build(TRAJNET, SGAN, RELEASE, MIRROR / "ethucy-scenes", out, PARAMS)
    return out, stats


def windows_by_first_step(table: pd.DataFrame, scene: str, track: str, frame: str, key: str):
    """(N, L, 4) [frame, track, x, y] of every window, sorted by (scene, track, first frame)."""
    table = table.sort_values([key, frame], kind="stable")
    firsts = table.groupby(key, sort=False)[[scene, track, frame]].first()
    order = firsts.sort_values([scene, track, frame], kind="stable").index
    groups = {k: g[[frame, track, "x", "y"]].to_numpy(np.float64) for k, g in table.groupby(key)}
    return np.stack([groups[k] for k in order]), firsts.loc[order, scene].astype(str).to_numpy()


# ---------------------------------------------------------------------------------------------
# Homographies


def scene_metres(scene: str) -> np.ndarray:
    """All positions (metres) of a recording, read plainly from SGAN's raw file."""
    path = SGAN / "datasets" / "raw" / "all_data" / f"{SCENES[scene].sgan_stem}.txt"
    return np.array([[float(v) for v in line.split()[2:4]] for line in path.read_text().splitlines()])


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_metres_pixels_round_trip_on_every_real_homography(scene):
    H = read_homography(ETHUCY / f"{scene}_H.txt")
    metres = scene_metres(scene)  # (R, 2)
    pixels = metres_to_pixels(metres, H, SCENES[scene].swap)
    np.testing.assert_allclose(pixels_to_metres(pixels, H, SCENES[scene].swap), metres, rtol=0,
                               atol=1e-9)
    np.testing.assert_allclose(metres_to_pixels(pixels_to_metres(pixels, H, SCENES[scene].swap), H,
                                                SCENES[scene].swap), pixels, rtol=0, atol=1e-7)
    # Pixels land on the scene's oracle grid (a few positions of eth/hotel lie just outside).
    height, width = cv2.imread(str(ETHUCY / scene / "oracle.png"), cv2.IMREAD_UNCHANGED).shape
    inside = (pixels >= -1).all(axis=1) & (pixels[:, 0] < width + 1) & (pixels[:, 1] < height + 1)
    assert inside.mean() > 0.99


def test_swap_exchanges_pixel_axes_only():
    H = np.array([[0.02, 0.001, -4.0], [0.0005, 0.025, -5.0], [0.0003, 0.0001, 0.5]])
    metres = np.array([[[1.0, 2.0], [3.5, -1.0]]])  # (1, 2, 2): any leading shape
    plain = metres_to_pixels(metres, H, swap=False)
    np.testing.assert_array_equal(metres_to_pixels(metres, H, swap=True), plain[..., ::-1])
    assert plain.shape == metres.shape


# ---------------------------------------------------------------------------------------------
# Window counts, computed independently


def plain_sgan_count(path: Path, length: int, min_agents: int) -> int:
    """Windows of one SGAN file: pedestrians present in all of `length` consecutive frames."""
    present = defaultdict(set)
    for line in path.read_text().splitlines():
        frame, ped = line.split()[:2]
        present[float(frame)].add(float(ped))
    frames = sorted(present)
    count = 0
    for start in range(len(frames) - length + 1):
        everywhere = set.intersection(*(present[f] for f in frames[start:start + length]))
        if len(everywhere) >= min_agents:
            count += len(everywhere)
    return count


def test_ethucy_window_counts_per_fold_and_split(built):
    _, stats = built
    counts_by_file = {}
    for fold in FOLD_TEST_SCENES:
        expected = {}
        for split in ("train", "val", "test"):
            total = 0
            for path in sorted((SGAN / "datasets" / fold / split).glob("*.txt")):
                key = (path.name, path.read_bytes())
                if key not in counts_by_file:
                    counts_by_file[key] = plain_sgan_count(path, 20, 2)
                total += counts_by_file[key]
            expected[split] = total
        assert stats["ethucy"][fold] == expected, fold
    assert stats["ethucy"]["eth"]["test"] == 181  # = the authors' eth_test.pkl


def test_sdd_window_counts(built):
    _, stats = built
    expected = defaultdict(int)
    for folder in ("train", "test"):
        for path in (TRAJNET / folder).glob("*.txt"):
            windows = len(path.read_text().splitlines()) // 20
            split = "test" if folder == "test" else "val" if path.stem in PARAMS.sdd_val_videos else "train"
            expected[split] += windows
    assert stats["sdd_trajnet"] == dict(expected)
    assert expected["test"] == 2829


def test_tables_follow_the_window_schema(built):
    out, _ = built
    for name in ["sdd_trajnet"] + [f"ethucy_{fold}" for fold in FOLD_TEST_SCENES]:
        table = pd.read_parquet(out / f"{name}.parquet")
        assert list(table.columns) == list(COLUMNS) + ["x_m", "y_m"]
        assert table.groupby("window_id").size().eq(20).all()
        assert set(table["t_f"]) == {12}
        arrays = to_arrays(table, n_past=8)
        assert arrays.past.shape[1:] == (8, 2) and arrays.future.shape[1:] == (12, 2)
        frames = table["frame"].to_numpy().reshape(-1, 20)
        assert (np.diff(frames, axis=1) == (12 if name == "sdd_trajnet" else 10)).all()


# ---------------------------------------------------------------------------------------------
# Against the authors' release


def test_sdd_test_windows_equal_the_release(built):
    out, _ = built
    manifest = read_manifest(REPO / "manifests" / "ynet-release.sha256")
    release = load_verified_pickle(RELEASE, "data/SDD/test_trajnet.pkl", manifest)
    ours = pd.read_parquet(out / "sdd_trajnet.parquet").query("split == 'test'")
    theirs, their_scenes = windows_by_first_step(release, "sceneId", "trackId", "frame", "metaId")
    mine, my_scenes = windows_by_first_step(ours, "scene_id", "track_id", "frame", "window_id")
    assert mine.shape == theirs.shape == (2829, 20, 4)
    np.testing.assert_array_equal(my_scenes, their_scenes)
    np.testing.assert_array_equal(mine[..., :2], theirs[..., :2])  # frames and tracks exactly
    np.testing.assert_allclose(mine[..., 2:], theirs[..., 2:], rtol=0, atol=1e-9)  # pixels


@pytest.mark.parametrize("scene", ["eth", "hotel", "zara1"])
def test_ethucy_test_windows_match_the_release(built, scene):
    """Checks the homography's direction and the eth/hotel swap on real data: the authors' test
    pixels are SGAN's metres through inv(H) (zara1's differ by SGAN's rounding to 0.1 mm)."""
    out, _ = built
    manifest = read_manifest(REPO / "manifests" / "ynet-release.sha256")
    release = load_verified_pickle(RELEASE, f"data/eth_ucy/{scene}_test.pkl", manifest)
    ours = pd.read_parquet(out / f"ethucy_{scene}.parquet").query("split == 'test'")
    theirs, _ = windows_by_first_step(release, "sceneId", "trackId", "frame", "metaId")
    mine, _ = windows_by_first_step(ours, "scene_id", "track_id", "frame", "window_id")
    assert mine.shape == theirs.shape
    np.testing.assert_array_equal(mine[..., :2], theirs[..., :2])
    np.testing.assert_allclose(mine[..., 2:], theirs[..., 2:], rtol=0, atol=0.01)


def test_pixels_map_back_to_the_metre_columns(built):
    out, _ = built
    scenes = load_ethucy_scenes(out / "ethucy_semantic")
    for fold in FOLD_TEST_SCENES:
        table = pd.read_parquet(out / f"ethucy_{fold}.parquet")
        for scene, group in table.groupby("scene_id"):
            info = scenes[str(scene)]
            metres = pixels_to_metres(group[["x", "y"]].to_numpy(), info.homography, info.swap)
            np.testing.assert_allclose(metres, group[["x_m", "y_m"]].to_numpy(), rtol=0, atol=1e-9)


def test_semantic_maps_load_like_sdd_maps(built):
    out, _ = built
    maps = load_semantic_maps(out / "ethucy_semantic")
    scenes = load_ethucy_scenes(out / "ethucy_semantic")
    assert set(maps) == set(scenes) == set(SCENES)
    for name, probs in maps.items():
        height, width = scenes[name].image_hw
        assert probs.shape == (len(MAP_CLASSES), round(height / 1.5), round(width / 1.5))
        np.testing.assert_allclose(probs.sum(axis=0), 1, atol=1e-5)
        assert probs[0].max() == 0  # padding only where Y-net pads
        road = read_oracle(ETHUCY / name / "oracle.png")
        assert abs(probs[2].mean() - road.mean()) < 0.01


def test_params_yaml_section_validates_and_matches_the_defaults_used_here():
    assert load_section(ShortTermParams, "short_term", read_params()) == PARAMS


# ---------------------------------------------------------------------------------------------
# Small fixtures: window rules and malformed input


def test_sgan_windows_need_every_frame_and_enough_agents(tmp_path):
    rows = np.array([[f, p, 0.0, 0.0] for f in range(0, 50, 10) for p in (1, 2)]
                    + [[f, 3, 0.0, 0.0] for f in (0, 10, 20)], dtype=float)
    windows = sgan_window_rows(rows, length=3, min_agents=2, path=tmp_path / "x.txt")
    firsts = sorted((rows[w[0], 1], rows[w[0], 0]) for w in windows)
    # runs starting at 0, 10, 20 (of 5 frames), peds 1 and 2 in each; ped 3 only at start 0
    assert firsts == [(1, 0), (1, 10), (1, 20), (2, 0), (2, 10), (2, 20), (3, 0)]
    alone = sgan_window_rows(rows[rows[:, 1] == 1], length=3, min_agents=2, path=tmp_path / "x.txt")
    assert len(alone) == 0


def test_sgan_gap_and_bad_line_name_the_file(tmp_path):
    rows = np.array([[f, 1, 0.0, 0.0] for f in (0, 10, 30)] + [[20, 2, 0, 0]], dtype=float)
    with pytest.raises(ShortTermInputError, match=r"gap.txt: pedestrian 1 is missing"):
        sgan_window_rows(rows, length=4, min_agents=1, path=tmp_path / "gap.txt")
    bad = tmp_path / "bad.txt"
    bad.write_text("0\t1\t1.0\t2.0\n10\t1\tnan-ish\t2.0\n")
    with pytest.raises(ShortTermInputError, match=r"bad.txt:2: expected 'frame ped x y'"):
        read_rows(bad, "frame ped x y")


def test_trajnet_window_spanning_two_tracks_is_an_error(tmp_path):
    rows = np.array([[12 * k, 1 if k < 3 else 2, 0, 0] for k in range(4)], dtype=float)
    with pytest.raises(ShortTermInputError, match=r"f.txt: rows 1-4 are not one track"):
        fixed_windows(rows, length=4, frame_step=12, path=tmp_path / "f.txt")


def test_malformed_ratio_homography_and_oracle_files(tmp_path):
    ratios = tmp_path / "H_SDD.txt"
    ratios.write_text("File\tVersion\tRatio\r\ngates_0.jpg\tA\t0.04\r\ngates_0.jpg\tB\t-1\r\n")
    assert read_sdd_ratios(ratios, "A") == {"gates_0": 0.04}
    with pytest.raises(ShortTermInputError, match=r"H_SDD.txt: no positive ratio for \['gates_0'\]"):
        read_sdd_ratios(ratios, "B")
    homography = tmp_path / "x_H.txt"
    homography.write_text("1 0 0\n0 1 0\n")
    with pytest.raises(HomographyError, match=r"x_H.txt: expected a 3x3 matrix"):
        read_homography(homography)
    oracle = tmp_path / "oracle.png"
    cv2.imwrite(str(oracle), np.full((4, 5), 2, np.uint8))
    with pytest.raises(ShortTermInputError, match=r"oracle.png: values \[2\]"):
        read_oracle(oracle)
