import numpy as np
import pandas as pd
import pytest

from pipeline.config.windows import WindowParams
from pipeline.data.tracks import build_tracks
from pipeline.data.window_table import to_arrays
from pipeline.data.windows import ReleaseError, count_windows, cut_pieces, cut_windows, raw_windows, validate_release
from tests.fixtures import STRIDE, annotation_lines, release_rows, write_annotations


def tracks_table(rows):
    """(scene_id, track_id, frame, label, lost) rows -> a minimal tracks table, x = frame."""
    table = pd.DataFrame(rows, columns=["scene_id", "track_id", "frame", "label", "lost"])
    return table.assign(x=table["frame"].astype(float), y=0.0)


def test_pieces_split_at_gaps_and_keep_every_30th_frame():
    rows = [("gates_2", 1, f, "Pedestrian", 0) for f in range(0, 95)]  # contiguous 0..94
    rows += [("gates_2", 1, f, "Pedestrian", 0) for f in range(97, 160)]  # gap of 3 frames
    pieces = cut_pieces(tracks_table(rows), "Pedestrian", STRIDE)
    assert pieces["frame"].tolist() == [0, 30, 60, 90, 97, 127, 157]
    assert pieces["piece_len"].tolist() == [4] * 4 + [3] * 3
    assert pieces["sub"].tolist() == [0, 1, 2, 3, 0, 1, 2]


def test_pieces_filter_label_and_lost_and_split_tracks():
    rows = [("gates_2", 1, f, "Pedestrian", int(40 <= f < 50)) for f in range(0, 100)]
    rows += [("gates_2", 2, f, "Biker", 0) for f in range(0, 100)]
    rows += [("gates_2", 3, f, "Pedestrian", 0) for f in range(100, 130)]  # follows track 1's frames
    pieces = cut_pieces(tracks_table(rows), "Pedestrian", STRIDE)
    assert pieces.groupby("track_id")["frame"].apply(list).to_dict() == {
        1: [0, 30, 50, 80], 3: [100]}
    assert pieces["piece"].nunique() == 3  # lost frames split track 1; track 3 is its own piece


def test_windows_do_not_overlap_and_drop_short_tails():
    rows = [("gates_2", 1, f, "Pedestrian", 0) for f in range(0, 23 * STRIDE)]  # 23 steps
    windows = cut_windows(cut_pieces(tracks_table(rows), "Pedestrian", STRIDE), length=10)
    assert windows["window_key"].nunique() == 2
    firsts = windows.groupby("window_key")["frame"].min().sort_values().tolist()
    assert firsts == [0, 10 * STRIDE]
    assert windows["step"].tolist() == list(range(10)) * 2


def test_raw_windows_schema_splits_and_arrays(tmp_path):
    write_annotations(tmp_path, "gates", 2, annotation_lines(1, range(0, 40 * STRIDE), 5, 5, 0.1, 0))
    write_annotations(tmp_path, "gates", 8, annotation_lines(1, range(0, 12 * STRIDE), 5, 5, 0, 0.1))
    write_annotations(tmp_path, "hyang", 12, annotation_lines(1, range(0, 12 * STRIDE), 5, 5, 0, 0))
    params = WindowParams(horizons=[5, 30])
    tables = raw_windows(build_tracks(tmp_path), params, val_videos={"gates_8"})
    table5, outside5 = tables[5]
    assert count_windows(table5, ["split"]) == {"test": 4, "val": 1}
    assert outside5 == 1  # hyang_12 is outside the TrajNet split
    assert set(table5["source"]) == {"raw"} and set(table5["t_f"]) == {5}
    arrays = to_arrays(table5, n_past=5)
    assert arrays.past.shape == (5, 5, 2) and arrays.future.shape == (5, 5, 2)
    # gates_2 moves 0.1 px per raw frame in x: 3 px per 1 FPS step, continuous from past to future.
    gates = arrays.scene_id == "gates_2"
    steps = np.diff(np.concatenate([arrays.past[gates], arrays.future[gates]], axis=1)[..., 0], axis=1)
    np.testing.assert_allclose(steps, 3.0, atol=1.0)
    assert count_windows(tables[30][0], ["split"]) == {"test": 1}


def test_release_validation():
    good = release_rows("gates_2", 1, 0, 0, 0.0, 0.0, 1.0, 0.0, meta_id=0)
    validate_release(good, "ok.pkl", 35, STRIDE)
    with pytest.raises(ReleaseError, match="1 window\\(s\\) not 35 steps"):
        validate_release(good.iloc[:-1], "short.pkl", 35, STRIDE)
    skipped = good.assign(frame=good["frame"].where(good.index != 3, good["frame"] + 1))
    with pytest.raises(ReleaseError, match="do not all step by 30"):
        validate_release(skipped, "skip.pkl", 35, STRIDE)
    with pytest.raises(ReleaseError, match="columns"):
        validate_release(good.rename(columns={"x": "X"}), "cols.pkl", 35, STRIDE)
