"""Small data sets in the official file formats, written by the tests themselves.

`write_mirror` lays out a mini mirror like `../shared/data` (SDD annotations, a release archive
with pandas pickles) whose windows are known by construction, plus its manifests. `write_maps_folder`
writes a scene-map folder (`maps.npz` + `index.json`) as the semantic-map stages do;
`write_walker_scenes` the inputs of a Y-net training stage (a window table, scene images, maps).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from collections.abc import Callable

import cv2
import numpy as np
import pandas as pd

STRIDE = 30  # raw frames per 1 FPS step


def centre(x0: float, y0: float, vx: float, vy: float, start: int, frame):
    """Box-centre of the fixture's integer 10x20 px boxes on a linear track started at `start`."""
    xmin = np.round(x0 + vx * (np.asarray(frame) - start) - 5)
    ymin = np.round(y0 + vy * (np.asarray(frame) - start) - 10)
    return xmin, ymin


def annotation_lines(track: int, frames, x0: float, y0: float, vx: float, vy: float,
                     label: str = "Pedestrian", lost=0) -> list[str]:
    """SDD rows for a box of 10x20 px whose centre moves linearly by (vx, vy) per raw frame."""
    frames = list(frames)
    lost_flags = lost if isinstance(lost, (list, tuple)) else [lost] * len(frames)
    xmin, ymin = centre(x0, y0, vx, vy, frames[0], frames)
    return [f'{track} {int(a)} {int(b)} {int(a) + 10} {int(b) + 20} {f} {flag} 0 0 "{label}"'
            for a, b, f, flag in zip(xmin, ymin, frames, lost_flags)]


def write_annotations(root: Path, scene: str, video: int, lines: list[str]) -> Path:
    folder = root / "annotations" / scene / f"video{video}"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "reference.jpg").write_bytes(b"\xff\xd8fixture-jpeg\xff\xd9")
    path = folder / "annotations.txt"
    path.write_text("\n".join(lines) + "\n")
    return path


def release_rows(scene_id: str, track: int, first_frame: int, track_start: int, x0: float,
                 y0: float, vx: float, vy: float, meta_id: int, length: int = 35) -> pd.DataFrame:
    """One release window (the authors' pickle layout) of a linear fixture track, every 30 frames."""
    frames = first_frame + STRIDE * np.arange(length)
    xmin, ymin = centre(x0, y0, vx, vy, track_start, frames)
    return pd.DataFrame({"trackId": track, "frame": frames, "x": xmin + 5.0, "y": ymin + 10.0,
                         "sceneId": scene_id, "metaId": meta_id})


def write_maps_folder(folder: Path, maps: dict[str, np.ndarray], classes: list[str],
                      key: str = "videos", entries: dict[str, dict] | None = None) -> Path:
    """`maps.npz` (uint8 maps) and its `index.json`, as `pipeline.data.semantic_maps` (key
    "videos") and `pipeline.benchmarks.ethucy` (key "scenes", `entries` adding e.g. homographies)
    write them."""
    folder.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(folder / "maps.npz", **maps)
    listed = {name: {"shape": list(m.shape), **(entries or {}).get(name, {})} for name, m in maps.items()}
    (folder / "index.json").write_text(json.dumps({
        "classes": list(classes), "resize": 0.25, "encoding": "uint8, probability = value / 255",
        key: listed}))
    return folder


def write_manifest(source_root: Path, manifest: Path) -> None:
    lines = []
    for path in sorted(p for p in source_root.rglob("*") if p.is_file()):
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        lines.append(f"{digest}  {path.relative_to(source_root).as_posix()}")
    manifest.parent.mkdir(parents=True, exist_ok=True)
    manifest.write_text("\n".join(lines) + "\n")


def write_mirror(mirror: Path, manifests: Path) -> dict:
    """A mini mirror with sdd/ and ynet-release/; returns the expected window counts.

    gates_2 (test): track 1 is 2 x 35 s long (2 windows at t_f = 30), track 2 is a biker.
    bookstore_0 (train): track 3 has a gap (split into a 36 s and a 20 s piece), track 4 is lost
    for a while. The release holds exactly the t_f = 30 windows of gates_2 and bookstore_0.
    """
    sdd = mirror / "sdd"
    long = range(100, 100 + 70 * STRIDE)
    write_annotations(sdd, "gates", 2, [
        *annotation_lines(1, long, 400.0, 300.0, 0.05, -0.02),
        *annotation_lines(2, range(0, 40 * STRIDE), 100.0, 100.0, 0.2, 0.0, label="Biker"),
    ])
    piece_a = range(0, 36 * STRIDE)
    piece_b = range(36 * STRIDE + 5, 36 * STRIDE + 5 + 20 * STRIDE)
    write_annotations(sdd, "bookstore", 0, [
        *annotation_lines(3, piece_a, 50.0, 60.0, 0.03, 0.03),
        *annotation_lines(3, piece_b, 200.0, 60.0, 0.0, 0.03),
        *annotation_lines(4, range(0, 12 * STRIDE), 10.0, 10.0, 0.01, 0.0,
                          lost=[0] * (6 * STRIDE) + [1] * (6 * STRIDE)),
    ])
    release = mirror / "ynet-release" / "data" / "SDD"
    release.mkdir(parents=True)
    release_rows("bookstore_0", 3, 0, 0, 50.0, 60.0, 0.03, 0.03, meta_id=0).to_pickle(
        release / "train_longterm.pkl")
    pd.concat([
        release_rows("gates_2", 1, 100, 100, 400.0, 300.0, 0.05, -0.02, meta_id=0),
        release_rows("gates_2", 1, 100 + 35 * STRIDE, 100, 400.0, 300.0, 0.05, -0.02, meta_id=1),
    ], ignore_index=True).to_pickle(release / "test_longterm.pkl")
    for source in ("sdd", "ynet-release"):
        write_manifest(mirror / source, manifests / f"{source}.sha256")
    return {"release": {"train": 1, "test": 2}, "raw_tf30": {"train": 1, "test": 2},
            "raw_tf5": {"train": 3 + 2, "test": 7}}


WALKER_SCENES = [("gates_0", "train", 6), ("gates_1", "val", 2), ("gates_2", "test", 3)]
"""(scene_id, split, walkers) of `write_walker_scenes`: one scene per split."""


def write_walker_scenes(root: Path, table: Path, image_hw: tuple[int, int],
                        walkers: Callable[..., pd.DataFrame]) -> None:
    """What a Y-net training stage reads, under `root`: the window table `table` of the windows
    `walkers(scene_id, split, n, first_id, rng)` gives per scene of `WALKER_SCENES`, each scene's
    random `reference.jpg` (`sdd/annotations/<scene>/video<k>/`, `image_hw` pixels) and random class
    maps at a quarter of it (`semantic_maps/`). One generator (seed 1) draws everything, in that
    order per scene."""
    from pipeline.data.semantic_maps import quantise
    from pipeline.data.window_table import conform
    from ynet.segmentation import CLASS_NAMES

    rng = np.random.default_rng(1)
    tables, maps = [], {}
    for scene_id, split, n in WALKER_SCENES:
        tables.append(walkers(scene_id, split, n, 100 * len(tables), rng))
        scene, video = scene_id.rsplit("_", 1)
        folder = root / "sdd" / "annotations" / scene / f"video{video}"
        folder.mkdir(parents=True)
        assert cv2.imwrite(str(folder / "reference.jpg"),
                           rng.integers(0, 255, (*image_hw, 3), dtype=np.uint8))
        probs = rng.dirichlet(np.ones(6), size=(image_hw[0] // 4, image_hw[1] // 4))
        maps[scene_id] = quantise(probs.transpose(2, 0, 1).astype(np.float32))
    conform(pd.concat(tables)).to_parquet(table)
    write_maps_folder(root / "semantic_maps", maps, CLASS_NAMES)
