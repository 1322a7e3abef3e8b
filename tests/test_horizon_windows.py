import numpy as np
import pandas as pd
import pytest

from pipeline.config.windows import WindowParams
from pipeline.data.horizon_windows import ChainError, chain_pieces, horizon_table
from pipeline.data.window_table import conform
from pipeline.data.windows import count_windows

STRIDE = 30


def window(window_id: int, scene: str, track: int, first_frame: int, length: int = 4) -> pd.DataFrame:
    frames = first_frame + STRIDE * np.arange(length)
    return pd.DataFrame({"window_id": window_id, "scene_id": scene, "track_id": track,
                         "step": np.arange(length), "frame": frames, "x": frames / 10.0, "y": 0.0,
                         "split": "train", "t_f": 2, "source": "release"})


def table(*windows: pd.DataFrame) -> pd.DataFrame:
    return conform(pd.concat(windows, ignore_index=True))


def test_contiguous_windows_chain_into_one_piece():
    windows = table(window(0, "coupa_3", 1, 0), window(1, "coupa_3", 1, 4 * STRIDE),
                    window(2, "coupa_3", 1, 8 * STRIDE))
    pieces = chain_pieces(windows, length=4, stride=STRIDE)
    assert pieces["piece"].nunique() == 1
    assert pieces["sub"].tolist() == list(range(12)) and set(pieces["piece_len"]) == {12}


def test_gaps_and_other_tracks_start_new_pieces():
    windows = table(window(0, "coupa_3", 1, 0), window(1, "coupa_3", 1, 5 * STRIDE),  # gap
                    window(2, "coupa_3", 2, 4 * STRIDE), window(3, "hyang_4", 1, 4 * STRIDE))
    pieces = chain_pieces(windows, length=4, stride=STRIDE)
    assert pieces["piece"].nunique() == 4
    assert set(pieces["piece_len"]) == {4}


def test_wrong_window_length_stops():
    windows = table(window(0, "coupa_3", 1, 0), window(1, "coupa_3", 1, 4 * STRIDE, length=3))
    with pytest.raises(ChainError, match="1 window\\(s\\) not 4 steps, e.g. window 1 has 3"):
        chain_pieces(windows, length=4, stride=STRIDE)


def test_break_inside_a_window_stops():
    broken = window(0, "coupa_3", 1, 0)
    broken.loc[2:, "frame"] += 1
    with pytest.raises(ChainError, match="window 0: chain break inside the window"):
        chain_pieces(table(broken), length=4, stride=STRIDE)


def test_duplicate_frame_stops():
    windows = table(window(0, "coupa_3", 1, 0), window(1, "coupa_3", 1, 3 * STRIDE))  # overlap
    with pytest.raises(ChainError, match="coupa_3 track 1: frame 90 appears in more than one"):
        chain_pieces(windows, length=4, stride=STRIDE)


def test_horizon_table_uses_raw_where_present_and_chains_elsewhere():
    params = WindowParams(n_past=2, horizons=[2, 6])
    chain = chain_pieces(table(window(0, "coupa_3", 1, 0), window(1, "coupa_3", 1, 4 * STRIDE),
                               window(2, "gates_4", 1, 0)), length=4, stride=STRIDE)
    raw = window(0, "gates_4", 7, 0).assign(source="raw", t_f=2)
    short = horizon_table(conform(raw), chain, {"gates_4"}, 2, params, set())
    # gates_4 has raw data: its chained window is not used; coupa_3's 8-step piece gives 2 windows.
    assert count_windows(short, ["source", "scene_id"]) == {"raw": {"gates_4": 1},
                                                            "release_chain": {"coupa_3": 2}}
    assert short["window_id"].nunique() == 3
    long = horizon_table(conform(raw.iloc[:0]), chain, {"gates_4"}, 6, params, set())
    assert count_windows(long, ["source"]) == {"release_chain": 1}
