"""ETH/UCY, the short-term benchmark in metres (paper Table 2): Social-GAN's five
leave-one-scene-out folds (eth, hotel, univ, zara1, zara2), each a benchmark of its own
(`EthUcyFold`).

Windows: `sgan/datasets/<fold>/{train,val,test}/*.txt` (`frame ped x y`, metres), cut as SGAN's
loader cuts them: every run of 20 consecutive frames of a file (stride one frame), one window per
pedestrian present in all 20, kept only where at least `ethucy_min_agents` pedestrians are (SGAN:
`> min_ped`, min_ped = 1). Pixels = the inverse of the authors' homography `<scene>_H.txt` (eth,
hotel: pixel coordinates swapped; `pipeline.data.homography`) on the grid of the scene's
`oracle.png`. Like every window table, x, y are ORIGINAL pixels: Y-net scales them by its own
`resize` (1/1.5 for ETH/UCY). The metres stay beside them (`x_m`, `y_m`) so that errors are
computed in metres, not pixels (upstream bug 4): Y-net's predictions go back to metres through
each scene's homography (`to_metres`); the baselines train and predict in metres
(`load_in_unit`).

Scene maps: for each scene, N_c = 2 classes from `oracle.png` (1 = road, the ground people walk
on; 0 = not road) plus channel 0 for padding, as `pipeline.data.semantic_maps` stores SDD's:
`ethucy_semantic/maps.npz` (uint8 p * 255, `load_semantic_maps` reads it) and `index.json`
(classes, resize, and per scene the pixel grid, homography and swap flag: `load_ethucy_scenes`).

Scoring stored predictions: the unit is metres (no scale); the scene masks are those maps
(`road_masks`): a position in metres goes to the scene's pixel grid through the inverse of its
homography, then to the map at `resize` map pixels per pixel; a map pixel is not road where its
not-road probability exceeds its road probability (the maps are area-resized: a boundary pixel
holds both), and not road is the forbidden class. A position the inverse homography sends to
infinity (the horizon) counts as outside the map. SGAN's loader cuts a window at every frame, so
each neighbour shares frames with a window in up to 2 n_f - 1 overlapping windows (zara1: 81
partner windows of 7 other pedestrians on average): collisions are counted only between windows
that start at the same frame, one sequence (`same_start_collisions`). The same sequences
(scene_id = S-GAN's file, first frame = its start frame) give S-GAN's own ADE / FDE.
"""

from __future__ import annotations

import io
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
import pandas as pd

from pipeline.benchmarks.base import SceneMasks, ScoredTable
from pipeline.benchmarks.short_term import (METRE_COLUMNS, ScoringSources, ShortTermBenchmark,
                                            ShortTermInputError, ShortTermSplits, number_windows,
                                            read_rows, splits_of)
from pipeline.data.homography import metres_to_pixels, pixels_to_metres, read_homography
from pipeline.data.semantic_maps import QUANT, load_semantic_maps, quantise
from pipeline.data.window_table import select_split, to_arrays
from pipeline.dataset_list import ETHUCY
from pipeline.io import IntermediateError, index_value, positive_ints, read_json_index
from pipeline.splits import FOLD_TEST_SCENES

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.short_term import ShortTermParams

ETHUCY_DIR = Path("data/eth_ucy")  # inside ynet-release/: <scene>_H.txt, <scene>/oracle.png
MAP_CLASSES = ("padding", "not_road", "road")  # channel order of the ETH/UCY maps (N_c = 2 + padding)
PAD_CHANNEL = 0  # like ynet.segmentation.PAD_CLASS, so padded_semantic() needs no change
MAPS = "ethucy_semantic"  # maps.npz + index.json inside the short_term_windows folder
NOT_ROAD, ROAD = MAP_CLASSES.index("not_road"), MAP_CLASSES.index("road")
METRES_TOLERANCE = 1e-6  # m: the homography must give back the table's metres of the ground truth


@dataclass(frozen=True)
class EthUcyScene:
    """One recording: its SGAN file stem, the authors' homography convention, its camera image."""

    name: str  # scene id in the tables = the authors' `<name>_H.txt` and `<name>/oracle.png`
    sgan_stem: str  # SGAN file `<stem>.txt` (test) / `<stem>_train.txt` / `<stem>_val.txt`
    swap: bool  # H takes pixels as (row, column): the ETH dataset's own homographies
    image: str  # folder of `ethucy-scenes/` holding the camera's `reference.png`


# The eight recordings of Social-GAN's ETH/UCY data. zara3 is the zara2 camera; students001,
# students003 and uni_examples are the univ camera.
SCENES = {s.name: s for s in (
    EthUcyScene("eth", "biwi_eth", True, "eth"),
    EthUcyScene("hotel", "biwi_hotel", True, "hotel"),
    EthUcyScene("zara1", "crowds_zara01", False, "zara1"),
    EthUcyScene("zara2", "crowds_zara02", False, "zara2"),
    EthUcyScene("zara3", "crowds_zara03", False, "zara2"),
    EthUcyScene("students001", "students001", False, "univ"),
    EthUcyScene("students003", "students003", False, "univ"),
    EthUcyScene("uni_examples", "uni_examples", False, "univ"),
)}
SCENE_BY_STEM = {s.sgan_stem: s for s in SCENES.values()}
# Leave-one-scene-out folds (SGAN's folder names) and the scenes each one tests on.
SGAN_SUFFIX = {"train": "_train", "val": "_val", "test": ""}  # file name = <stem><suffix>.txt


@dataclass(frozen=True)
class EthUcyFold(ShortTermBenchmark):
    """One leave-one-scene-out fold: windows in original pixels of each scene's grid, errors in
    metres (the table's `x_m`, `y_m`)."""

    def maps(self, windows: Path) -> Path:
        """The scene maps and index (pixel grid, homography, swap) of the `short_term_windows`
        folder `windows`."""
        return Path(windows) / MAPS

    def load(self, windows: Path, n_past: int, n_future: int) -> ShortTermSplits:
        """Pixels, the test truth in metres: predictions go through each scene's homography."""
        return splits_in_metres(self.read_table(windows), self.dataset, n_past, n_future,
                                load_ethucy_scenes(self.maps(windows)))

    def splits_in_unit(self, table: pd.DataFrame, n_past: int, n_future: int) -> ShortTermSplits:
        """Every split from the metre columns (train, val and test alike, the truth too)."""
        missing = [c for c in METRE_COLUMNS if c not in table.columns]
        if missing:
            raise ValueError(f"{self.dataset}: the window table has no metre columns {missing}")
        train, val, test = splits_of(table.assign(x=table["x_m"], y=table["y_m"]), self.dataset,
                                     n_past, n_future)
        return ShortTermSplits(train, val, test, test.future, self.unit, lambda points: points)

    def scene_sizes(self, windows: Path, sdd: Path | None, scene_ids: set[str]
                    ) -> dict[str, tuple[int, int]]:
        """Every scene's pixel grid, from the maps' index."""
        return {name: info.image_hw for name, info in load_ethucy_scenes(self.maps(windows)).items()}

    def scene_images(self, windows: Path, sdd: Path | None, cameras: Path | None
                     ) -> Callable[[str], np.ndarray]:
        """The camera image under `cameras` on the scene's oracle grid (`ethucy_scene_image`)."""
        scenes = load_ethucy_scenes(self.maps(windows))
        return lambda name: ethucy_scene_image(cameras, name, scenes[name].image_hw)

    def scored_table(self, sources: ScoringSources) -> ScoredTable:
        """Its test windows as scoring sees them: metres, the road masks (`road_masks`, shared by
        the folds), collisions within one SGAN sequence."""
        return ScoredTable(self.prediction_benchmark(), self.table(sources.windows), self.unit,
                           sources.n_past, self.truth_columns, self.split,
                           masks=sources.masks(self.maps(sources.windows), road_masks),
                           same_start_collisions=self.same_start_collisions)


TABLE_K = 20  # Table 2's K: the one a fold's summary (stage short_term_tables) holds
RAW_CAMERAS = "ethucy-scenes"  # the fetched camera images (data/raw/ethucy-scenes)
FOLD_LABELS = {"eth": "ETH", "hotel": "Hotel", "univ": "Univ", "zara1": "Zara1", "zara2": "Zara2"}
FOLDS = {fold: EthUcyFold(f"ethucy_{fold}", f"ETH/UCY, {fold} fold", "m", METRE_COLUMNS,
                          label=FOLD_LABELS[fold], paper_table="eth_ucy", paper_key=fold,
                          in_paper=f"Table 2, {fold.upper()} fold", study_key=fold,
                          dataset=fold, table_file=f"ethucy_{fold}.parquet", settings_key=ETHUCY,
                          same_start_collisions=True, summary_file=f"ethucy_{fold}.json",
                          table_k=TABLE_K, images_source=RAW_CAMERAS)
         for fold in FOLD_TEST_SCENES}


def to_metres(points: np.ndarray, scene_ids: np.ndarray,
              scenes: dict[str, EthUcySceneInfo]) -> np.ndarray:
    """Original pixels (N, ..., 2) of windows in scenes `scene_ids` (N,) -> metres (N, ..., 2)."""
    points = np.asarray(points, dtype=np.float64)
    out = np.empty_like(points)
    for name in np.unique(scene_ids):
        rows = scene_ids == name
        info = scenes[str(name)]
        out[rows] = pixels_to_metres(points[rows], info.homography, info.swap)
    return out


def splits_in_metres(table: pd.DataFrame, fold: str, n_past: int, n_future: int,
                     scenes: dict[str, EthUcySceneInfo]) -> ShortTermSplits:
    """The splits of a fold's table in original pixels, the test truth from its metre columns,
    checked against the scenes' homographies."""
    train, val, test = splits_of(table, fold, n_past, n_future)
    metres = select_split(to_arrays(table.assign(x=table["x_m"], y=table["y_m"]), n_past), "test")
    assert np.array_equal(metres.window_id, test.window_id)  # one order: window_id
    missing = sorted(set(test.scene_id) - set(scenes))
    if missing:
        raise ValueError(f"{fold}: no homography for test scene(s) {missing}")

    def to_unit(points: np.ndarray) -> np.ndarray:
        return to_metres(points, test.scene_id, scenes)

    worst = float(np.abs(to_unit(test.future) - metres.future).max())
    if worst > METRES_TOLERANCE:
        raise ValueError(f"{fold}: the scenes' homographies map the test pixels {worst:.3g} m "
                         "away from the table's metres: tables and scene index disagree")
    return ShortTermSplits(train, val, test, metres.future, "m", to_unit)


def road_masks(maps_dir: Path) -> SceneMasks:
    """The ETH/UCY road / not-road maps as class masks (NOT_ROAD where p(not road) > p(road), else
    ROAD) on each scene's grid, positions in metres mapped through the scene's homography."""
    maps_dir = Path(maps_dir)
    index_path = maps_dir / "index.json"
    resize = index_value(read_json_index(index_path), "resize", float, index_path)
    if not 0 < resize < float("inf"):
        raise IntermediateError(f"{index_path}: resize: expected a positive scale, got {resize}")
    scenes = load_ethucy_scenes(maps_dir)
    maps = load_semantic_maps(maps_dir)  # scene -> (3, h, w) probabilities

    def read(name: str) -> np.ndarray:
        probs = maps[name]
        return np.where(probs[NOT_ROAD] > probs[ROAD], NOT_ROAD, ROAD).astype(np.uint8)

    def to_pixels(points: np.ndarray, name: str) -> np.ndarray:
        info = scenes[name]
        pixels = metres_to_pixels(points, info.homography, info.swap)
        return np.where(np.isfinite(pixels), pixels, -1.0)  # at infinity: outside the map

    return SceneMasks(f"road / not-road maps {maps_dir.as_posix()} (oracle.png at resize "
                      f"{resize:.4g}, through each scene's homography)", (NOT_ROAD,),
                      ("not_road",), frozenset(set(maps) & set(scenes)), read, resize, to_pixels)


# ---------------------------------------------------------------------------------------------
# Building the tables and maps (stage `short_term_windows`)


def sgan_window_rows(rows: np.ndarray, length: int, min_agents: int, path: Path) -> np.ndarray:
    """Indices (N, length) into `rows` (R, 4: frame ped x y) of every window SGAN's loader cuts.

    Frames are the file's distinct frame numbers in order; a window is a pedestrian present in all
    `length` consecutive frames of a run, where at least `min_agents` pedestrians are.
    """
    frames = np.unique(rows[:, 0])
    index = np.searchsorted(frames, rows[:, 0])  # (R,) position of each row's frame
    ped = rows[:, 1].astype(np.int64)
    order = np.lexsort((index, ped))  # by pedestrian, then frame
    fi, pi = index[order], ped[order]
    same_ped = pi[1:] == pi[:-1]
    duplicate = np.flatnonzero(same_ped & (fi[1:] == fi[:-1]))
    if len(duplicate):
        k = order[duplicate[0]]
        raise ShortTermInputError(f"{path}: pedestrian {ped[k]} appears twice in frame "
                                  f"{rows[k, 0]:.0f}")
    starts_run = np.r_[True, ~(same_ped & (np.diff(fi) == 1))]
    run = np.cumsum(starts_run) - 1
    run_first = np.flatnonzero(starts_run)
    run_length = np.diff(np.r_[run_first, len(fi)])
    left = run_length[run] - (np.arange(len(fi)) - run_first[run])  # rows of the run from here
    full = left >= length  # (R,) sorted rows that start a complete window
    # SGAN takes a pedestrian seen in a run's first and last frame as present throughout (and fails
    # on a gap in between): such a gap is an error here too.
    keys = pi * len(frames) + fi
    seen_at_end = (fi + length - 1 < len(frames)) & np.isin(keys + length - 1, keys)
    gap = np.flatnonzero(seen_at_end & ~full)
    if len(gap):
        k = order[gap[0]]
        raise ShortTermInputError(f"{path}: pedestrian {ped[k]} is missing from some frame of the "
                                  f"{length} frames from {rows[k, 0]:.0f} but present at both ends")
    agents = np.bincount(fi[full], minlength=len(frames))  # (F,) complete pedestrians per run start
    kept = np.flatnonzero(full & (agents[fi] >= min_agents))
    return order[kept[:, None] + np.arange(length)]  # (N, length)


def gap_windows(rows: np.ndarray, windows: np.ndarray) -> int:
    """Windows (N, L) whose frames do not all step by the file's usual frame step."""
    if not len(windows):
        return 0
    steps = np.diff(np.unique(rows[:, 0]))
    usual = np.bincount(steps.astype(np.int64)).argmax() if len(steps) else 0
    return int((np.diff(rows[windows, 0], axis=1) != usual).any(axis=1).sum())


def sgan_file_scene(path: Path, split: str) -> EthUcyScene:
    stem = path.stem.removesuffix(SGAN_SUFFIX[split]) if SGAN_SUFFIX[split] else path.stem
    if not path.stem.endswith(SGAN_SUFFIX[split]) or stem not in SCENE_BY_STEM:
        raise ShortTermInputError(f"{path}: not an SGAN {split} file `<recording>{SGAN_SUFFIX[split]}"
                                  f".txt` of a known recording {sorted(SCENE_BY_STEM)}")
    return SCENE_BY_STEM[stem]


def ethucy_fold_windows(sgan_root: Path, ethucy_root: Path, fold: str, params: ShortTermParams,
                        homographies: dict[str, np.ndarray]) -> tuple[pd.DataFrame, int]:
    """One leave-one-out fold: its window table (pixels and metres) and its windows over frame gaps.

    `homographies`: scene -> (3, 3) pixels-to-metres, read on first use and shared between folds.
    """
    parts, n_gap, scenes_by_split = [], 0, {}
    for split in ("train", "val", "test"):
        folder = sgan_root / "datasets" / fold / split
        paths = sorted(folder.glob("*.txt"))
        if not paths:
            raise ShortTermInputError(f"{folder}: no SGAN files")
        scenes_by_split[split] = set()
        for path in paths:
            scene = sgan_file_scene(path, split)
            scenes_by_split[split].add(scene.name)
            rows = read_rows(path, "frame ped x y")
            windows = sgan_window_rows(rows, params.window_length, params.ethucy_min_agents, path)
            n_gap += gap_windows(rows, windows)
            if scene.name not in homographies:
                homographies[scene.name] = read_homography(ethucy_root / f"{scene.name}_H.txt")
            metres = rows[windows.reshape(-1)][:, 2:]  # (N * L, 2)
            pixels = metres_to_pixels(metres, homographies[scene.name], scene.swap)
            n, length = windows.shape
            parts.append(pd.DataFrame({
                "scene_id": scene.name,
                "track_id": rows[windows.reshape(-1), 1].astype(np.int64),
                "frame": rows[windows.reshape(-1), 0].astype(np.int64),
                "x": pixels[:, 0],
                "y": pixels[:, 1],
                "x_m": metres[:, 0],
                "y_m": metres[:, 1],
                "step": np.tile(np.arange(length), n),
                "window_key": len(parts) * 10**7 + np.repeat(np.arange(n), length),
                "split": split,
            }))
    test = scenes_by_split["test"]
    if test != FOLD_TEST_SCENES[fold]:
        raise ShortTermInputError(f"{sgan_root / 'datasets' / fold / 'test'}: tests {sorted(test)}, "
                                  f"expected {sorted(FOLD_TEST_SCENES[fold])}")
    leaked = sorted(test & (scenes_by_split["train"] | scenes_by_split["val"]))
    if leaked:
        raise ShortTermInputError(f"{sgan_root / 'datasets' / fold}: test scene(s) {leaked} also "
                                  f"in train/val: not a leave-one-out fold")
    table = number_windows(pd.concat(parts, ignore_index=True), params.n_future, "sgan")
    return table, n_gap


def read_oracle(path: Path) -> np.ndarray:
    """The road mask (H, W) bool of `oracle.png` (values 0 / 1); ShortTermInputError names the file."""
    mask = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if mask is None:
        raise ShortTermInputError(f"{path}: missing or not an image")
    if mask.ndim != 2 or mask.dtype != np.uint8:
        raise ShortTermInputError(f"{path}: expected a single-channel 8-bit mask, got "
                                  f"{mask.shape} {mask.dtype}")
    values = set(np.unique(mask).tolist())
    if not values <= {0, 1}:
        raise ShortTermInputError(f"{path}: values {sorted(values - {0, 1})} (expected 0 / 1)")
    return mask == 1


def road_map(road: np.ndarray, resize: float) -> np.ndarray:
    """Road mask (H, W) -> probabilities (3, h, w) of (padding, not road, road) at `resize`."""
    one_hot = np.stack([np.zeros_like(road), ~road, road]).astype(np.float32)  # (3, H, W)
    height, width = (max(1, round(s * resize)) for s in road.shape)
    if (height, width) == road.shape:
        return one_hot
    return np.stack([cv2.resize(c, (width, height), interpolation=cv2.INTER_AREA) for c in one_hot])


def write_ethucy_maps(out: Path, release_root: Path, scenes_root: Path, scene_names,
                      homographies: dict[str, np.ndarray], resize: float) -> dict[str, dict]:
    """Write `maps.npz` + `index.json` for `scene_names` into the folder `out`; returns the index's
    per-scene entries."""
    maps, entries = {}, {}
    for name in sorted(scene_names):
        scene = SCENES[name]
        road = read_oracle(release_root / ETHUCY_DIR / name / "oracle.png")  # (H, W)
        maps[name] = quantise(road_map(road, resize))  # (3, h, w) uint8
        image_path = scenes_root / scene.image / "reference.png"
        image = cv2.imread(str(image_path), cv2.IMREAD_COLOR)
        if image is None:
            raise ShortTermInputError(f"{image_path}: missing or not an image")
        entries[name] = {
            "shape": list(maps[name].shape),
            "image_hw": list(road.shape),
            "homography": homographies[name].tolist(),
            "swap": scene.swap,
            "road_fraction": round(float(road.mean()), 4),
            "reference_image": f"{scene.image}/reference.png",
            "reference_hw": list(image.shape[:2]),
        }
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **maps)
    (out / "maps.npz").write_bytes(buffer.getvalue())
    (out / "index.json").write_text(json.dumps({
        "classes": list(MAP_CLASSES),
        "resize": resize,
        "encoding": f"uint8, probability = value / {QUANT}; see pipeline.semantic_maps.load_semantic_maps",
        "coordinates": "image_hw is the original pixel grid of the window tables' x, y (oracle.png); "
                       "homography maps those pixels (swapped to (row, column) where swap) to metres",
        "scenes": entries,
    }, indent=1) + "\n")
    return entries


def on_road_fraction(tables: dict[str, pd.DataFrame], release_root: Path) -> dict[str, float]:
    """Per scene, the share of window positions (all folds) on an oracle road pixel."""
    positions = pd.concat([t[["scene_id", "x", "y"]] for t in tables.values()], ignore_index=True)
    shares = {}
    for name, group in positions.groupby("scene_id"):
        road = read_oracle(release_root / ETHUCY_DIR / str(name) / "oracle.png")
        col = np.clip(np.rint(group["x"].to_numpy()).astype(int), 0, road.shape[1] - 1)
        row = np.clip(np.rint(group["y"].to_numpy()).astype(int), 0, road.shape[0] - 1)
        shares[str(name)] = round(float(road[row, col].mean()), 4)
    return shares


# ---------------------------------------------------------------------------------------------
# The scene index


@dataclass(frozen=True)
class EthUcySceneInfo:
    """What a consumer of the ETH/UCY windows needs besides the map (`load_semantic_maps`)."""

    image_hw: tuple[int, int]  # original pixel grid (height, width) of the tables' x, y
    homography: np.ndarray  # (3, 3) pixels -> metres
    swap: bool  # the homography takes pixels as (row, column)


def scene_info(entry: dict, path: Path, where: str) -> EthUcySceneInfo:
    """One scene entry of the ETH/UCY `index.json` at `path`, checked: the metres of every
    ETH/UCY score come from its homography."""
    hw = index_value(entry, "image_hw", list, path, where)
    if not positive_ints(hw, 2):
        raise IntermediateError(f"{path}: {where}image_hw: expected [height, width] of positive "
                                f"integers, got {hw}")
    rows = index_value(entry, "homography", list, path, where)
    numbers = all(isinstance(r, list) and len(r) == 3 and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in r) for r in rows)
    if not (len(rows) == 3 and numbers and np.isfinite(np.array(rows, np.float64)).all()):
        raise IntermediateError(f"{path}: {where}homography: expected a 3 x 3 matrix of finite "
                                f"numbers, got {rows}")
    swap = index_value(entry, "swap", bool, path, where)
    return EthUcySceneInfo(tuple(hw), np.array(rows, np.float64), swap)


def load_ethucy_scenes(folder: Path) -> dict[str, EthUcySceneInfo]:
    """Per scene: pixel grid, homography and swap flag, from the maps folder's `index.json`."""
    path = Path(folder) / "index.json"
    index = read_json_index(path)
    scenes = index_value(index, "scenes", dict, path)
    return {name: scene_info(index_value(scenes, name, dict, path, "scenes."), path, f"scenes.{name}.")
            for name in scenes}


def ethucy_scene_image(scenes_root: Path, name: str, image_hw: tuple[int, int]) -> np.ndarray:
    """(H, W, 3) uint8 BGR: the camera image of scene `name` (`<scenes_root>/<image>/reference.png`)
    on the scene's pixel grid `image_hw` (oracle.png's, the tables' x, y, which the homography maps
    to metres): the camera frame is the grid's top-left corner, black where the grid is larger
    (zara2 / zara3: a 576 x 720 frame on a 640 x 736 grid; the other scenes' sizes agree)."""
    if name not in SCENES:
        raise ShortTermInputError(f"no ETH/UCY scene {name!r} (known: {sorted(SCENES)})")
    path = Path(scenes_root) / SCENES[name].image / "reference.png"
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise ShortTermInputError(f"{path}: missing or not an image")
    height, width = image_hw
    if image.shape[0] > height or image.shape[1] > width:
        raise ShortTermInputError(f"{path}: {image.shape[0]} x {image.shape[1]} pixels, larger than "
                                  f"scene {name}'s grid {height} x {width}")
    canvas = np.zeros((height, width, 3), np.uint8)
    canvas[:image.shape[0], :image.shape[1]] = image
    return canvas

