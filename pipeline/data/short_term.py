"""The short-term benchmarks' windows (n_p = 8 + n_f = 12 at 2.5 FPS): TrajNet SDD and ETH/UCY
(stage `short_term_windows`).

SDD, TrajNet split: `trajnet-sdd/{train,test}/<scene>_<video>.txt` hold fixed windows of 20 steps
(`frame track x y`, 20 consecutive rows per window, raw 30 FPS frame numbers stepping by 12) in
metres. Pixels = metres / the video's ratio in `H_SDD.txt` (the `sdd_ratio_version` row); with
version A the test windows equal the authors' `test_trajnet.pkl`. Validation = whole train videos.

ETH/UCY: Social-GAN's leave-one-scene-out folds `sgan/datasets/<fold>/{train,val,test}/*.txt`
(`frame ped x y`, metres). Windows as SGAN's loader cuts them: every run of 20 consecutive frames of
a file (stride one frame), one window per pedestrian present in all 20, kept only where at least
`ethucy_min_agents` pedestrians are (SGAN: `> min_ped`, min_ped = 1). Pixels = the inverse of the
authors' homography `<scene>_H.txt` (eth, hotel: pixel coordinates swapped; `pipeline.data.homography`)
on the grid of the scene's `oracle.png`. Like every window table, x, y are ORIGINAL pixels: Y-net
scales them by its own `resize` (1/1.5 for ETH/UCY). The metres stay beside them (`x_m`, `y_m`)
so that errors are computed in metres, not pixels (upstream bug 4).

Scene maps: for each ETH/UCY scene, N_c = 2 classes from `oracle.png` (1 = road, the ground people
walk on; 0 = not road) plus channel 0 for padding, as `pipeline.data.semantic_maps` stores SDD's:
`maps.npz` (uint8 p * 255, `load_semantic_maps` reads it) and `index.json` (classes, resize, and per
scene the pixel grid, homography and swap flag: `load_ethucy_scenes`).

Outputs (`--out`): `sdd_trajnet.parquet`, `ethucy_<fold>.parquet` (window-table schema plus `x_m`,
`y_m`; `t_f` holds n_f, the horizon in steps, as at 1 FPS), `ethucy_semantic/{maps.npz,index.json}`.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from pipeline.config import ShortTermParams
from pipeline.data.homography import metres_to_pixels, read_homography
from pipeline.data.semantic_maps import QUANT, quantise
from pipeline.data.window_table import conform
from pipeline.data.windows import count_windows
from pipeline.io import IntermediateError, atomic_dir, index_value, positive_ints, read_json_index
from pipeline.splits import FOLD_TEST_SCENES, TEST_VIDEOS, TRAIN_VIDEOS, split_of

SDD_RATIOS = "H_SDD.txt"  # metres per pixel of every SDD video, inside trajnet-sdd/
ETHUCY_DIR = Path("data/eth_ucy")  # inside ynet-release/: <scene>_H.txt, <scene>/oracle.png
METRE_COLUMNS = ("x_m", "y_m")
MAP_CLASSES = ("padding", "not_road", "road")  # channel order of the ETH/UCY maps (N_c = 2 + padding)
PAD_CHANNEL = 0  # like ynet.segmentation.PAD_CLASS, so padded_semantic() needs no change


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


class ShortTermInputError(ValueError):
    """A raw file of the short-term benchmarks that cannot be used as it is."""


# ---------------------------------------------------------------------------------------------
# Reading


def read_rows(path: Path, what: str) -> np.ndarray:
    """(R, 4) float64 rows of a whitespace-separated text file of `what` (four numbers a line).

    A line that is not four finite numbers, or a first or second column (frame, agent id) that is
    not a whole number, is a ShortTermInputError naming the file and line.
    """
    lines = Path(path).read_text().splitlines()
    rows = []
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        fields = line.split()
        try:
            values = [float(v) for v in fields]
        except ValueError:
            values = []
        if len(values) != 4 or not np.isfinite(values).all() or values[0] % 1 or values[1] % 1:
            raise ShortTermInputError(f"{path}:{number}: expected '{what}' (4 numbers, whole frame "
                                      f"and id), got {line!r}")
        rows.append(values)
    if not rows:
        raise ShortTermInputError(f"{path}: no rows")
    return np.asarray(rows, dtype=np.float64)


def read_sdd_ratios(path: Path, version: str) -> dict[str, float]:
    """`<scene>_<video>` -> metres per pixel, from `H_SDD.txt` (tab-separated, one A and one B row)."""
    try:
        table = pd.read_csv(path, sep="\t")
    except (OSError, ValueError) as e:
        raise ShortTermInputError(f"{path}: cannot be read as a tab-separated table ({e})") from e
    missing = sorted({"File", "Version", "Ratio"} - set(table.columns))
    if missing:
        raise ShortTermInputError(f"{path}: lacks column(s) {missing}")
    rows = table.loc[table["Version"] == version]
    names = rows["File"].astype(str).str.removesuffix(".jpg")
    ratios = pd.to_numeric(rows["Ratio"], errors="coerce")
    if names.duplicated().any():
        raise ShortTermInputError(f"{path}: several version-{version} rows for "
                                  f"{sorted(names[names.duplicated()])}")
    bad = ~(ratios > 0)
    if bad.any():
        raise ShortTermInputError(f"{path}: no positive ratio for {sorted(names[bad])}")
    return dict(zip(names, ratios.astype(float)))


# ---------------------------------------------------------------------------------------------
# Window tables


def number_windows(windows: pd.DataFrame, n_future: int, source: str) -> pd.DataFrame:
    """Window ids in (scene, track, first frame) order; schema columns (`conform`), then x_m, y_m.

    `windows`: one row per (window, step) with the schema's columns except window_id, t_f and
    source, plus `window_key` (unique per window) and the metre columns.
    """
    firsts = (windows.loc[windows["step"] == 0, ["window_key", "scene_id", "track_id", "frame"]]
              .sort_values(["scene_id", "track_id", "frame", "window_key"], kind="stable"))
    ids = pd.Series(np.arange(len(firsts), dtype=np.int64), index=firsts["window_key"].to_numpy())
    windows = windows.assign(window_id=windows["window_key"].map(ids), t_f=n_future, source=source)
    windows = windows.sort_values(["window_id", "step"], kind="stable").reset_index(drop=True)
    table = conform(windows)  # same (window_id, step) order: that pair is unique
    return table.assign(**{c: windows[c].to_numpy(np.float64) for c in METRE_COLUMNS})


def fixed_windows(rows: np.ndarray, length: int, frame_step: int, path: Path) -> np.ndarray:
    """Rows (R, 4) of a TrajNet file -> (N, length, 4): consecutive blocks of one track each."""
    if len(rows) % length:
        raise ShortTermInputError(f"{path}: {len(rows)} rows are not whole windows of {length} "
                                  f"(TrajNet files hold fixed 20-step windows: n_past + n_future)")
    blocks = rows.reshape(-1, length, 4)
    one_track = (blocks[:, :, 1] == blocks[:, :1, 1]).all(axis=1)
    steady = (np.diff(blocks[:, :, 0], axis=1) == frame_step).all(axis=1)
    bad = np.flatnonzero(~(one_track & steady))
    if len(bad):
        first = bad[0] * length + 1
        raise ShortTermInputError(
            f"{path}: rows {first}-{first + length - 1} are not one track stepping {frame_step} "
            f"frames ({len(bad)} such window(s)); is n_past + n_future the files' window length?")
    return blocks


def sdd_trajnet_windows(root: Path, params: ShortTermParams) -> pd.DataFrame:
    """The TrajNet SDD windows, train / val / test, in pixels (and metres)."""
    ratios = read_sdd_ratios(root / SDD_RATIOS, params.sdd_ratio_version)
    val_videos = set(params.sdd_val_videos)
    parts = []
    for folder, allowed, videos in (("train", {"train", "val"}, TRAIN_VIDEOS),
                                    ("test", {"test"}, TEST_VIDEOS)):
        paths = sorted((root / folder).glob("*.txt"))
        if not paths:
            raise ShortTermInputError(f"{root / folder}: no TrajNet files")
        for path in paths:
            video = path.stem
            split = split_of(video, val_videos)
            if split not in allowed:
                raise ShortTermInputError(f"{path}: {video} is not a TrajNet {folder} video "
                                          f"(expected one of {sorted(videos)})")
            if video not in ratios:
                raise ShortTermInputError(f"{root / SDD_RATIOS}: no ratio for {video} ({path})")
            blocks = fixed_windows(read_rows(path, "frame track x y"), params.window_length,
                                   params.sdd_frame_step, path)  # (N, L, 4)
            n, length = blocks.shape[:2]
            metres = blocks[:, :, 2:].reshape(-1, 2)  # (N * L, 2)
            parts.append(pd.DataFrame({
                "scene_id": video,
                "track_id": blocks[:, :, 1].reshape(-1).astype(np.int64),
                "frame": blocks[:, :, 0].reshape(-1).astype(np.int64),
                "x": metres[:, 0] / ratios[video],
                "y": metres[:, 1] / ratios[video],
                "x_m": metres[:, 0],
                "y_m": metres[:, 1],
                "step": np.tile(np.arange(length), n),
                "window_key": len(parts) * 10**7 + np.repeat(np.arange(n), length),
                "split": split,
            }))
    missing = sorted(val_videos - {p["scene_id"].iloc[0] for p in parts})
    if missing:
        raise ShortTermInputError(f"{root / 'train'}: no file for validation video(s) {missing}")
    return number_windows(pd.concat(parts, ignore_index=True), params.n_future, "trajnet")


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


# ---------------------------------------------------------------------------------------------
# ETH/UCY scene maps


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
# Stage


def build(trajnet_root: Path, sgan_root: Path, release_root: Path, scenes_root: Path, out: Path,
          params: ShortTermParams) -> dict:
    """Write every table and the ETH/UCY maps into `out` (replaced atomically); returns the stats."""
    sdd = sdd_trajnet_windows(trajnet_root, params)
    homographies: dict[str, np.ndarray] = {}
    ethucy, gaps = {}, {}
    for fold in params.ethucy_folds:
        ethucy[fold], gaps[fold] = ethucy_fold_windows(sgan_root, release_root / ETHUCY_DIR, fold,
                                                       params, homographies)
    with atomic_dir(out) as tmp:
        sdd.to_parquet(tmp / "sdd_trajnet.parquet", index=False)
        for fold, table in ethucy.items():
            table.to_parquet(tmp / f"ethucy_{fold}.parquet", index=False)
        maps_dir = tmp / "ethucy_semantic"
        maps_dir.mkdir()
        write_ethucy_maps(maps_dir, release_root, scenes_root, homographies, homographies,
                          params.ethucy_resize)
    return {
        "n_past": params.n_past, "n_future": params.n_future, "fps": params.fps,
        "t_f_seconds": params.n_future / params.fps,
        "sdd_trajnet": count_windows(sdd, ["split"]),
        "ethucy": {fold: count_windows(table, ["split"]) for fold, table in ethucy.items()},
        "ethucy_windows_over_frame_gaps": gaps,
        "ethucy_positions_on_road": on_road_fraction(ethucy, release_root),
    }
