import re

import pytest

from pipeline.data.tracks import AnnotationError, build_tracks, parse_annotations
from pipeline.stages import tracks as tracks_stage
from tests.fixtures import annotation_lines, write_annotations, write_manifest


def test_box_centres_and_all_rows_kept(tmp_path):
    lines = ['7 10 20 30 60 5 0 1 0 "Pedestrian"', '8 0 0 4 4 5 1 0 1 "Biker"']
    write_annotations(tmp_path, "gates", 2, lines)
    tracks = build_tracks(tmp_path)
    assert len(tracks) == 2
    first = tracks.iloc[0]
    assert (first.scene_id, first.video, first.track_id, first.frame) == ("gates_2", 2, 7, 5)
    assert (first.x, first.y) == (20.0, 40.0)
    assert tracks["lost"].tolist() == [0, 1] and tracks["occluded"].tolist() == [1, 0]
    assert tracks["label"].tolist() == ["Pedestrian", "Biker"]


def test_compat_drop_first_row_drops_exactly_one_row_per_file(tmp_path):
    write_annotations(tmp_path, "gates", 2, annotation_lines(1, range(10), 0, 0, 1, 0))
    write_annotations(tmp_path, "little", 0, annotation_lines(1, range(5), 0, 0, 1, 0))
    assert len(build_tracks(tmp_path)) == 15
    dropped = build_tracks(tmp_path, drop_first_row=True)
    assert len(dropped) == 13
    assert dropped.groupby("scene_id")["frame"].min().tolist() == [1, 1]


@pytest.mark.parametrize("bad_line", [
    '1 10 20 30 "Pedestrian"',                 # too few fields
    '1 10 20 30 40 5 0 0 0 "Pedestrian" 9',    # too many fields
    '1 10 20 30 40 5 2 0 0 "Pedestrian"',      # lost not 0/1
    '1 10 20 30 40 5 0 0 0 "Unicorn"',         # unknown label
    '1 1x0 20 30 40 5 0 0 0 "Pedestrian"',     # not a number
])
def test_malformed_line_names_file_and_line(tmp_path, bad_line):
    lines = annotation_lines(1, range(3), 0, 0, 1, 0)
    lines.insert(2, bad_line)
    path = write_annotations(tmp_path, "gates", 2, lines)
    with pytest.raises(AnnotationError, match=rf"{path}:3: malformed annotation line"):
        parse_annotations(path)


def test_truncated_file(tmp_path):
    path = write_annotations(tmp_path, "gates", 2, annotation_lines(1, range(3), 0, 0, 1, 0))
    path.write_text(path.read_text() + '1 10 20 30 40 9 0 0 0 "Pedes')
    with pytest.raises(AnnotationError, match=rf"{path}:4: malformed"):
        parse_annotations(path)
    # Cut right after a complete row: every field present but no final newline.
    path.write_text(path.read_text().rsplit("\n", 1)[0])
    with pytest.raises(AnnotationError, match=rf"{path}:3: file ends mid-line"):
        parse_annotations(path)


def test_empty_file_and_missing_annotations(tmp_path):
    path = write_annotations(tmp_path, "gates", 2, [])
    path.write_text("")
    with pytest.raises(AnnotationError, match="empty file"):
        build_tracks(tmp_path)
    with pytest.raises(AnnotationError, match="no \\*/video\\*/annotations.txt"):
        build_tracks(tmp_path / "elsewhere")


@pytest.mark.parametrize("extra, message", [
    ('1 10 20 30 40 1 0 0 0 "Pedestrian"', r":2, 4: track 1 has two different boxes in frame 1"),
    ('1 31 34 41 54 1 0 0 0 "Pedestrian"', r":2, 4: track 1 has the same box twice in frame 1"),
    ('2 30 20 10 40 1 0 0 0 "Pedestrian"', r":4: impossible box of track 2 in frame 1: x 30..10"),
    ('2 10 20 30 20 1 0 0 0 "Pedestrian"', r":4: impossible box of track 2 in frame 1: x 10..30, y 20..20"),
    ('1 10 20 36 44 9 0 0 0 "Biker"', r":4: track 1 is labelled 'Biker' here but 'Pedestrian' on line 1"),
    ('3 10 20 36 44 9 0 0 0 "Biker"', None),  # another track, another label: fine
])
def test_rows_that_contradict_each_other_stop_the_stage(tmp_path, monkeypatch, extra, message):
    """Each caught by `tracks`, which names the file and lines and writes nothing."""
    lines = annotation_lines(1, range(3), 10, 20, 26, 24) + [extra]
    path = write_annotations(tmp_path / "sdd", "gates", 2, lines)
    if message is None:
        assert len(parse_annotations(path)) == 4
        return
    with pytest.raises(AnnotationError, match=rf"^{re.escape(str(path))}{message}"):
        parse_annotations(path)
    monkeypatch.chdir(tmp_path)
    write_manifest(tmp_path / "sdd", tmp_path / "sdd.sha256")
    (tmp_path / "params.yaml").write_text("compat: {drop_first_row: false}\ndata: {ind: {}}\n")
    with pytest.raises(SystemExit, match=rf"tracks: {re.escape(str(path))}{message}"):
        tracks_stage.main(["--sdd", str(tmp_path / "sdd"), "--manifest", "sdd.sha256",
                           "--out", "out/sdd.parquet", "--sources", "out/sdd_sources.json"])
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_a_number_beyond_64_bits_names_file_and_line(tmp_path):
    lines = annotation_lines(1, range(3), 0, 0, 1, 0)
    lines.insert(1, '99999999999999999999 10 20 30 40 5 0 0 0 "Pedestrian"')
    path = write_annotations(tmp_path, "gates", 2, lines)
    with pytest.raises(AnnotationError, match=rf"^{re.escape(str(path))}:2: a number beyond 64-bit integers"):
        parse_annotations(path)
