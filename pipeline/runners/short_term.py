"""One model on one short-term benchmark (paper Tables 1 and 2): what the stages
`train_short_term_ynet`, `evaluate_short_term_ynet`, `train_short_term_baseline` and
`evaluate_short_term_baseline` share.

Benchmarks (`--dataset`, `pipeline.benchmarks.registry.short_term`): `sdd`, the TrajNet split
(errors in original pixels), or one ETH/UCY leave-one-scene-out fold, `eth`, `hotel`, `univ`,
`zara1`, `zara2` (errors in metres). Each says where its windows are, loads them (original
pixels, the test truth in its unit) and holds its own settings keys (`settings_key`). Windows of
n_p = 8 observed + n_f = 12 future steps at 2.5 FPS, as `short_term_windows` cut them.

- Y-net, the authors' short-term configuration (params.yaml `short_term_models.paper`): the goal
  is the only waypoint (step n_f - 1), TTST with temperature 1.0 and rel_threshold 0.01 (`cpu`:
  its own threshold per benchmark, `rel_threshold.<benchmark>`), no CWS, K_a = 1.
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
(`pipeline.benchmarks.ethucy.to_metres`) and compared with the table's metre columns `x_m`,
`y_m`; upstream mixes pixels and metres there (upstream bug 4). The first K's rounds can be kept
as scored, in the benchmark's unit (a `pipeline.harness.predictions.PredictionRounds`; metadata:
`ShortTermBenchmark.prediction_metadata`), and `ynet_qualitative` draws a few test windows as the long-term
qualitative figure draws its own.

A Y-net run on a dataset outside `ynet_datasets` gets the not-run record instead (a profile's
choice, as `ynet_horizons`), which the report shows in the cell.

Files: the training record `{dataset, model, profile, trained: true, train: <facts>}` (or the
not-run record) and the run record `run_record` builds from it and the scores (the layout
`short_term_tables` and the report read); the stored predictions and Y-net's qualitative arrays.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from pipeline.benchmarks.short_term import ShortTermBenchmark, ShortTermSplits
from pipeline.config.cws import CwsParams
from pipeline.config.ttst import TtstParams
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.window_table import WindowArrays, subset
from pipeline.data.ynet_data import SceneWindows
from pipeline.device import CPU, generator
from pipeline.runners import baselines
from pipeline.harness.metrics import seeded_rounds, window_errors
from pipeline.harness.predictions import PredictionRounds
from pipeline.io import IntermediateError
from pipeline.preemption import NEVER, Preemption
from pipeline.runners.ynet_scoring import (Sampling, predict_samplings, qualitative_examples,
                                           sampling_options)
from pipeline.runners.ynet_training import train
from ynet.model import YNet
from ynet.sampling import SamplingOptions

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.short_term_models import ShortTermModelsParams
    from pipeline.config.ynet import YnetSettings


# ---------------------------------------------------------------------------------------------
# Windows


def sample_windows(arrays: WindowArrays, n: int, seed: int) -> WindowArrays:
    """A fixed seeded sample of `n` windows in their original order (all of them if n = 0 or more)."""
    if n == 0 or n >= len(arrays):
        return arrays
    rows = np.sort(np.random.default_rng(seed).choice(len(arrays), n, replace=False))
    return subset(arrays, rows)


# ---------------------------------------------------------------------------------------------
# Scoring


def score(sample: Callable[[int], tuple[np.ndarray, np.ndarray | None, np.ndarray | None]],
          bench: ShortTermSplits, rounds: int, seed: int, kept: PredictionRounds | None = None) -> dict:
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


# ---------------------------------------------------------------------------------------------
# Inputs


def ynet_maps(maps_path: Path) -> tuple[dict[str, np.ndarray], int]:
    """Y-net's scene maps (SDD's `data/semantic_maps`, or ETH/UCY's `EthUcyFold.maps`) and their
    channel count."""
    maps = load_semantic_maps(maps_path)
    if not maps:
        raise IntermediateError(f"{maps_path}: the index lists no maps")
    # every map has the index's class count (load_semantic_maps checks each against it)
    return maps, next(iter(maps.values())).shape[0]


# ---------------------------------------------------------------------------------------------
# Y-net

YNET_REPORTED_SETTINGS = ("resize", "kernel_size", "sigma", "crop", "crop_lead_steps", "waypoints",
                          "batch_size", "learning_rate", "augmentations", "steps_per_epoch",
                          "semantic_classes")
"""The settings a run record shows under `train.settings` (read from the checkpoint)."""


def missing_raw_source(benchmark: ShortTermBenchmark, options: Mapping[str, Any],
                       images: bool) -> str | None:
    """Why Y-net cannot run on `benchmark` with a stage's `options` (`vars(args)`): the first
    fetched raw source it reads (`ShortTermBenchmark.raw_sources`) that is not given; None if
    none is missing."""
    for source in benchmark.raw_sources(images):
        if options.get(source.replace("-", "_")) is None:
            return f"Y-net on {benchmark.dataset} needs --{source}"
    return None


def train_ynet(bench: ShortTermSplits, semantic_maps, sizes, settings: YnetSettings, n_past: int,
               folder: Path, val_windows: int, seed: int, device: torch.device = CPU,
               preemption: Preemption = NEVER) -> dict:
    """Train (or resume) Y-net in `folder` (`last.pt`, `best.pt`, `history.csv`), the epoch selected
    on `val_windows` validation windows sampled with `seed`; returns the training facts."""
    val = sample_windows(bench.val, val_windows, seed)
    return train(bench.train, val, semantic_maps, sizes, settings, n_past, folder / "last.pt",
                 folder / "best.pt", folder / "history.csv", device=device, preemption=preemption)


def ynet_options(params: ShortTermModelsParams, benchmark: ShortTermBenchmark, k: int
                 ) -> SamplingOptions:
    """The short-term sampling on `benchmark` at K_e = `k`: TTST (its own threshold), no CWS,
    K_a = 1 (the goal is the only waypoint)."""
    ttst = TtstParams(temperature=params.temperature,
                      rel_threshold=benchmark.rel_threshold(params))
    return sampling_options(k, 1, ttst, CwsParams(), use_ttst=True, use_cws=False)


def score_ynet(model: YNet, loaded: YnetSettings, scenes: list[SceneWindows],
               bench: ShortTermSplits, benchmark: ShortTermBenchmark,
               params: ShortTermModelsParams, ks: list[int],
               kept: PredictionRounds | None = None) -> tuple[dict[int, dict], float, dict]:
    """Score the checkpoint `load_for_scoring` gave (`model`, its settings `loaded`, `bench.test`
    of `benchmark` grouped by scene) at every K_e of `ks`: (scores per K, seconds, the model's
    reported settings). `kept` receives the rounds of the first K (`score`). Reads only the scoring
    keys of `params` (temperature, rel_threshold, the K lists, rounds, seed, eval_batch_size,
    eval_chunk_size, bf16)."""
    eval_params = params.eval_params()
    start, results = time.perf_counter(), {}
    samplings = [Sampling(ynet_options(params, benchmark, k), params.seed + r)
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


def ynet_qualitative(model: YNet, loaded: YnetSettings, scenes: list[SceneWindows],
                     bench: ShortTermSplits, benchmark: ShortTermBenchmark,
                     params: ShortTermModelsParams, k: int,
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
    return qualitative_examples(model, picks, loaded, ynet_options(params, benchmark, k), params.seed,
                                loaded.crop, loaded.crop_lead_steps)


# ---------------------------------------------------------------------------------------------
# Baselines


def train_baseline(name: str, bench: ShortTermSplits, config, folder: Path, train_seed: int,
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


def score_baseline(name: str, bench: ShortTermSplits, folder: Path, ks: list[int], rounds: int, seed: int,
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


def run_record(dataset: str, model: str, profile: str, bench: ShortTermSplits, rounds: int,
               ks: list[int], results: dict[int, dict], facts: dict) -> dict:
    """The run's metrics (`metrics/short_term/runs/<dataset>_<model>.json`); `facts`: the training
    facts with `eval_seconds` (and, for Y-net, `settings`) added."""
    return {"dataset": dataset, "model": model, "profile": profile, "trained": True,
            "unit": bench.unit, "n_windows": len(bench.test), "rounds": rounds, "ks": ks,
            **{f"k{k}": result for k, result in results.items()},
            "train_seconds": facts["train_seconds"], "eval_seconds": facts["eval_seconds"],
            "train": facts}
