"""The short-term benchmarks as `pipeline.harness.stored_scores.Benchmark`s: what scoring their
stored predictions (`data/predictions/short_term/<dataset>/<model>.parquet`) needs besides the
files (stage `score_short_term_predictions`, `metrics/beyond/short_term.json`).

- TrajNet SDD (`sdd_trajnet.parquet`, benchmark `short_term_sdd_trajnet`): original pixels, truth
  columns `x`, `y`, the test windows. Metres per pixel: SDD's estimated scales per video, as for
  the long-term benchmark (they agree with TrajNet's own `H_SDD.txt` ratios, the table's
  `x_m / x`, to 1e-4 relative on every test video). Scene masks: the hand labels of `data/labels`
  at the original resolution (they cover all 60 SDD videos, so every TrajNet test window),
  forbidden classes `forbidden_classes`.
- An ETH/UCY fold (`ethucy_<fold>.parquet`, benchmark `short_term_ethucy_<fold>`): metres, truth
  columns `x_m`, `y_m`, the test windows; the unit is metres (no scale). Scene masks: the road /
  not-road maps `short_term_windows` stores for Y-net (`ethucy_semantic/maps.npz`: the authors'
  `oracle.png` at `resize` of each scene's original pixel grid `image_hw`). A position in metres
  goes to that grid through the inverse of the scene's homography (`swap`: eth, hotel), then to
  the map at `resize` map pixels per pixel; a map pixel is not road where its not-road probability
  exceeds its road probability (the maps are area-resized: a boundary pixel holds both), and not
  road is the forbidden class. A position the inverse homography sends to infinity (the horizon)
  counts as outside the map. SGAN's loader cuts a window at every frame, so each neighbour shares
  frames with a window in up to 2 n_f - 1 overlapping windows (zara1: 81 partner windows of 7
  other pedestrians on average): collisions are counted only between windows that start at the
  same frame, one sequence (`Benchmark.same_start_collisions`). TrajNet SDD's windows meet each
  neighbour once and keep the long-term rule (any shared raw frame). The same sequences (scene_id
  = S-GAN's file, first frame = its start frame) give S-GAN's own ADE / FDE
  (`ade_sgan_sequence`, `fde_sgan_sequence`; the paper's ETH/UCY S-GAN row is scored so).

Window ids are those of the dataset's table; an id of another split is "not in" the benchmark.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from pipeline.data.homography import metres_to_pixels
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.short_term import MAP_CLASSES, METRE_COLUMNS, load_ethucy_scenes
from pipeline.harness.stored_scores import Benchmark, SceneMasks
from pipeline.io import IntermediateError, index_value, read_json_index

SDD = "sdd"
SDD_TABLE = "sdd_trajnet.parquet"  # as pipeline.runners.short_term.table_path names the tables
ETHUCY_SCENES = "ethucy_semantic"  # maps.npz + index.json inside the short_term_windows folder
SPLIT = "test"  # the windows the evaluate_short_term_* stages predict
NOT_ROAD, ROAD = MAP_CLASSES.index("not_road"), MAP_CLASSES.index("road")


def table_path(windows: Path, dataset: str) -> Path:
    """The window table of `dataset` (sdd or an ETH/UCY fold) in the short_term_windows folder."""
    return Path(windows) / (SDD_TABLE if dataset == SDD else f"ethucy_{dataset}.parquet")


def benchmark_name(table: Path) -> str:
    """The benchmark a short-term table defines, as its predictions' metadata names it."""
    return f"short_term_{Path(table).stem}"


def trajnet_sdd(windows: Path, n_past: int, masks: SceneMasks, scales: Mapping[str, float],
                scales_path: Path) -> Benchmark:
    table = table_path(windows, SDD)
    return Benchmark(benchmark_name(table), table, "px", n_past, ("x", "y"), SPLIT,
                     metres_per_unit=scales, scales_source=f"per video, {Path(scales_path)}",
                     masks=masks)


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


def ethucy_fold(windows: Path, fold: str, n_past: int, masks: SceneMasks) -> Benchmark:
    table = table_path(windows, fold)
    return Benchmark(benchmark_name(table), table, "m", n_past, tuple(METRE_COLUMNS), SPLIT,
                     masks=masks, same_start_collisions=True)


def short_term_benchmarks(windows: Path, predictions: Path, datasets: Sequence[str], n_past: int,
                          sdd_masks: SceneMasks, scales: Mapping[str, float], scales_path: Path
                          ) -> dict[str, tuple[Benchmark, Path]]:
    """{dataset: (its Benchmark, its predictions folder `<predictions>/<dataset>`)}: what
    `stored_scores.score_benchmarks` scores. The ETH/UCY maps are read only if a fold is asked
    for."""
    folds = [d for d in datasets if d != SDD]
    roads = road_masks(Path(windows) / ETHUCY_SCENES) if folds else None
    out = {}
    for dataset in datasets:
        benchmark = (trajnet_sdd(windows, n_past, sdd_masks, scales, scales_path)
                     if dataset == SDD else ethucy_fold(windows, dataset, n_past, roads))
        out[dataset] = (benchmark, Path(predictions) / dataset)
    return out
