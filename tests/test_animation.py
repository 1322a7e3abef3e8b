"""The animated predictions (`pipeline.report.animation`, stage `animations`): the storyboard's frames
show what they say at the pixels where it must be, the bytes are the same on every run, and a bad
`.npz` is named with its key.

The window is synthetic and tiny: a grey 40 x 30 scene (x 12 on screen), three observed points,
four predicted steps, three predicted paths ending far apart, two goals away from them.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pipeline.report import animation
from pipeline.stages import animations as stage

GREY = 128
SCALE = 12  # 480 / 40: Storyboard.long_side over the scene's longer side
ENDS = np.array([[6.0, 4.0], [34.0, 5.0], [30.0, 26.0]], np.float32)  # the K = 3 paths' last points


def window_arrays(i: int = 0) -> dict[str, np.ndarray]:
    """One window in the evaluations' format, keys `<name>_<i>`."""
    past = np.array([[18.0, 14.0], [19.0, 14.5], [20.0, 15.0]], np.float32)
    steps = np.linspace(0.25, 1.0, 4, dtype=np.float32)[None, :, None]  # (1, 4, 1)
    predictions = past[-1] + steps * (ENDS[:, None, :] - past[-1])  # (3, 4, 2) straight to the ends
    heatmap = np.zeros((15, 20), np.float32)  # half the scene's size: stretched over it
    heatmap[2:4, 2:4] = 1.0  # a blob around scene pixel (6, 6)
    arrays = {"scene_image": np.full((30, 40, 3), GREY, np.uint8), "past": past,
              "future": np.array([[22.0, 16.0], [24.0, 17.0], [26.0, 18.0], [28.0, 19.0]], np.float32),
              "goal_heatmap": heatmap, "sampled_goals": np.array([[10.0, 24.0], [36.0, 15.0]], np.float32),
              "trajectory_heatmap": heatmap, "predictions": predictions.astype(np.float32),
              "scene_id": np.array("gates_2")}
    return {f"{name}_{i}": value for name, value in arrays.items()}


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, **arrays)
    return path


@pytest.fixture
def window(tmp_path) -> animation.Window:
    return animation.read_windows(write_npz(tmp_path / "q.npz", window_arrays()))[0]


def pixel(frame: animation.Frame, x: float, y: float) -> np.ndarray:
    """The frame's RGB at scene coordinates (x, y) (the scene is 480 wide: no centring offset)."""
    return np.asarray(frame.image, dtype=int)[round(y * SCALE), round(x * SCALE)]


def is_red(rgb) -> bool:
    return rgb[0] > 150 and rgb[1] < 70 and rgb[2] < 70


def test_the_storyboard_has_one_frame_per_point_fade_goals_and_step(window):
    frames = animation.frames(window, "SDD long-term")
    board = animation.Storyboard()
    assert len(frames) == 3 + 2 + 1 + 4 == board.frame_count(3, 4)
    assert [f.duration_ms for f in frames] == [250, 250, 250, 200, 200, 1500, 120, 120, 120, 3000]
    assert {f.image.size for f in frames} == {(480, 360 + board.caption_height)}


def test_the_last_frame_shows_every_path_to_its_end_and_the_first_none(window):
    frames = animation.frames(window, "SDD long-term")
    first, goals, last = frames[0], frames[5], frames[-1]
    for x, y in ENDS:
        assert is_red(pixel(last, x, y)), (x, y, pixel(last, x, y))
        assert list(pixel(first, x, y)) == [GREY] * 3
        assert not is_red(pixel(frames[-2], x, y))  # one step earlier the paths end elsewhere
    truth_end = pixel(last, 28.0, 19.0)
    assert truth_end[1] > 150 and truth_end[0] < 60 and truth_end[2] < 60  # green
    for x, y in window.sampled_goals:  # cyan stars from the goals frame on
        assert list(pixel(goals, x, y)) == list(animation.GOAL)
        assert list(pixel(frames[4], x, y)) == [GREY] * 3
    past_end = pixel(first, 18.0, 14.0)
    assert past_end[2] > 200 and past_end[0] < 80  # blue: the first observed point


def test_the_goal_heatmap_fades_in_then_dims_under_the_paths(window):
    frames = animation.frames(window, "SDD long-term")
    blob = [int(np.abs(pixel(f, 6.0, 6.0) - GREY).sum()) for f in frames]
    assert blob[:3] == [0, 0, 0]  # the past alone
    assert 0 < blob[3] < blob[4] == blob[5]  # fading in, then the goals frame at full opacity
    assert 0 < blob[6] < blob[5] and blob[6] == blob[-1]  # dimmed while the futures unfold
    assert list(pixel(frames[5], 38.0, 28.0)) == [GREY] * 3  # no heatmap far from the blob


def test_the_animation_is_a_looping_webp_with_every_frame_and_the_same_bytes_each_time(window):
    first = animation.animate(window, "SDD long-term")
    again = animation.animate(animation.Window(**{**window.__dict__}), "SDD long-term")
    assert first == again
    image = Image.open(io.BytesIO(first))
    assert image.format == "WEBP" and image.n_frames == 10 and image.info.get("loop") == 0
    durations = []
    for i in range(image.n_frames):
        image.seek(i)
        image.load()  # Pillow reads a WebP frame's duration when it decodes it
        durations.append(image.info["duration"])
    assert durations == [f.duration_ms for f in animation.frames(window, "SDD long-term")]
    image.seek(image.n_frames - 1)
    decoded = np.asarray(image.convert("RGB"), dtype=int)
    for x, y in ENDS:  # lossy, but the paths' ends survive the encoding
        assert is_red(decoded[round(y * SCALE), round(x * SCALE)])
    assert len(first) < 100_000


@pytest.mark.parametrize("change, message", [
    (lambda a: a.pop("goal_heatmap_0"), "missing key goal_heatmap_0"),
    (lambda a: a.update(predictions_0=a["predictions_0"][:, :3]),
     "predictions_0 has shape (3, 3, 2), expected (K, T, 2) with T = 4"),
    (lambda a: a.update(past_0=a["past_0"][:, :1]), "past_0 has shape (3, 1), expected (P, 2)"),
    (lambda a: a.update(scene_image_0=a["scene_image_0"].astype(np.float32)),
     "scene_image_0 has dtype float32, expected uint8"),
    (lambda a: a["future_0"].__setitem__((0, 0), np.nan), "future_0 must hold finite floats"),
])
def test_a_bad_npz_is_named_with_its_key(tmp_path, change, message):
    arrays = window_arrays()
    change(arrays)
    path = write_npz(tmp_path / "bad.npz", arrays)
    with pytest.raises(animation.AnimationInputError) as raised:
        animation.read_windows(path)
    assert str(raised.value).startswith(f"{path}: ") and message in str(raised.value)


def test_a_file_that_is_not_an_npz_is_named(tmp_path):
    path = tmp_path / "q.npz"
    path.write_text("not a zip")
    with pytest.raises(animation.AnimationInputError, match="q.npz: not a readable npz archive"):
        animation.read_windows(path)


def test_the_stage_animates_each_benchmark_and_records_a_missing_one(tmp_path):
    long_term = write_npz(tmp_path / "long.npz", window_arrays(0) | window_arrays(1))
    out = tmp_path / "animations"
    stage.main(["--qualitative", f"long_term={long_term}",
                "--qualitative", f"short_term_eth={tmp_path / 'absent.npz'}", "--out", str(out)])
    index = json.loads((out / "index.json").read_text())
    shown, missing = index["benchmarks"]
    assert shown["benchmark"] == "long_term" and shown["status"] == "shown"
    assert [w["file"] for w in shown["windows"]] == ["long_term_0.webp", "long_term_1.webp"]
    assert shown["windows"][0] | {"bytes": 0} == {"file": "long_term_0.webp", "scene_id": "gates_2",
                                                  "bytes": 0, "frames": 10, "n_past": 3,
                                                  "n_future": 4, "k": 3}
    assert missing["status"] == "missing" and missing["windows"] == []
    assert missing["title"] == "ETH/UCY, eth fold, 0.4 s a step" and "absent.npz missing" in missing["reason"]
    assert sorted(p.name for p in out.iterdir()) == ["index.json", "long_term_0.webp", "long_term_1.webp"]
    assert (out / "long_term_0.webp").stat().st_size == shown["windows"][0]["bytes"]


def test_a_file_saying_its_model_was_not_run_is_recorded_with_the_reason(tmp_path):
    not_run = write_npz(tmp_path / "hotel.npz", {"not_run_reason": np.array("not in the profile's datasets")})
    rendered = animation.render_benchmark("short_term_hotel", not_run)
    assert rendered.files == {}
    assert rendered.entry["status"] == "not_run" and rendered.entry["windows"] == []
    assert rendered.entry["reason"] == "Y-net not run: not in the profile's datasets"


def test_the_stage_stops_on_a_malformed_file_and_on_a_bad_label(tmp_path):
    arrays = window_arrays()
    del arrays["predictions_0"]
    bad = write_npz(tmp_path / "bad.npz", arrays)
    with pytest.raises(SystemExit, match=f"animations: {bad}: missing key predictions_0"):
        stage.main(["--qualitative", f"long_term={bad}", "--out", str(tmp_path / "out")])
    assert not (tmp_path / "out").exists()
    with pytest.raises(SystemExit):
        stage.main(["--qualitative", f"Long-Term={bad}", "--out", str(tmp_path / "out")])
