"""inD, the long-term benchmark on another dataset (`IND`): its windows, cut from the user's own
copy of inD (stage `ind_windows`), the folder's index as the runners read it (`read_index`,
`read_windows`) and what scoring its stored predictions needs (`Ind.scored_table`).

inD (the Intersection Drone Dataset) is licence-restricted: this project never fetches, stores or
redistributes it. A user who holds a copy sets `data.ind.path` in params.yaml to the release folder
(the one holding `data/XX_tracks.csv`); with the path empty the stage still succeeds and writes an
explicit "not provided" record and empty tables, so every later stage and the report run.

Recipe (paper, "Intersection Drone Dataset"; upstream fact 7), per recording `XX` of
`<path>/data/`, in the official inD format (`XX_tracks.csv`, `XX_tracksMeta.csv`,
`XX_recordingMeta.csv`, `XX_background.png`):
- keep the tracks whose `class` is "pedestrian" (tracksMeta);
- world metres -> pixels of the recording's background image: x_px = x / (orthoPxToMeter * 12),
  y_px = -y / (orthoPxToMeter * 12) (the backgrounds are the orthophoto downscaled 12 times, and
  the world y axis points up where image rows go down);
- split a track wherever its frame step is not 1, keep every (frameRate / target_fps)-th frame of
  each piece (25 -> 1 FPS), cut non-overlapping windows of n_p + t_f steps from each piece's start
  (the SDD recipe, `pipeline.data.windows.cut_pieces` / `cut_windows`);
- split: test = location 4 (recordings 00-06, unseen in training), val = the whole train recordings
  listed in `data.ind.val_recordings` (model selection never sees test), train = the rest.
One scene per recording (`ind_loc<location>_rec<XX>`); its background image is the scene image.

Outputs (`--out`, replaced as a whole only when everything succeeded): `tf30.parquet` (the
benchmark, t_f = 30 s) and `tf5.parquet` (t_f = 5 s: R-PECNet's PECNet trains on it) in the shared
window-table schema (`pipeline.data.window_table`; `frame` is the raw 25 FPS frame), `index.json`
(scenes: recording, location, split, image size, files), `backgrounds/<scene>.png` and, with
`data.ind.labels`, the validated masks `labels/<scene>.png`. `--metrics`: window counts, what was
kept and a fingerprint of the files read.

The copy lies outside the repository, so DVC cannot watch it: after changing the files at the same
path, run `dvc repro -f ind_windows`; the fingerprint in the metrics then shows the change.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
import pandas as pd

from pipeline.benchmarks.base import SceneMasks, ScoredTable, class_values
from pipeline.benchmarks.long_term import Background, LongTermBenchmark, LongTermData
from pipeline.data.labels import validate_mask
from pipeline.data.window_table import COLUMNS, WindowArrays, conform, select_split, to_arrays
from pipeline.data.windows import count_windows, cut_pieces, cut_windows
from pipeline.io import (IntermediateError, atomic_dir, index_value, read_json_index,
                         write_json)

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.data import IndParams
    from pipeline.config.ind_benchmark import IndBenchmarkParams
    from pipeline.config.segmentation import SegmentationParams
    from pipeline.config.windows import WindowParams
    from pipeline.config.ynet import YnetSettings

# Columns of the official inD format this stage reads (the files hold more; see the inD
# documentation: tracks also carry heading, width, length, velocities and accelerations).
TRACK_COLUMNS = {"recordingId": "int64", "trackId": "int64", "frame": "int64",
                 "xCenter": "float64", "yCenter": "float64"}
TRACKS_META_COLUMNS = {"recordingId": "int64", "trackId": "int64", "class": "str"}
RECORDING_META_COLUMNS = {"recordingId": "int64", "locationId": "int64", "frameRate": "float64",
                          "orthoPxToMeter": "float64"}

PEDESTRIAN = "pedestrian"  # the one `class` kept (others: car, truck_bus, bicycle)
BACKGROUND_SCALE = 12  # XX_background.png is the orthophoto downscaled 12x (upstream fact 7)
# Paper: location 4 (recordings 00-06) is used only at test time, to test on an unseen place.
TEST_LOCATION = 4
LONG_TERM_HORIZON = 30  # t_f (s) of the benchmark (paper Table 3)
RPECNET_HORIZON = 5  # t_f (s) of the PECNet that R-PECNet rolls out (= RecurrentPecnet.base_horizon)
HORIZONS = (LONG_TERM_HORIZON, RPECNET_HORIZON)
SOURCE = "raw"  # window-table `source`: cut here from the annotations
RECORDING_FILE = re.compile(r"^(?P<recording>\d{2})_recordingMeta\.csv$")
MASK_FILE = re.compile(r"^(?P<recording>\d{2})_background_mask\.png$")

UNLABELLED_NOTE = ("no inD label masks (data.ind.labels empty): the SDD-trained U-Net segments the "
                   "inD backgrounds unchanged (the paper fine-tunes it on labelled train-location "
                   "backgrounds)")
NOT_PROVIDED_REASON = (
    "inD is licence-restricted and not redistributed; set data.ind.path in params.yaml to your copy "
    "of the inD release (the folder holding data/XX_tracks.csv) and run `dvc repro`")


class IndError(ValueError):
    """The inD copy (or the settings pointing at it) cannot be used as it is."""


@dataclass(frozen=True)
class Recording:
    """One inD recording: its metadata and its pedestrian positions in background pixels."""

    recording: int
    location: int
    frame_rate: float
    ortho_px_to_meter: float
    stride: int  # raw frames per target step
    background: Path
    image_hw: tuple[int, int]
    positions: pd.DataFrame  # scene_id, track_id, frame, x, y (pedestrians only)
    class_counts: dict[str, int]  # tracks per class, before filtering

    @property
    def scene_id(self) -> str:
        return scene_id(self.location, self.recording)


def scene_id(location: int, recording: int) -> str:
    return f"ind_loc{location}_rec{recording:02d}"


def world_to_pixels(x, y, ortho_px_to_meter: float, scale: float = BACKGROUND_SCALE):
    """inD world metres -> background-image pixels (x to the right, y down the image rows).

    One background pixel is `ortho_px_to_meter * scale` metres; the world y axis points up, image
    rows go down, hence the sign.
    """
    metres_per_pixel = ortho_px_to_meter * scale
    return np.asarray(x) / metres_per_pixel, -np.asarray(y) / metres_per_pixel


def frame_stride(frame_rate: float, target_fps: int, where: str) -> int:
    """Raw frames per target step; an error unless the frame rate is a whole multiple of the target."""
    ratio = frame_rate / target_fps
    if not (math.isfinite(ratio) and ratio >= 1 and abs(ratio - round(ratio)) < 1e-9):
        raise IndError(f"{where}: frameRate {frame_rate:g} is not a multiple of the target "
                       f"{target_fps} FPS (windows.target_fps)")
    return int(round(ratio))


def read_table(path: Path, columns: dict[str, str]) -> pd.DataFrame:
    """The `columns` (name -> dtype) of a CSV, or an IndError naming the file and what is wrong."""
    if not path.is_file():
        raise IndError(f"{path}: missing file (expected the official inD layout <path>/data/XX_*.csv)")
    try:
        header = pd.read_csv(path, nrows=0).columns
    except ValueError as e:  # empty file, undecodable bytes, broken quoting
        raise IndError(f"{path}: cannot be read as a CSV file ({e})") from e
    missing = [c for c in columns if c not in header]
    if missing:
        raise IndError(f"{path}: missing column(s) {missing}; found {list(header)}")
    try:
        return pd.read_csv(path, usecols=list(columns), dtype=columns)
    except ValueError as e:  # e.g. a non-numeric value in a numeric column
        raise IndError(f"{path}: cannot be read as the inD CSV format ({e})") from e


def csv_lines(rows: pd.Index) -> list[int]:
    """File line numbers of the first (at most 5) data rows `rows` of a CSV read whole (line 1 is
    the header)."""
    return [int(i) + 2 for i in rows[:5]]


def check_track_rows(tracks: pd.DataFrame, path: Path) -> None:
    """Every position finite, every (trackId, frame) once: a NaN would reach the windows as a
    position, and a track twice in one frame has no single position to give."""
    bad = ~np.isfinite(tracks[["xCenter", "yCenter"]].to_numpy()).all(axis=1)
    if bad.any():
        raise IndError(f"{path}: {int(bad.sum())} row(s) with a non-finite xCenter or yCenter, on "
                       f"line(s) {csv_lines(tracks.index[bad])}")
    twice = tracks.duplicated(["trackId", "frame"], keep=False)
    if twice.any():
        first = tracks.loc[twice].iloc[0]
        same = twice & tracks["trackId"].eq(first["trackId"]) & tracks["frame"].eq(first["frame"])
        raise IndError(f"{path}: {int(twice.sum())} row(s) repeat a (trackId, frame), e.g. trackId "
                       f"{int(first['trackId'])} frame {int(first['frame'])} on lines "
                       f"{csv_lines(tracks.index[same])}")


def list_recordings(data_dir: Path) -> list[int]:
    """The recording numbers of `<path>/data` (one XX_recordingMeta.csv each)."""
    if not data_dir.is_dir():
        raise IndError(f"{data_dir}: not a folder; data.ind.path must be the inD release folder "
                       "holding data/XX_tracks.csv")
    found = sorted(int(m["recording"]) for p in data_dir.iterdir()
                   if (m := RECORDING_FILE.match(p.name)))
    if not found:
        raise IndError(f"{data_dir}: no XX_recordingMeta.csv; expected the official inD layout "
                       "data/XX_tracks.csv, XX_tracksMeta.csv, XX_recordingMeta.csv, XX_background.png")
    return found


def read_recording(data_dir: Path, recording: int, target_fps: int) -> Recording:
    """Read and check one recording; pedestrians only, positions in background pixels."""
    prefix = f"{recording:02d}_"
    meta_path = data_dir / f"{prefix}recordingMeta.csv"
    meta = read_table(meta_path, RECORDING_META_COLUMNS)
    if len(meta) != 1:
        raise IndError(f"{meta_path}: expected one row, found {len(meta)}")
    row = meta.iloc[0]
    if int(row["recordingId"]) != recording:
        raise IndError(f"{meta_path}: recordingId {row['recordingId']} differs from the file name")
    frame_rate, ortho = float(row["frameRate"]), float(row["orthoPxToMeter"])
    if not (math.isfinite(ortho) and ortho > 0):
        raise IndError(f"{meta_path}: orthoPxToMeter must be a positive number, got {ortho}")
    stride = frame_stride(frame_rate, target_fps, str(meta_path))

    background = data_dir / f"{prefix}background.png"
    if not background.is_file():
        raise IndError(f"{background}: missing file (the recording's scene image)")
    image = cv2.imread(str(background), cv2.IMREAD_COLOR)
    if image is None:
        raise IndError(f"{background}: cannot be read as an image")

    tracks_meta_path = data_dir / f"{prefix}tracksMeta.csv"
    tracks_meta = read_table(tracks_meta_path, TRACKS_META_COLUMNS)
    if tracks_meta["trackId"].duplicated().any():
        raise IndError(f"{tracks_meta_path}: trackId(s) listed twice, e.g. "
                       f"{int(tracks_meta.loc[tracks_meta['trackId'].duplicated(), 'trackId'].iloc[0])}")
    tracks_path = data_dir / f"{prefix}tracks.csv"
    tracks = read_table(tracks_path, TRACK_COLUMNS)
    if not tracks["recordingId"].eq(recording).all():
        raise IndError(f"{tracks_path}: rows of another recording than {recording:02d}")
    check_track_rows(tracks, tracks_path)
    listed = tracks["trackId"].isin(tracks_meta["trackId"])
    if not listed.all():
        unknown = sorted(tracks.loc[~listed, "trackId"].unique().tolist())
        raise IndError(f"{tracks_path}: trackId(s) {unknown[:5]} have no row in {tracks_meta_path.name}")
    track_class = tracks["trackId"].map(tracks_meta.set_index("trackId")["class"])

    pedestrians = tracks.loc[track_class.eq(PEDESTRIAN)]
    x, y = world_to_pixels(pedestrians["xCenter"].to_numpy(np.float64),
                           pedestrians["yCenter"].to_numpy(np.float64), ortho)
    location = int(row["locationId"])
    positions = pd.DataFrame({
        "scene_id": scene_id(location, recording),
        "track_id": pedestrians["trackId"].to_numpy(np.int64),
        "frame": pedestrians["frame"].to_numpy(np.int64),
        "x": x, "y": y,
    })
    counts = tracks_meta["class"].value_counts()
    return Recording(recording, location, frame_rate, ortho, stride, background, image.shape[:2],
                     positions, {str(k): int(v) for k, v in counts.items()})


def assign_splits(recordings: list[Recording], val_recordings: list[int]) -> dict[str, str]:
    """scene_id -> train / val / test; val recordings must exist and lie outside the test location."""
    by_number = {r.recording: r for r in recordings}
    absent = sorted(set(val_recordings) - set(by_number))
    if absent:
        raise IndError(f"data.ind.val_recordings: recording(s) {absent} not in the inD copy "
                       f"(recordings there: {sorted(by_number)})")
    at_test = sorted(r for r in val_recordings if by_number[r].location == TEST_LOCATION)
    if at_test:
        raise IndError(f"data.ind.val_recordings: recording(s) {at_test} are at the test location "
                       f"{TEST_LOCATION}; validation must come from train locations")
    return {r.scene_id: "test" if r.location == TEST_LOCATION
            else "val" if r.recording in val_recordings else "train" for r in recordings}


def empty_table() -> pd.DataFrame:
    return conform(pd.DataFrame({name: pd.Series(dtype=dtype) for name, dtype in COLUMNS.items()}))


def window_tables(recordings: list[Recording], splits: dict[str, str], n_past: int,
                  target_fps: int) -> dict[int, pd.DataFrame]:
    """t_f -> window table for every horizon in HORIZONS."""
    parts = []
    offset = 0
    strides = pd.Series({r.scene_id: r.stride for r in recordings})
    positions = pd.concat([r.positions for r in recordings], ignore_index=True)
    for stride, group in positions.groupby(positions["scene_id"].map(strides), sort=True):
        pieces = cut_pieces(group.assign(label=PEDESTRIAN, lost=0), PEDESTRIAN, int(stride))
        pieces["piece"] += offset  # unique piece numbers across frame rates
        offset = int(pieces["piece"].max()) + 1 if len(pieces) else offset
        parts.append(pieces)
    pieces = pd.concat(parts, ignore_index=True) if parts else None
    tables = {}
    for t_f in HORIZONS:
        if pieces is None or pieces.empty:
            tables[t_f] = empty_table()
            continue
        windows = cut_windows(pieces, n_past + t_f * target_fps)
        firsts = (windows.loc[windows["step"] == 0, ["window_key", "scene_id", "track_id", "frame"]]
                  .sort_values(["scene_id", "track_id", "frame"], kind="stable"))
        ids = pd.Series(np.arange(len(firsts), dtype=np.int64), index=firsts["window_key"].to_numpy())
        tables[t_f] = conform(windows.assign(
            window_id=windows["window_key"].map(ids), split=windows["scene_id"].map(splits),
            t_f=t_f, source=SOURCE))
    return tables


def find_masks(labels_dir: Path, recordings: list[Recording]) -> dict[str, np.ndarray]:
    """scene_id -> validated mask (H, W) uint8 for every XX_background_mask.png of `labels_dir`."""
    if not labels_dir.is_dir():
        raise IndError(f"data.ind.labels = {labels_dir}: not a folder")
    by_number = {r.recording: r for r in recordings}
    masks = {}
    for path in sorted(labels_dir.glob("*_background_mask.png")):
        match = MASK_FILE.match(path.name)
        if match is None:
            raise IndError(f"{path}: not named XX_background_mask.png")
        recording = by_number.get(int(match["recording"]))
        if recording is None:
            raise IndError(f"{path}: no recording {match['recording']} in the inD copy")
        masks[recording.scene_id] = validate_mask(cv2.imread(str(path), cv2.IMREAD_UNCHANGED),
                                                  recording.image_hw, path)
    if not masks:
        raise IndError(f"data.ind.labels = {labels_dir}: no XX_background_mask.png")
    if all(r.location == TEST_LOCATION for r in recordings if r.scene_id in masks):
        raise IndError(f"data.ind.labels = {labels_dir}: no mask of a train location "
                       "(fine-tuning the segmentation net needs at least one)")
    return masks


def fingerprint(paths: list[Path]) -> dict:
    """SHA-256 of the names, sizes and modification times of the files read (cheap: no content)."""
    digest = hashlib.sha256()
    total = 0
    for path in sorted(paths):
        stat = path.stat()
        total += stat.st_size
        digest.update(f"{path.parent.name}/{path.name}\0{stat.st_size}\0{stat.st_mtime_ns}\n".encode())
    return {"sha256": digest.hexdigest(), "files": len(paths), "bytes": total,
            "of": "file names, sizes and modification times (not contents)"}


@dataclass(frozen=True)
class IndWindows:
    """Everything the stage writes, computed before anything is written."""

    tables: dict[int, pd.DataFrame]
    index: dict
    metrics: dict
    backgrounds: dict[str, Path]  # scene_id -> source image
    masks: dict[str, np.ndarray]


def split_counts(table: pd.DataFrame) -> dict[str, int]:
    counts = count_windows(table, ["split"])
    return {split: counts.get(split, 0) for split in ("train", "val", "test")}


def not_provided(n_past: int) -> IndWindows:
    """The record written when data.ind.path is empty: empty tables, and why."""
    tables = {t_f: empty_table() for t_f in HORIZONS}
    index = {"provided": False, "reason": NOT_PROVIDED_REASON, "n_past": n_past,
             "horizon": LONG_TERM_HORIZON, "tables": {str(t): f"tf{t}.parquet" for t in HORIZONS},
             "scenes": {}}
    metrics = {"provided": False, "status": "not provided", "reason": NOT_PROVIDED_REASON,
               "windows": {f"tf{t}": split_counts(tables[t]) for t in HORIZONS}}
    return IndWindows(tables, index, metrics, {}, {})


def build(params: IndParams, windows: WindowParams) -> IndWindows:
    """Read the copy at params.path and cut its windows (nothing written)."""
    if not params.provided:
        return not_provided(windows.n_past)
    data_dir = Path(params.path).expanduser() / "data"
    recordings = [read_recording(data_dir, r, windows.target_fps) for r in list_recordings(data_dir)]
    splits = assign_splits(recordings, params.val_recordings)
    tables = window_tables(recordings, splits, windows.n_past, windows.target_fps)
    masks = find_masks(Path(params.labels).expanduser(), recordings) if params.labels else {}
    read = [data_dir / f"{r.recording:02d}_{name}" for r in recordings
            for name in ("tracks.csv", "tracksMeta.csv", "recordingMeta.csv", "background.png")]
    if params.labels:
        read += sorted(Path(params.labels).expanduser().glob("*_background_mask.png"))

    scenes = {}
    for r in recordings:
        scenes[r.scene_id] = {
            "recording": r.recording, "location": r.location, "split": splits[r.scene_id],
            "height": int(r.image_hw[0]), "width": int(r.image_hw[1]), "frame_rate": r.frame_rate,
            "ortho_px_to_meter": r.ortho_px_to_meter, "image": f"backgrounds/{r.scene_id}.png",
            "labels": f"labels/{r.scene_id}.png" if r.scene_id in masks else None,
        }
    index = {"provided": True, "n_past": windows.n_past, "target_fps": windows.target_fps,
             "horizon": LONG_TERM_HORIZON, "tables": {str(t): f"tf{t}.parquet" for t in HORIZONS},
             "background_scale": BACKGROUND_SCALE, "scenes": scenes}

    positions = pd.concat([r.positions for r in recordings], ignore_index=True)
    sizes = pd.DataFrame([(r.scene_id, *r.image_hw) for r in recordings],
                         columns=["scene_id", "height", "width"]).set_index("scene_id")
    height = positions["scene_id"].map(sizes["height"]).to_numpy()
    width = positions["scene_id"].map(sizes["width"]).to_numpy()
    outside = ((positions["x"] < 0) | (positions["x"] >= width)
               | (positions["y"] < 0) | (positions["y"] >= height))
    classes: dict[str, int] = {}
    for r in recordings:
        for name, n in r.class_counts.items():
            classes[name] = classes.get(name, 0) + n
    metrics = {
        "provided": True, "status": "ok",
        "horizon": LONG_TERM_HORIZON,
        "windows": {f"tf{t}": split_counts(tables[t]) for t in HORIZONS},
        "windows_per_scene": {f"tf{t}": count_windows(tables[t], ["split", "scene_id"]) for t in HORIZONS},
        "recordings": {split: sorted(r.recording for r in recordings if splits[r.scene_id] == split)
                       for split in ("train", "val", "test")},
        "tracks_per_class": dict(sorted(classes.items())),
        "pedestrian_positions": int(len(positions)),
        "pedestrian_positions_outside_image": int(outside.sum()),
        "frame_rates": sorted({r.frame_rate for r in recordings}),
        "labels": sorted(masks),
        "source_fingerprint": fingerprint(read),
    }
    return IndWindows(tables, index, metrics, {r.scene_id: r.background for r in recordings}, masks)


def write(result: IndWindows, out: Path, metrics: Path) -> None:
    """The output folder (staged, then renamed over `out`) and the metrics JSON."""
    with atomic_dir(out) as staging:
        for t_f, table in result.tables.items():
            table.to_parquet(staging / f"tf{t_f}.parquet", index=False)
        (staging / "backgrounds").mkdir()
        for name, source in result.backgrounds.items():
            shutil.copyfile(source, staging / "backgrounds" / f"{name}.png")
        if result.masks:
            (staging / "labels").mkdir()
            for name, mask in result.masks.items():
                cv2.imwrite(str(staging / "labels" / f"{name}.png"), mask)
        (staging / "index.json").write_text(json.dumps(result.index, indent=1, sort_keys=True) + "\n")
    write_json(result.metrics, metrics, sort_keys=True)


# ---------------------------------------------------------------------------------------------
# The benchmark


@dataclass(frozen=True)
class Ind(LongTermBenchmark):
    """inD: the t_f = 30 s table's test windows, in pixels of each recording's background image;
    one record of every model (stage `evaluate_ind`), from the user's own copy of inD (no study
    runs on it)."""

    def baseline_metrics(self, model: str, t_f: int) -> tuple[str, tuple[str, ...]]:
        """Beside Y-net's, in its one record."""
        return self.metrics_file, ("baselines", model)

    def stored_scores(self, model: str, table: str) -> tuple[str, tuple[str, ...]]:
        """inD's record of `score_predictions` (one window table)."""
        return "beyond/ind.json", ("benchmarks", self.name, "models", model)

    def prediction_benchmark(self) -> str:
        """The benchmark an inD predictions file names (its windows: the t_f = 30 s table's)."""
        return f"{self.name}_long_term"

    def prediction_metadata(self, model: str, table: Path | None = None, **extra) -> dict:
        """What an inD predictions file records besides its seeds (pixels of the recording's
        background image; window ids of `table`, the t_f = 30 s window table of `ind_windows`)."""
        metadata = {"model": model, "benchmark": self.prediction_benchmark(), "unit": self.unit,
                    "split": self.split}
        if table is not None:
            metadata["window_table"] = str(table)
        return {**metadata, **extra}

    def not_provided(self, ind_dir: Path) -> str | None:
        """The index's reason when inD was not provided (None: it was); the index checked first."""
        index = read_index(ind_dir)
        return None if index["provided"] else index["reason"]

    def load(self, ind_dir: Path) -> LongTermData:
        """The t_f = 30 s windows (train / val / test), the t_f = 5 s ones of R-PECNet's PECNet, and
        every recording's background: the U-Net is fine-tuned on one labelled background per train
        location and scored on one per test location (recordings of a place share a background)."""
        index = read_index(ind_dir)
        long = read_windows(ind_dir, index, index["horizon"])
        base = read_windows(ind_dir, index, RPECNET_HORIZON)
        splits = {split: select_split(long, split) for split in IND_SPLITS}
        empty = [split for split, arrays in splits.items() if len(arrays) == 0]
        if empty:
            raise ValueError(f"{ind_dir}: no t_f = {index['horizon']} s windows in split(s) {empty} "
                             "(test: location 4; val: data.ind.val_recordings); see metrics/ind_windows.json")
        scenes = index["scenes"]
        labelled = [name for name, info in scenes.items() if info["labels"]]
        return LongTermData(
            index=Path(ind_dir) / "index.json", n_past=index["n_past"], horizon=int(index["horizon"]),
            table=Path(ind_dir) / index["tables"][str(index["horizon"])], long=long, base=base,
            splits=splits, sizes={name: (info["height"], info["width"]) for name, info in scenes.items()},
            backgrounds={name: Background(ind_dir / info["image"],
                                          ind_dir / info["labels"] if info["labels"] else None)
                         for name, info in scenes.items()},
            finetune_scenes=one_per_location(scenes, [n for n in labelled if scenes[n]["split"] != "test"]),
            scored_scenes=one_per_location(scenes, [n for n in labelled if scenes[n]["split"] == "test"]),
            unlabelled_note=UNLABELLED_NOTE)

    def scored_table(self, ind_dir: Path, forbidden_classes: Sequence[str]) -> ScoredTable:
        """inD (stage `ind_windows`' folder) as scoring sees it: the t_f = `horizon` table's test
        windows in pixels of each recording's background, metres per pixel orthoPxToMeter x
        `background_scale` per recording, the hand-labelled masks the index names (`labels`, in
        `ynet.segmentation.CLASS_NAMES` values) where there are any. inD not provided: no scales
        and no masks, the index's reason why."""
        ind_dir = Path(ind_dir)
        path = ind_dir / "index.json"
        index = read_json_index(path)
        horizon = index_value(index, "horizon", int, path)
        tables = index_value(index, "tables", dict, path)
        table = ind_dir / index_value(tables, str(horizon), str, path, "tables.")
        n_past = index_value(index, "n_past", int, path)
        if not index_value(index, "provided", bool, path):
            reason = index_value(index, "reason", str, path)
            return ScoredTable(self.prediction_benchmark(), table, self.unit, n_past,
                               split=self.split, metres_per_unit={},
                               scales_source=f"inD not provided: {reason}",
                               masks_absent=f"inD not provided: {reason}")
        background = index_value(index, "background_scale", float, path)
        scenes = index_value(index, "scenes", dict, path)
        scales, labelled = {}, {}
        for name in scenes:
            entry = index_value(scenes, name, dict, path, "scenes.")
            where = f"scenes.{name}."
            scales[name] = index_value(entry, "ortho_px_to_meter", float, path, where) * background
            if not 0 < scales[name] < float("inf"):
                raise IntermediateError(f"{path}: {where}ortho_px_to_meter: expected a positive "
                                        f"scale, got {entry['ortho_px_to_meter']}")
            labels = index_value(entry, "labels", str | None, path, where)
            if labels is not None:
                labelled[name] = (ind_dir / labels, (index_value(entry, "height", int, path, where),
                                                     index_value(entry, "width", int, path, where)))

        def read(name: str) -> np.ndarray:
            mask_path, size = labelled[name]
            mask = cv2.imread(str(mask_path), cv2.IMREAD_UNCHANGED)
            if mask is None or mask.shape != size:
                raise IntermediateError(f"{mask_path}: expected a {size} mask (H, W), got "
                                        f"{None if mask is None else mask.shape}")
            return mask

        masks = (SceneMasks(f"hand labels {ind_dir.as_posix()}/labels",
                            class_values(forbidden_classes), tuple(forbidden_classes),
                            frozenset(labelled), read) if labelled else None)
        return ScoredTable(self.prediction_benchmark(), table, self.unit, n_past, split=self.split,
                           metres_per_unit=scales,
                           scales_source=f"per recording, orthoPxToMeter x {background:g} ({path})",
                           masks=masks, masks_absent=None if labelled else
                           "no hand-labelled inD mask (data.ind.labels not set)")


IND = Ind("ind", "inD long-term", "px", label="inD", paper_table="sdd_long", paper_key="ind",
          metrics_file="ind_benchmark.json")


# ---------------------------------------------------------------------------------------------
# Reading the stage's folder


IND_SPLITS = ("train", "val", "test")
SCENE_KEYS = {"location": int, "split": str, "height": int, "width": int, "image": str,
              "labels": str | None}  # what the benchmark reads of each `scenes` entry


def check_ind_scene(entry: dict, ind_dir: Path, path: Path, where: str) -> None:
    """One `scenes` entry of the `ind_windows` index: typed keys, a known split, a positive image
    size, and the background (and mask) files it names present."""
    for key, kind in SCENE_KEYS.items():
        index_value(entry, key, kind, path, where, choices=IND_SPLITS if key == "split" else None)
    if entry["height"] <= 0 or entry["width"] <= 0:
        raise IntermediateError(f"{path}: {where}height, width: expected positive sizes, got "
                                f"{entry['height']}, {entry['width']}")
    for key in ("image", "labels"):
        if entry[key] is not None and not (ind_dir / entry[key]).is_file():
            raise IntermediateError(f"{path}: {where}{key}: {entry[key]} not in {ind_dir}")


def read_index(ind_dir: Path) -> dict:
    """The `index.json` of `ind_windows`, checked: the keys the benchmark reads, typed, and every
    table and image it names present. An IntermediateError names the file and the key."""
    ind_dir = Path(ind_dir)
    path = ind_dir / "index.json"
    index = read_json_index(path)
    if not index_value(index, "provided", bool, path):
        index_value(index, "reason", str, path)
        return index
    index_value(index, "n_past", int, path)
    index_value(index, "horizon", int, path)
    for horizon, name in index_value(index, "tables", dict, path).items():
        if not (isinstance(name, str) and (ind_dir / name).is_file()):
            raise IntermediateError(f"{path}: tables.{horizon}: {name!r} not a file in {ind_dir}")
    scenes = index_value(index, "scenes", dict, path)
    for name in scenes:
        check_ind_scene(index_value(scenes, name, dict, path, "scenes."), ind_dir, path,
                        f"scenes.{name}.")
    return index


def one_per_location(scenes: dict[str, dict], names: list[str]) -> list[str]:
    """The first of `names` at each location: recordings of one place share one background."""
    seen, chosen = set(), []
    for name in sorted(names):
        if scenes[name]["location"] not in seen:
            seen.add(scenes[name]["location"])
            chosen.append(name)
    return chosen


def at_ind_scale(params: IndBenchmarkParams, ynet: YnetSettings, segmentation: SegmentationParams
                 ) -> tuple[YnetSettings, SegmentationParams]:
    """Y-net's and the U-Net's settings at inD's scales: maps at `ynet_resize` of the background,
    the U-Net's input downsampled by `segmentation_downsample`."""
    return (replace(ynet, resize=params.ynet_resize),
            replace(segmentation, downsample=params.segmentation_downsample))


def read_windows(ind_dir: Path, index: dict, horizon: int) -> WindowArrays:
    name = index["tables"].get(str(horizon))
    if name is None:
        raise IntermediateError(f"{ind_dir}/index.json: no window table for t_f = {horizon} s")
    return to_arrays(pd.read_parquet(ind_dir / name), index["n_past"])

