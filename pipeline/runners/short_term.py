"""One model on one short-term benchmark (paper Tables 1 and 2): what the stages
`train_short_term_ynet`, `evaluate_short_term_ynet`, `train_short_term_baseline` and
`evaluate_short_term_baseline` share.

Benchmarks (`--dataset`): `sdd`, the TrajNet split (errors in original pixels), or one ETH/UCY
leave-one-scene-out fold, `eth`, `hotel`, `univ`, `zara1`, `zara2` (errors in metres). Windows of
n_p = 8 observed + n_f = 12 future steps at 2.5 FPS, as `short_term_windows` cut them.

- Y-net, the authors' short-term configuration (`shared/reference/upstream.md`): the goal is the
  only waypoint (step n_f - 1), TTST with temperature 1.0 and rel_threshold 0.01 (`cpu`: its
  own threshold per benchmark, `rel_threshold.<benchmark>`), no CWS, K_a = 1.
  Architecture, optimiser and augmentation are `ynet.<profile>`'s; map scale, Gaussian kernel and
  sigma per benchmark are `short_term_models.<profile>`'s (`ynet_sdd`, `ynet_ethucy`). ETH/UCY maps
  have 3 channels (padding, not road, road), SDD's 6.
- S-GAN and PECNet: their `sgan` / `pecnet` sections with `short_term_models`' epochs, on the same
  windows.

Y-net may see a square window around each agent instead of its whole scene, in training and
scoring alike (`crop` of `ynet_sdd` / `ynet_ethucy`, centred `crop_lead_steps` steps of its last
velocity ahead): the cpu profile's speed-up, since a 4.8-s future stays near the agent.

Training (`train_ynet`, `train_baseline`) selects the epoch on validation ADE in pixels over at most
`val_windows` validation windows (a seeded sample), never the test set, and resumes from the
checkpoint folder. Y-net trains with `pipeline.runners.ynet_training.train` (the long-term loop);
`YnetSettings.semantic_classes` and `steps_per_epoch` carry the differences.

Scoring (`score_ynet`, `score_baseline`) takes the best epoch of the checkpoint folder (its
settings with it) and scores it at each K of `k_sdd` / `k_ethucy` (best of K; K_e for Y-net) on
every test window, in `rounds` seeded rounds (round r: seed + r), with `pipeline.harness.metrics`
(independent minima, the paper's protocol, and joint ones). ETH/UCY: every predicted position
(original pixels) is mapped to metres through its scene's homography and swap flag
(`pipeline.data.homography.pixels_to_metres`) and compared with the table's metre columns `x_m`,
`y_m`; upstream mixes pixels and metres there (upstream bug 4). The first K's rounds can be kept
as scored, in the benchmark's unit (a `pipeline.harness.predictions.PredictionRounds`; metadata:
`prediction_metadata`), and `ynet_qualitative` draws a few test windows as the long-term
qualitative figure draws its own.

A Y-net run on a dataset outside `ynet_datasets` gets the not-run record instead (a profile's
choice, as `ynet_horizons`), which the report shows in the cell.

Files: the training record `{dataset, model, profile, trained: true, train: <facts>}` (or the
not-run record) and the run record `run_record` builds from it and the scores (the layout
`short_term_tables` and the report read); the stored predictions and Y-net's qualitative arrays.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from pipeline.config import CwsParams, ShortTermModelsParams, TtstParams, YnetSettings
from pipeline.data.homography import pixels_to_metres
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.short_term import (METRE_COLUMNS, EthUcySceneInfo, ethucy_scene_image,
                                       load_ethucy_scenes)
from pipeline.data.window_table import WindowArrays, to_arrays
from pipeline.data.ynet_data import SceneWindows, image_sizes
from pipeline.device import CPU, generator
from pipeline.harness import baselines
from pipeline.harness.baselines.common import select_split, subset
from pipeline.harness.metrics import seeded_rounds, window_errors
from pipeline.harness.predictions import PredictionRounds
from pipeline.io import IntermediateError
from pipeline.preemption import NEVER, Preemption
from pipeline.runners.ynet_scoring import (Sampling, predict_samplings, qualitative_examples,
                                           sampling_options, sdd_scene_image)
from pipeline.runners.ynet_training import train
from ynet.model import YNet
from ynet.sampling import SamplingOptions

# File names inside the `short_term_windows` output folder (pipeline.data.short_term.build).
SDD_TABLE = "sdd_trajnet.parquet"
ETHUCY_SCENES = "ethucy_semantic"  # maps.npz + index.json (pixel grid, homography, swap per scene)
METRES_TOLERANCE = 1e-6  # m: the homography must give back the table's metres of the ground truth


def benchmark_of(dataset: str) -> str:
    return "sdd" if dataset == "sdd" else "ethucy"


def unit_of(dataset: str) -> str:
    """px (SDD: original pixels) or m (ETH/UCY: metres through the homographies)."""
    return "px" if dataset == "sdd" else "m"


def table_path(windows: Path, dataset: str) -> Path:
    return Path(windows) / (SDD_TABLE if dataset == "sdd" else f"ethucy_{dataset}.parquet")


# ---------------------------------------------------------------------------------------------
# Settings


def ynet_settings(base: YnetSettings, params: ShortTermModelsParams, dataset: str, n_future: int,
                  semantic_classes: int) -> YnetSettings:
    """`ynet.<profile>` with the short-term goal-only waypoint, this benchmark's scale and epochs,
    and the benchmark's training departures (`ynet_training.<benchmark>`)."""
    benchmark = benchmark_of(dataset)
    scale = params.ynet_sdd if benchmark == "sdd" else params.ynet_ethucy
    return YnetSettings(**{
        **asdict(base), **asdict(scale), **params.ynet_training.of(benchmark).overrides(),
        "waypoints": [n_future - 1], "epochs": params.epochs["ynet"][benchmark],
        "semantic_classes": semantic_classes, "steps_per_epoch": params.ynet_steps_per_epoch})


# ---------------------------------------------------------------------------------------------
# Windows and units


@dataclass(frozen=True)
class Benchmark:
    """One dataset's windows (original pixels) and the test ground truth in the unit it is scored in."""

    train: WindowArrays
    val: WindowArrays
    test: WindowArrays
    truth: np.ndarray  # (N_test, n_f, 2) in `unit`
    unit: str  # px | m
    to_unit: Callable[[np.ndarray], np.ndarray]  # (N_test, ..., 2) original pixels -> unit


def sample_windows(arrays: WindowArrays, n: int, seed: int) -> WindowArrays:
    """A fixed seeded sample of `n` windows in their original order (all of them if n = 0 or more)."""
    if n == 0 or n >= len(arrays):
        return arrays
    rows = np.sort(np.random.default_rng(seed).choice(len(arrays), n, replace=False))
    return subset(arrays, rows)


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


def load_benchmark(table: pd.DataFrame, dataset: str, n_past: int, n_future: int,
                   scenes: dict[str, EthUcySceneInfo] | None) -> Benchmark:
    """Splits of a short-term window table; ETH/UCY (`scenes` given): test truth in metres."""
    arrays = to_arrays(table, n_past)
    if arrays.future.shape[1] != n_future:
        raise ValueError(f"{dataset}: windows of {n_past} + {arrays.future.shape[1]} steps, "
                         f"expected {n_past} + {n_future}")
    train, val, test = (select_split(arrays, s) for s in ("train", "val", "test"))
    if min(len(train), len(val), len(test)) == 0:
        raise ValueError(f"{dataset}: every split needs windows (train {len(train)}, "
                         f"val {len(val)}, test {len(test)})")
    if scenes is None:
        return Benchmark(train, val, test, test.future, "px", lambda points: points)
    metres = select_split(to_arrays(table.assign(x=table["x_m"], y=table["y_m"]), n_past), "test")
    assert np.array_equal(metres.window_id, test.window_id)  # one order: window_id
    missing = sorted(set(test.scene_id) - set(scenes))
    if missing:
        raise ValueError(f"{dataset}: no homography for test scene(s) {missing}")

    def to_unit(points: np.ndarray) -> np.ndarray:
        return to_metres(points, test.scene_id, scenes)

    worst = float(np.abs(to_unit(test.future) - metres.future).max())
    if worst > METRES_TOLERANCE:
        raise ValueError(f"{dataset}: the scenes' homographies map the test pixels {worst:.3g} m "
                         "away from the table's metres: tables and scene index disagree")
    return Benchmark(train, val, test, metres.future, "m", to_unit)


# ---------------------------------------------------------------------------------------------
# Scoring


def score(sample: Callable[[int], tuple[np.ndarray, np.ndarray | None, np.ndarray | None]],
          bench: Benchmark, rounds: int, seed: int, kept: PredictionRounds | None = None) -> dict:
    """Best-of-K errors in the benchmark's unit over seeded rounds; `kept` (for `bench.test`'s
    windows) receives each round's paths, goals and weights in that unit, exactly as scored.

    sample(seed) -> (paths (N, K, n_f, 2), goals (N, K, 2) or None, weights (N, K) or None), paths
    and goals in original pixels.
    """
    def score_round(round_seed: int):
        paths, goals, weights = sample(round_seed)
        paths = bench.to_unit(paths)  # (N, K, n_f, 2) in bench.unit
        goals = None if goals is None else bench.to_unit(goals)  # (N, K, 2)
        if kept is not None:
            kept.add(round_seed, paths, weights=weights, goals=goals)
        return window_errors(paths, bench.truth, goals)

    return seeded_rounds(score_round, rounds, seed)


def prediction_metadata(windows: Path, dataset: str, model: str, ks: list[int] | None = None,
                        **extra) -> dict:
    """What a stored short-term predictions file records besides its seeds: the model, the
    benchmark of the window table scored (`short_term_<table stem>`: window ids belong to their
    table), the unit and the table's columns the predictions compare with, the split and, where
    scored, K (the first of `ks`, the K stored) and every K scored."""
    table = table_path(windows, dataset)
    metadata = {"model": model, "benchmark": f"short_term_{table.stem}", "unit": unit_of(dataset),
                "truth_columns": ["x", "y"] if dataset == "sdd" else list(METRE_COLUMNS),
                "split": "test", "window_table": str(table)}
    if ks is not None:
        metadata.update(k=ks[0], ks_scored=list(ks))
    return {**metadata, **extra}


# ---------------------------------------------------------------------------------------------
# Inputs


def load_dataset(windows: Path, dataset: str, n_past: int,
                 n_future: int) -> tuple[Benchmark, dict[str, EthUcySceneInfo] | None]:
    """The benchmark of `dataset` from the `short_term_windows` folder, and (ETH/UCY) its scenes."""
    ethucy_scenes = None
    if dataset != "sdd":
        ethucy_scenes = load_ethucy_scenes(Path(windows) / ETHUCY_SCENES)
    table = pd.read_parquet(table_path(windows, dataset))
    return load_benchmark(table, dataset, n_past, n_future, ethucy_scenes), ethucy_scenes


def ynet_inputs(maps_path: Path, sdd: Path | None, scene_ids: set[str],
                ethucy_scenes: dict[str, EthUcySceneInfo] | None
                ) -> tuple[dict[str, np.ndarray], dict[str, tuple[int, int]], int]:
    """Y-net's scene maps, the original (height, width) of each of `scene_ids` (SDD: its reference
    image under `sdd`; ETH/UCY: the scene index) and the maps' channel count."""
    maps = load_semantic_maps(maps_path)
    if ethucy_scenes is None:
        sizes = image_sizes(sdd, scene_ids)
    else:
        sizes = {name: info.image_hw for name, info in ethucy_scenes.items()}
    if not maps:
        raise IntermediateError(f"{maps_path}: the index lists no maps")
    # every map has the index's class count (load_semantic_maps checks each against it)
    return maps, sizes, next(iter(maps.values())).shape[0]


# ---------------------------------------------------------------------------------------------
# Y-net

YNET_REPORTED_SETTINGS = ("resize", "kernel_size", "sigma", "crop", "crop_lead_steps", "waypoints",
                          "batch_size", "learning_rate", "augmentations", "steps_per_epoch",
                          "semantic_classes")
"""The settings a run record shows under `train.settings` (read from the checkpoint)."""


def train_ynet(bench: Benchmark, semantic_maps, sizes, settings: YnetSettings, n_past: int,
               folder: Path, val_windows: int, seed: int, device: torch.device = CPU,
               preemption: Preemption = NEVER) -> dict:
    """Train (or resume) Y-net in `folder` (`last.pt`, `best.pt`, `history.csv`), the epoch selected
    on `val_windows` validation windows sampled with `seed`; returns the training facts."""
    val = sample_windows(bench.val, val_windows, seed)
    return train(bench.train, val, semantic_maps, sizes, settings, n_past, folder / "last.pt",
                 folder / "best.pt", folder / "history.csv", device=device, preemption=preemption)


def ynet_options(params: ShortTermModelsParams, dataset: str, k: int) -> SamplingOptions:
    """The short-term sampling of `dataset` at K_e = `k`: TTST (its benchmark's threshold), no
    CWS, K_a = 1 (the goal is the only waypoint)."""
    ttst = TtstParams(temperature=params.temperature,
                      rel_threshold=params.rel_threshold[benchmark_of(dataset)])
    return sampling_options(k, 1, ttst, CwsParams(), use_ttst=True, use_cws=False)


def score_ynet(model: YNet, loaded: YnetSettings, scenes: list[SceneWindows], bench: Benchmark,
               dataset: str, params: ShortTermModelsParams, ks: list[int],
               kept: PredictionRounds | None = None) -> tuple[dict[int, dict], float, dict]:
    """Score the checkpoint `load_for_scoring` gave (`model`, its settings `loaded`, `bench.test`
    of `dataset` grouped by scene) at every K_e of `ks`: (scores per K, seconds, the model's
    reported settings). `kept` receives the rounds of the first K (`score`). Reads only the scoring
    keys of `params` (temperature, rel_threshold, the K lists, rounds, seed, eval_batch_size,
    eval_chunk_size, bf16)."""
    eval_params = params.eval_params()
    start, results = time.perf_counter(), {}
    samplings = [Sampling(ynet_options(params, dataset, k), params.seed + r)
                 for k in ks for r in range(params.rounds)]  # all sampled in one pass
    sampled, _ = predict_samplings(model, scenes, loaded, samplings, eval_params, len(bench.test),
                                   f"Y-net K_e={'/'.join(map(str, ks))}", loaded.crop,
                                   loaded.crop_lead_steps)
    for number, k in enumerate(ks):
        rounds = sampled[number * params.rounds:(number + 1) * params.rounds]

        def sample(seed: int, rounds=rounds) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
            drawn = rounds[seed - params.seed]
            return drawn.paths, drawn.goals, drawn.weights

        results[k] = score(sample, bench, params.rounds, params.seed, kept if number == 0 else None)
    seconds = time.perf_counter() - start
    return results, seconds, {key: getattr(loaded, key) for key in YNET_REPORTED_SETTINGS}


QUALITATIVE_WINDOWS = 3  # test windows drawn for the animated view (few: one forward pass each)


def qualitative_rows(test: WindowArrays, n: int = QUALITATIVE_WINDOWS) -> list[int]:
    """Rows of `n` test windows that move farthest (last observed to last future position), in
    different scenes first, then of different tracks, then any: deterministic (ties to the lower
    row), and varied where the test split allows."""
    moved = np.linalg.norm(test.future[:, -1] - test.past[:, -1], axis=-1)  # (N,)
    order = np.argsort(-moved, kind="stable")
    chosen: list[int] = []
    for key in (lambda r: test.scene_id[r], lambda r: (test.scene_id[r], test.track_id[r]),
                lambda r: r):
        used = {key(r) for r in chosen}
        for r in order.tolist():
            if len(chosen) == n:
                return chosen
            if r not in chosen and key(r) not in used:
                chosen.append(r)
                used.add(key(r))
    return chosen


def scene_images(sdd: Path | None, ethucy_root: Path | None,
                 ethucy_scenes: dict[str, EthUcySceneInfo] | None) -> Callable[[str], np.ndarray]:
    """scene_id -> its original-size BGR image, on the grid of the windows' original pixels: SDD's
    `reference.jpg` under `sdd`, or (ETH/UCY, `ethucy_scenes` given) the camera image on the
    scene's oracle grid (`ethucy_scene_image`)."""
    if ethucy_scenes is None:
        return lambda scene_id: sdd_scene_image(sdd, scene_id)
    return lambda name: ethucy_scene_image(ethucy_root, name, ethucy_scenes[name].image_hw)


def ynet_qualitative(model: YNet, loaded: YnetSettings, scenes: list[SceneWindows],
                     bench: Benchmark, dataset: str, params: ShortTermModelsParams, k: int,
                     image_of: Callable[[str], np.ndarray]) -> dict[str, np.ndarray]:
    """The `qualitative_rows` windows drawn as the long-term qualitative figure draws its own
    (`ynet_scoring.qualitative_examples`: the same keys and dtypes, coordinates in pixels of the
    scene image resized to the model's map), sampled at K_e = `k` with `params.seed`, on the crop
    the model scores each window on."""
    by_id = {scene.scene_id: scene for scene in scenes}
    picks = []
    for r in qualitative_rows(bench.test):
        scene = by_id[bench.test.scene_id[r]]
        picks.append((scene, int(np.flatnonzero(scene.index == r)[0]), image_of(scene.scene_id)))
    return qualitative_examples(model, picks, loaded, ynet_options(params, dataset, k), params.seed,
                                loaded.crop, loaded.crop_lead_steps)


# ---------------------------------------------------------------------------------------------
# Baselines


def train_baseline(name: str, bench: Benchmark, config, folder: Path, train_seed: int,
                   val_windows: int, seed: int, device: torch.device = CPU,
                   preemption: Preemption = NEVER) -> dict:
    """Fit S-GAN or PECNet in `folder` (resuming), the epoch selected on `val_windows` validation
    windows sampled with `seed`; returns the training facts."""
    val = sample_windows(bench.val, val_windows, seed)
    model = baselines.get(name).fit(bench.train, val, config, folder, train_seed, device=device,
                                    preemption=preemption)
    fit = model.fit_result
    return {"epochs": fit.epochs, "best_epoch": fit.best_epoch, "best_val_ade_px": fit.best_val_ade,
            "train_seconds": fit.train_seconds, "train_windows": len(bench.train),
            "val_windows": len(val)}


def score_baseline(name: str, bench: Benchmark, folder: Path, ks: list[int], rounds: int, seed: int,
                   device: torch.device = CPU, kept: PredictionRounds | None = None
                   ) -> tuple[dict[int, dict], float]:
    """Score the best epoch in `folder` (its config from the checkpoint) at every K of `ks`;
    `kept` receives the rounds of the first K (`score`)."""
    model = baselines.get(name).load(folder, device)
    start, results = time.perf_counter(), {}
    for k in ks:
        def sample(seed: int, k=k) -> tuple[np.ndarray, None, None]:
            return model.predict(bench.test, k, generator(device, seed)), None, None

        results[k] = score(sample, bench, rounds, seed, kept if k == ks[0] else None)
    return results, time.perf_counter() - start


# ---------------------------------------------------------------------------------------------
# Records


def not_run_record(dataset: str, model: str, profile: str, params: ShortTermModelsParams) -> dict:
    reason = (f"Y-net is not trained on {dataset} in the {profile} profile (it runs on "
              f"{', '.join(params.ynet_datasets) or 'no dataset'} here)")
    if params.why_subset:
        reason += f": {params.why_subset}"
    return {"dataset": dataset, "model": model, "profile": profile, "trained": False,
            "not_run_reason": reason}


def training_record(dataset: str, model: str, profile: str, facts: dict) -> dict:
    """What a training stage writes beside its checkpoint folder."""
    return {"dataset": dataset, "model": model, "profile": profile, "trained": True, "train": facts}


def run_record(dataset: str, model: str, profile: str, bench: Benchmark, rounds: int, ks: list[int],
               results: dict[int, dict], facts: dict) -> dict:
    """The run's metrics (`metrics/short_term/runs/<dataset>_<model>.json`); `facts`: the training
    facts with `eval_seconds` (and, for Y-net, `settings`) added."""
    return {"dataset": dataset, "model": model, "profile": profile, "trained": True,
            "unit": bench.unit, "n_windows": len(bench.test), "rounds": rounds, "ks": ks,
            **{f"k{k}": result for k, result in results.items()},
            "train_seconds": facts["train_seconds"], "eval_seconds": facts["eval_seconds"],
            "train": facts}
