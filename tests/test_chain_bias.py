import pandas as pd
import pytest

from pipeline.config.windows import WindowParams
from pipeline.studies.chain_bias import chain_bias

STRIDE = 30


def straight_track(scene: str, track: int, steps: int, speed: float) -> pd.DataFrame:
    frames = pd.RangeIndex(0, steps * STRIDE)
    return pd.DataFrame({"scene_id": scene, "track_id": track, "frame": frames,
                         "x": speed * frames / STRIDE, "y": 0.0, "label": "Pedestrian", "lost": 0})


def test_chains_lose_tails_and_short_pieces():
    # 40 steps: raw gives 4 windows of 10 at t_f=5; release-style chains keep only the first 35
    # steps (3 windows). 20 steps: raw 2 windows, chains none (shorter than 35).
    tracks = pd.concat([straight_track("gates_2", 1, 40, 2.0), straight_track("gates_2", 2, 20, 1.0)])
    result = chain_bias(tracks, WindowParams(horizons=[5, 30]))
    assert result["tf5"]["raw"]["windows"] == 6
    assert result["tf5"]["release_chain"]["windows"] == 3
    assert result["tf5"]["kept_fraction"] == pytest.approx(0.5)
    # Straight tracks at constant speed: constant velocity is exact on both sources.
    assert result["tf5"]["raw"]["cv_ade"] == pytest.approx(0.0, abs=1e-9)
    assert result["tf30"]["raw"]["windows"] == result["tf30"]["release_chain"]["windows"] == 1


def accelerating_track(scene: str, track: int, steps: int, acceleration: float) -> pd.DataFrame:
    frames = pd.RangeIndex(0, steps * STRIDE)
    seconds = frames / STRIDE
    return pd.DataFrame({"scene_id": scene, "track_id": track, "frame": frames,
                         "x": 0.5 * acceleration * seconds**2, "y": 0.0, "label": "Pedestrian",
                         "lost": 0})


def test_constant_velocity_errors_are_those_of_a_constant_acceleration():
    """x = a t^2 / 2: extrapolating the last step's velocity misses step k by a (k^2 + k) / 2
    wherever the window starts, so over k = 1..5 the ADE is 7 a and the FDE 15 a."""
    result = chain_bias(accelerating_track("gates_2", 1, 40, 2.0), WindowParams(horizons=[5]))
    for source in ("raw", "release_chain"):
        assert result["tf5"][source]["windows"] > 0
        assert result["tf5"][source]["cv_ade"] == pytest.approx(14.0)
        assert result["tf5"][source]["cv_fde"] == pytest.approx(30.0)
