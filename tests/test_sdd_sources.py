"""Your own SDD copy beside the fetched mirror (`data.sdd.path`, `pipeline.data.sdd_sources`, stages
`tracks` and `audit`), on a miniature official download written here.

The fetched mirror is `tests.fixtures.write_mirror`'s: bookstore_0 and gates_2, both pinned by its
manifest. The copy (`write_copy`), laid out `annotations/<scene>/video<k>/{annotations.txt,
reference.jpg,video.mov}` as the official download:
- gates_2: the mirror's bytes (pinned and identical);
- coupa_3 (train), hyang_0 (test), nexus_10 (outside the TrajNet split): beyond the manifest, two
  pedestrians of 36 s each at 30 FPS (one t_f = 30 window each);
- a `video.mov` in each video folder (coupa_3's a dangling link that cannot even be read) and a
  stray file: ignored. bookstore_0 is not in the copy (it stays the mirror's).
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pipeline.config.data import DataParams, SddParams
from pipeline.config.loading import ParamsError, from_dict
from pipeline.config.windows import WindowParams
from pipeline.data.checksums import read_manifest
from pipeline.data.horizon_windows import chain_pieces, horizon_table
from pipeline.data.sdd_sources import (ORIGIN_COPY, ORIGIN_FETCHED, ORIGIN_IDENTICAL, choose_videos,
                                       copy_images)
from pipeline.data.tracks import build_tracks
from pipeline.data.window_table import conform
from pipeline.data.windows import count_windows, raw_windows
from pipeline.stages import audit as audit_stage
from pipeline.stages import tracks as tracks_stage
from tests.fixtures import STRIDE, annotation_lines, write_annotations, write_mirror

EXTRA = [("coupa", 3), ("hyang", 0), ("nexus", 10)]  # videos beyond the manifest
WINDOWS_YAML = ("windows: {n_past: 5, horizons: [5, 30], raw_fps: 30, target_fps: 1, "
                "label: Pedestrian, release_horizon: 30}\nsplit: {val_videos: []}\n")


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_copy(copy: Path, mirror_sdd: Path) -> Path:
    """The miniature official download described in the module docstring."""
    for name in ("annotations.txt", "reference.jpg"):
        target = copy / "annotations/gates/video2" / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(mirror_sdd / "annotations/gates/video2" / name, target)
    (copy / "annotations/gates/video2/video.mov").write_bytes(b"\x00\x00\x00\x18ftypqt  " * 64)
    for i, (scene, video) in enumerate(EXTRA):
        path = write_annotations(copy, scene, video, [
            *annotation_lines(1, range(0, 36 * STRIDE), 100.0 + 50 * i, 200.0, 0.04, 0.01),
            *annotation_lines(2, range(300, 300 + 36 * STRIDE), 300.0, 50.0 + 20 * i, -0.03, 0.02),
            *annotation_lines(3, range(0, 10 * STRIDE), 20.0, 20.0, 0.2, 0.0, label="Biker"),
        ])
        (path.parent / "reference.jpg").write_bytes(f"\xff\xd8{scene}{video}\xff\xd9".encode())
        if scene != "coupa":
            (path.parent / "video.mov").write_bytes(b"moov" * 256)
    (copy / "annotations/coupa/video3/video.mov").symlink_to(copy / "nowhere.mov")
    (copy / "README.txt").write_text("Stanford Drone Dataset, official download\n")
    return copy


@pytest.fixture
def sdd(tmp_path, monkeypatch):
    """Mirror, manifests and copy under tmp_path, which is the working directory."""
    write_mirror(tmp_path / "mirror", tmp_path / "manifests")
    write_copy(tmp_path / "copy", tmp_path / "mirror/sdd")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def write_params(root: Path, path: str) -> None:
    (root / "params.yaml").write_text(WINDOWS_YAML + "compat: {drop_first_row: false}\n"
                                      f"data: {{ind: {{}}, sdd: {{path: '{path}'}}}}\n")


def run_tracks(root: Path) -> tuple[pd.DataFrame, dict]:
    tracks_stage.main(["--sdd", "mirror/sdd", "--manifest", "manifests/sdd.sha256",
                       "--out", "out/sdd.parquet", "--sources", "out/sdd_sources.json"])
    return (pd.read_parquet(root / "out/sdd.parquet"),
            json.loads((root / "out/sdd_sources.json").read_text()))


# ---------------------------------------------------------------------------------------------
# Parameters


def test_sdd_params():
    assert not SddParams().provided and SddParams("x").provided
    assert from_dict(SddParams, {"path": None}, "data.sdd").path == ""
    with pytest.raises(ParamsError, match=r"^data.sdd.path: expected str or null, got int 3$"):
        from_dict(SddParams, {"path": 3}, "data.sdd")
    with pytest.raises(ValueError, match=r"path must be a folder path \(a string\), got 3"):
        SddParams(3)
    with pytest.raises(ParamsError, match=r"data.sdd: unknown key\(s\) \['pth'\]"):
        from_dict(DataParams, {"ind": {}, "sdd": {"pth": "x"}}, "data")
    # A params file from before data.sdd existed still loads: no copy.
    assert from_dict(DataParams, {"ind": {}}, "data").sdd == SddParams("")


# ---------------------------------------------------------------------------------------------
# Choosing the files


def test_each_video_is_parsed_from_the_mirror_or_the_copy(sdd):
    manifest = read_manifest(sdd / "manifests/sdd.sha256")
    videos = choose_videos(sdd / "mirror/sdd", manifest, sdd / "copy")
    assert [v.scene_id for v in videos] == ["bookstore_0", "coupa_3", "gates_2", "hyang_0", "nexus_10"]
    by_id = {v.scene_id: v for v in videos}
    mirror, copy = sdd / "mirror/sdd/annotations", sdd / "copy/annotations"
    assert by_id["bookstore_0"].origin == ORIGIN_FETCHED
    assert by_id["bookstore_0"].path == mirror / "bookstore/video0/annotations.txt"
    # Identical to the pin: parsed once, from the mirror.
    gates = by_id["gates_2"]
    assert (gates.origin, gates.pinned, gates.path) == (
        ORIGIN_IDENTICAL, True, mirror / "gates/video2/annotations.txt")
    assert gates.sha256 == manifest["annotations/gates/video2/annotations.txt"]
    for scene, video in EXTRA:
        extra = by_id[f"{scene}_{video}"]
        path = copy / scene / f"video{video}" / "annotations.txt"
        assert (extra.origin, extra.pinned, extra.path) == (ORIGIN_COPY, False, path)
        assert extra.sha256 == sha256(path)
    # Without a copy: the mirror's videos, as they are.
    alone = choose_videos(sdd / "mirror/sdd", manifest, None)
    assert [(v.scene_id, v.origin) for v in alone] == [("bookstore_0", ORIGIN_FETCHED),
                                                       ("gates_2", ORIGIN_FETCHED)]


def test_reference_images_are_checked_or_fingerprinted_and_videos_ignored(sdd):
    manifest = read_manifest(sdd / "manifests/sdd.sha256")
    images = {i.rel: i for i in copy_images(sdd / "copy", manifest)}
    assert sorted(images) == [f"annotations/{s}/video{k}/reference.jpg"
                              for s, k in sorted(EXTRA + [("gates", 2)])]
    assert images["annotations/gates/video2/reference.jpg"].pinned
    coupa = images["annotations/coupa/video3/reference.jpg"]
    assert not coupa.pinned and coupa.sha256 == sha256(sdd / "copy" / coupa.rel)
    assert copy_images(None, manifest) == []


# ---------------------------------------------------------------------------------------------
# Stage tracks


def test_tracks_stage_parses_the_copy_and_records_where_each_video_came_from(sdd):
    write_params(sdd, "copy")  # relative to the repository root (the working directory)
    tracks, sources = run_tracks(sdd)
    mirror_tracks = build_tracks(sdd / "mirror/sdd")
    assert tracks["scene_id"].unique().tolist() == ["bookstore_0", "coupa_3", "gates_2", "hyang_0",
                                                    "nexus_10"]
    pd.testing.assert_frame_equal(  # the mirror's videos exactly as before
        tracks[tracks["scene_id"].isin(["bookstore_0", "gates_2"])].reset_index(drop=True),
        mirror_tracks)
    coupa = tracks[tracks["scene_id"] == "coupa_3"]
    assert len(coupa) == 2 * 36 * STRIDE + 10 * STRIDE and set(coupa["label"]) == {"Pedestrian", "Biker"}

    assert sources["copy"] == {"provided": True, "path": "copy"}
    assert sources["totals"]["per_origin"] == {ORIGIN_FETCHED: 1, ORIGIN_IDENTICAL: 1, ORIGIN_COPY: 3}
    assert sources["totals"]["videos"] == 5 and sources["totals"]["rows"] == len(tracks)
    assert sources["totals"]["reference_images"] == {"pinned": 1, "fingerprinted": 3}
    rows = tracks.groupby("scene_id").size()
    for video, record in sources["videos"].items():
        assert record["rows"] == rows[video]
    nexus = sources["videos"]["nexus_10"]
    assert nexus == {"origin": ORIGIN_COPY, "file": "annotations/nexus/video10/annotations.txt",
                     "pinned": False, "rows": int(rows["nexus_10"]),
                     "sha256": sha256(sdd / "copy/annotations/nexus/video10/annotations.txt")}
    gates = sources["videos"]["gates_2"]
    assert gates["origin"] == ORIGIN_IDENTICAL and gates["pinned"]
    assert sources["reference_images"]["annotations/hyang/video0/reference.jpg"] == {
        "sha256": sha256(sdd / "copy/annotations/hyang/video0/reference.jpg"), "pinned": False}
    text = (sdd / "out/sdd_sources.json").read_text()
    assert "video.mov" not in text and "README" not in text


def test_an_empty_path_gives_the_mirrors_tracks_unchanged(sdd):
    write_params(sdd, "")
    tracks, sources = run_tracks(sdd)
    pd.testing.assert_frame_equal(tracks, build_tracks(sdd / "mirror/sdd"))
    assert sources["copy"] == {"provided": False, "path": ""}
    assert sources["totals"]["per_origin"] == {ORIGIN_FETCHED: 2}
    assert sources["reference_images"] == {}
    manifest = read_manifest(sdd / "manifests/sdd.sha256")
    assert {v: r["sha256"] for v, r in sources["videos"].items()} == {
        "bookstore_0": manifest["annotations/bookstore/video0/annotations.txt"],
        "gates_2": manifest["annotations/gates/video2/annotations.txt"]}


@pytest.mark.parametrize("rel", ["annotations/gates/video2/annotations.txt",
                                 "annotations/gates/video2/reference.jpg"])
def test_a_copy_file_that_differs_from_its_pin_stops_the_stage(sdd, rel):
    path = sdd / "copy" / rel
    path.write_bytes(path.read_bytes() + b"\n")
    pin = read_manifest(sdd / "manifests/sdd.sha256")[rel]
    write_params(sdd, str(sdd / "copy"))
    message = (rf"^tracks: {re.escape(str(path))}: SHA-256 {sha256(path)} differs from the "
               rf"manifest's {pin} for {re.escape(rel)}: this file of your SDD copy")
    with pytest.raises(SystemExit, match=message):
        run_tracks(sdd)
    assert not (sdd / "out").exists()


@pytest.mark.parametrize("make, expected", [
    (lambda root: "missing", r"data.sdd.path: missing is not a folder"),
    (lambda root: (root / "empty").mkdir() or "empty",
     r"data.sdd.path: empty holds no annotations/<scene>/video<k>/annotations.txt"),
    (lambda root: "copy/annotations",  # one level too deep
     r"data.sdd.path: copy/annotations holds no annotations/<scene>/video<k>/annotations.txt"),
])
def test_a_copy_path_that_is_no_sdd_copy_is_named(sdd, make, expected):
    write_params(sdd, make(sdd))
    with pytest.raises(SystemExit, match=rf"^tracks: {expected}"):
        run_tracks(sdd)
    assert not (sdd / "out").exists()


# ---------------------------------------------------------------------------------------------
# What the extra videos change downstream


def release_window(window_id: int, scene: str, track: int, first_frame: int) -> pd.DataFrame:
    frames = first_frame + STRIDE * np.arange(35)
    return pd.DataFrame({"window_id": window_id, "scene_id": scene, "track_id": track,
                         "step": np.arange(35), "frame": frames, "x": frames / 10.0, "y": 0.0,
                         "split": "train", "t_f": 30, "source": "release"})


def test_horizon_windows_are_raw_on_the_copys_videos_and_chained_only_elsewhere(sdd):
    write_params(sdd, "copy")
    tracks, _ = run_tracks(sdd)
    params = WindowParams(horizons=[5, 30])
    raw = raw_windows(tracks, params, set())
    # The release has windows on coupa_3 (now raw) and on deathCircle_0 (no raw tracks).
    release = conform(pd.concat([release_window(0, "coupa_3", 9, 0),
                                 release_window(1, "deathCircle_0", 4, 0)], ignore_index=True))
    chain = chain_pieces(release, params.window_length(30), params.stride)
    raw_videos = set(tracks["scene_id"])
    for t_f in (5, 30):
        table = horizon_table(raw[t_f][0], chain, raw_videos, t_f, params, set())
        counts = count_windows(table, ["source", "scene_id"])
        assert set(counts) == {"raw", "release_chain"}
        assert set(counts["release_chain"]) == {"deathCircle_0"}
        assert {"coupa_3", "hyang_0"} <= set(counts["raw"])
        assert "nexus_10" not in counts["raw"]  # outside the TrajNet split: counted, dropped
    assert count_windows(horizon_table(raw[30][0], chain, raw_videos, 30, params, set()),
                         ["source", "scene_id"])["raw"]["coupa_3"] == 2


def test_audit_reparses_the_same_files_and_covers_the_copys_videos(sdd):
    write_params(sdd, "copy")
    tracks, _ = run_tracks(sdd)
    raw, _ = raw_windows(tracks, WindowParams(horizons=[30]), set())[30]
    windows = sdd / "windows"
    windows.mkdir()
    raw.to_parquet(windows / "raw_tf30.parquet", index=False)
    raw.assign(source="release").to_parquet(windows / "release_tf30.parquet", index=False)
    audit_stage.main(["--sdd", "mirror/sdd", "--manifest", "manifests/sdd.sha256",
                      "--windows", str(windows), "--out", "out/audit.json"])
    audit = json.loads((sdd / "out/audit.json").read_text())
    assert audit["totals"]["videos_with_raw"] == 5  # nexus_10 too, though outside the split
    assert sorted(audit["videos"]) == ["bookstore_0", "coupa_3", "gates_2", "hyang_0"]
    assert audit["videos"]["coupa_3"] == {"ours": 2, "release": 2, "exact_matches": 2}
    assert audit["videos"]["hyang_0"] == {"ours": 2, "release": 2, "exact_matches": 2}
    assert audit["totals"]["unexplained_mismatches"] == 0

    # A copy file changed after `tracks` ran stops the audit too (same choice of files).
    path = sdd / "copy/annotations/gates/video2/annotations.txt"
    path.write_bytes(path.read_bytes() + b"\n")
    (sdd / "out/audit.json").unlink()
    with pytest.raises(SystemExit, match=r"^audit: copy/annotations/gates/video2/annotations.txt: SHA-256 "):
        audit_stage.main(["--sdd", "mirror/sdd", "--manifest", "manifests/sdd.sha256",
                          "--windows", str(windows), "--out", "out/audit.json"])
    assert not (sdd / "out/audit.json").exists()
