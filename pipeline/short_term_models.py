"""Stages `short_term_ynet` and `short_term_baseline`: one model trained and scored on one short-term
benchmark (paper Tables 1 and 2).

Benchmarks (`--dataset`): `sdd`, the TrajNet split (errors in original pixels), or one ETH/UCY
leave-one-scene-out fold, `eth`, `hotel`, `univ`, `zara1`, `zara2` (errors in metres). Windows of
n_p = 8 observed + n_f = 12 future steps at 2.5 FPS, as `short_term_windows` cut them.

- Y-net, the authors' short-term configuration (`shared/reference/upstream.md`): the goal is the
  only waypoint (step n_f - 1), TTST with temperature 1.0 and rel_threshold 0.01, no CWS, K_a = 1.
  Architecture, optimiser and augmentation are `ynet.<profile>`'s; map scale, Gaussian kernel and
  sigma per benchmark are this stage's (`ynet_sdd`, `ynet_ethucy`). ETH/UCY maps have 3 channels
  (padding, not road, road), SDD's 6.
- S-GAN and PECNet: their `sgan` / `pecnet` sections with this stage's epochs, on the same windows.

Y-net may see a square window around each agent instead of its whole scene, in training and
scoring alike (`crop` of `ynet_sdd` / `ynet_ethucy`, centred `crop_lead_steps` steps of its last
velocity ahead): the cpu profile's speed-up, since a 4.8-s future stays near the agent.

Every model is scored at each K of `k_sdd` / `k_ethucy` (best of K; K_e for Y-net) on every test
window, in `rounds` seeded rounds (round r: seed + r), with `pipeline.metrics` (independent minima,
the paper's protocol, and joint ones). ETH/UCY: every predicted position (original pixels) is mapped
to metres through its scene's homography and swap flag (`pipeline.homography.pixels_to_metres`)
and compared with the table's metre columns `x_m`, `y_m`; upstream mixes pixels and metres there
(upstream bug 4). Model selection (the epoch kept) uses validation ADE in pixels on at most
`val_windows` validation windows, never the test set. Training resumes from the checkpoint folder.

A Y-net run on a dataset outside `ynet_datasets` writes {"not_run_reason": ...} instead (a
profile's choice, as `ynet_horizons`), which the report shows in the cell.

Y-net trains with `pipeline.train_ynet.train` (the same loop, checkpoints and resumption as the
long-term model); `YnetSettings.semantic_classes` and `steps_per_epoch` carry the differences.

    python -m pipeline.short_term_models --dataset eth --model ynet --windows data/short_term \\
        --maps data/short_term/ethucy_semantic --checkpoint-dir checkpoints/short_term/eth_ynet \\
        --metrics metrics/short_term/runs/eth_ynet.json
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from pipeline import baselines
from pipeline.baselines.common import select_split, subset
from pipeline.device import CPU, RuntimeParams, describe, generator, select_device
from pipeline.evaluate_ynet import (CwsParams, EvalParams, TtstParams, load_model, predict_scenes,
                                    sampling_options, summarize_rounds, write_json)
from pipeline.homography import pixels_to_metres
from pipeline.metrics import summarize, window_errors
from pipeline.params import load_profile, load_section, read_params
from pipeline.preemption import NEVER, Preemption, exit_when_stopped
from pipeline.semantic_maps import load_semantic_maps
from pipeline.short_term import (FOLD_TEST_SCENES, EthUcySceneInfo, ShortTermParams,
                                 load_ethucy_scenes)
from pipeline.train_baseline import TrainBaselineParams, model_config
from pipeline.train_ynet import YnetSettings, image_sizes, train
from pipeline.window_table import WindowArrays, to_arrays
from pipeline.ynet_data import group_by_scene

DATASETS = ("sdd", *FOLD_TEST_SCENES)  # sdd, then the five ETH/UCY folds
MODELS = ("ynet", "sgan", "pecnet")
BENCHMARKS = ("sdd", "ethucy")
METRIC_KEYS = ("ade", "fde", "ade_joint", "fde_joint")
# File names inside the `short_term_windows` output folder (pipeline.short_term.build).
SDD_TABLE = "sdd_trajnet.parquet"
ETHUCY_SCENES = "ethucy_semantic"  # maps.npz + index.json (pixel grid, homography, swap per scene)
METRES_TOLERANCE = 1e-6  # m: the homography must give back the table's metres of the ground truth


def benchmark_of(dataset: str) -> str:
    return "sdd" if dataset == "sdd" else "ethucy"


def table_path(windows: Path, dataset: str) -> Path:
    return Path(windows) / (SDD_TABLE if dataset == "sdd" else f"ethucy_{dataset}.parquet")


# ---------------------------------------------------------------------------------------------
# Settings


@dataclass
class YnetScale:
    """Y-net's map scale on one benchmark and the Gaussian ground truth that goes with it."""

    resize: float
    """Maps and coordinates relative to the original image (authors: SDD 0.25, ETH/UCY 1 / 1.5)."""
    kernel_size: int
    """Side of the Gaussian ground-truth kernel, pixels of the resized map (authors: 31)."""
    sigma: float
    """Its standard deviation, pixels of the resized map (authors: 4)."""
    crop: int = 0
    """Side of the window around each agent the model sees (`YnetSettings.crop`); 0 = whole scene."""
    crop_lead_steps: float = 0.0
    """The window is centred this many steps of the last observed velocity ahead of the agent."""

    def __post_init__(self):
        if not 0 < self.resize <= 1 or self.sigma <= 0 or self.kernel_size % 2 != 1:
            raise ValueError("need 0 < resize <= 1, sigma > 0 and an odd kernel_size")


@dataclass
class ShortTermModelsParams:
    """Section `short_term_models.<profile>` of params.yaml."""

    epochs: dict[str, dict[str, int]]
    """Model (ynet, sgan, pecnet) -> benchmark (sdd, ethucy: each fold) -> training epochs."""
    ynet_steps_per_epoch: int
    """Y-net optimiser steps per epoch, about (windows drawn afresh each epoch); 0 = every window."""
    ynet_learning_rate: float | None
    """Y-net's Adam learning rate here; None = `ynet.<profile>`'s (the long-term model's)."""
    val_windows: int
    """Validation windows that select the epoch (a fixed seeded sample); 0 = all of them."""
    ynet_sdd: YnetScale
    ynet_ethucy: YnetScale
    ynet_datasets: list[str]
    """Datasets this profile trains and scores Y-net on; any other gets a not-run record."""
    why_subset: str
    """Shown in the report for a dataset outside `ynet_datasets`."""
    temperature: float
    """TTST temperature of the short-term setting (authors: 1.0)."""
    rel_threshold: float
    """TTST: goal pixels below rel_threshold * max are never sampled (authors: 0.01)."""
    k_sdd: list[int]
    """K values scored on SDD (Table 1: 20 and 5)."""
    k_ethucy: list[int]
    """K values scored on ETH/UCY (Table 2: 20)."""
    rounds: int
    """Seeded evaluation rounds; mean and spread are reported."""
    seed: int
    """Round r samples with seed + r; also draws the validation sample."""
    eval_batch_size: int
    """Y-net: test windows per forward pass (one scene per batch)."""
    eval_chunk_size: int
    """Y-net: samples per window decoded together by the trajectory decoder."""
    bf16: bool
    """Y-net: bfloat16 autocast for the trajectory decoder (`ynet.sampling.predict`)."""

    def __post_init__(self):
        if set(self.epochs) != set(MODELS) or any(
                set(e) != set(BENCHMARKS) or min(e.values()) < 1 for e in self.epochs.values()):
            raise ValueError(f"epochs must give every model {list(MODELS)} positive epochs for "
                             f"each of {list(BENCHMARKS)}, got {self.epochs}")
        if self.ynet_steps_per_epoch < 0 or self.val_windows < 0:
            raise ValueError("ynet_steps_per_epoch and val_windows must be >= 0 (0 = all)")
        if self.ynet_learning_rate is not None and self.ynet_learning_rate <= 0:
            raise ValueError(f"ynet_learning_rate must be positive or null, got {self.ynet_learning_rate}")
        unknown = sorted(set(self.ynet_datasets) - set(DATASETS))
        if unknown:
            raise ValueError(f"ynet_datasets: unknown dataset(s) {unknown}; known: {list(DATASETS)}")
        if not self.k_sdd or not self.k_ethucy or min(self.k_sdd + self.k_ethucy) < 1:
            raise ValueError("k_sdd and k_ethucy must be non-empty lists of positive K")
        if self.rounds < 1 or self.temperature <= 0 or not 0 <= self.rel_threshold < 1:
            raise ValueError("need rounds >= 1, temperature > 0 and 0 <= rel_threshold < 1")
        if min(self.eval_batch_size, self.eval_chunk_size) < 1:
            raise ValueError("eval_batch_size and eval_chunk_size must be positive")

    def ks(self, dataset: str) -> list[int]:
        return self.k_sdd if dataset == "sdd" else self.k_ethucy

    def eval_params(self) -> EvalParams:
        """What `evaluate_ynet.predict_scenes` reads (seeds are passed per round)."""
        return EvalParams(k_e=max(self.k_sdd + self.k_ethucy), k_a=1, rounds=self.rounds,
                          seed=self.seed, batch_size=self.eval_batch_size,
                          chunk_size=self.eval_chunk_size, bf16=self.bf16)


def ynet_settings(base: YnetSettings, params: ShortTermModelsParams, dataset: str, n_future: int,
                  semantic_classes: int) -> YnetSettings:
    """`ynet.<profile>` with the short-term goal-only waypoint, this benchmark's scale, epochs and
    (if set) learning rate."""
    scale = params.ynet_sdd if dataset == "sdd" else params.ynet_ethucy
    learning_rate = (base.learning_rate if params.ynet_learning_rate is None
                     else params.ynet_learning_rate)
    return YnetSettings(**{
        **asdict(base), **asdict(scale), "waypoints": [n_future - 1],
        "epochs": params.epochs["ynet"][benchmark_of(dataset)], "learning_rate": learning_rate,
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


def score(sample: Callable[[int], tuple[np.ndarray, np.ndarray | None]], bench: Benchmark,
          rounds: int, seed: int) -> dict:
    """Best-of-K errors in the benchmark's unit over seeded rounds.

    sample(seed) -> (paths (N, K, n_f, 2), goals (N, K, 2) or None) in original pixels.
    """
    per_round = []
    for r in range(rounds):
        paths, goals = sample(seed + r)
        errors = window_errors(bench.to_unit(paths), bench.truth,
                               None if goals is None else bench.to_unit(goals))
        per_round.append({key: value for key, value in summarize(errors).items()
                          if key in METRIC_KEYS})
    return {**summarize_rounds(per_round), "rounds": rounds, "per_round": per_round}


# ---------------------------------------------------------------------------------------------
# Y-net


def run_ynet(bench: Benchmark, semantic_maps, sizes, settings: YnetSettings, n_past: int,
             folder: Path, params: ShortTermModelsParams, ks: list[int],
             device: torch.device = CPU,
             preemption: Preemption = NEVER) -> tuple[dict, dict[int, dict]]:
    """Train (or resume) Y-net, then score its best epoch at every K_e of `ks`."""
    val = sample_windows(bench.val, params.val_windows, params.seed)
    facts = train(bench.train, val, semantic_maps, sizes, settings, n_past, folder / "last.pt",
                  folder / "best.pt", folder / "history.csv", device=device, preemption=preemption)
    model, loaded = load_model(folder / "best.pt", device)
    torch.set_num_threads(loaded.threads)
    scenes = group_by_scene(bench.test, semantic_maps, sizes, loaded.resize, device)
    ttst = TtstParams(temperature=params.temperature, rel_threshold=params.rel_threshold)
    eval_params = params.eval_params()
    start, results = time.perf_counter(), {}
    for k in ks:  # K_a = 1, no CWS: the goal is the only waypoint
        options = sampling_options(k, 1, ttst, CwsParams(), use_ttst=True, use_cws=False)

        def sample(seed: int, options=options) -> tuple[np.ndarray, np.ndarray]:
            return predict_scenes(model, scenes, loaded, options, seed, eval_params,
                                  len(bench.test), f"Y-net K_e={options.K_e}", loaded.crop,
                                  loaded.crop_lead_steps)

        results[k] = score(sample, bench, params.rounds, params.seed)
    facts["eval_seconds"] = time.perf_counter() - start
    facts["settings"] = {key: getattr(settings, key) for key in
                         ("resize", "kernel_size", "sigma", "crop", "crop_lead_steps", "waypoints",
                          "batch_size", "learning_rate", "augmentations", "steps_per_epoch",
                          "semantic_classes")}
    return facts, results


# ---------------------------------------------------------------------------------------------
# Baselines


def run_baseline(name: str, bench: Benchmark, config, folder: Path, train_seed: int,
                 params: ShortTermModelsParams, ks: list[int],
                 device: torch.device = CPU,
                 preemption: Preemption = NEVER) -> tuple[dict, dict[int, dict]]:
    """Fit S-GAN or PECNet (resuming from `folder`), then score its best epoch at every K."""
    val = sample_windows(bench.val, params.val_windows, params.seed)
    model = baselines.get(name).fit(bench.train, val, config, folder, train_seed, device=device,
                                    preemption=preemption)
    fit = model.fit_result
    facts = {"epochs": fit.epochs, "best_epoch": fit.best_epoch, "best_val_ade_px": fit.best_val_ade,
             "train_seconds": fit.train_seconds, "train_windows": len(bench.train),
             "val_windows": len(val)}
    start, results = time.perf_counter(), {}
    for k in ks:
        def sample(seed: int, k=k) -> tuple[np.ndarray, None]:
            return model.predict(bench.test, k, generator(device, seed)), None

        results[k] = score(sample, bench, params.rounds, params.seed)
    facts["eval_seconds"] = time.perf_counter() - start
    return facts, results


# ---------------------------------------------------------------------------------------------
# Stage


def not_run_record(dataset: str, model: str, profile: str, params: ShortTermModelsParams) -> dict:
    reason = (f"Y-net is not trained on {dataset} in the {profile} profile (it runs on "
              f"{', '.join(params.ynet_datasets) or 'no dataset'} here)")
    if params.why_subset:
        reason += f": {params.why_subset}"
    return {"dataset": dataset, "model": model, "profile": profile, "trained": False,
            "not_run_reason": reason}


@exit_when_stopped
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=DATASETS)
    parser.add_argument("--model", required=True, choices=MODELS)
    parser.add_argument("--windows", type=Path, required=True,
                        help="short_term_windows output folder (tables and ETH/UCY scene index)")
    parser.add_argument("--maps", type=Path,
                        help="Y-net's scene maps: data/semantic_maps (sdd) or <windows>/ethucy_semantic")
    parser.add_argument("--sdd", type=Path, help="fetched SDD root (Y-net on sdd: scene sizes)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    args = parser.parse_args(argv)
    params = read_params()
    profile = params["profile"]
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    runtime = load_section(RuntimeParams, "runtime", params)
    device = select_device(runtime.device)
    print(f"short_term_models: {args.model} on {describe(device)}")
    if args.model == "ynet" and args.dataset not in settings.ynet_datasets:
        write_json(not_run_record(args.dataset, args.model, profile, settings), args.metrics)
        print(f"short_term_models: Y-net not run on {args.dataset} in the {profile} profile")
        return
    if args.model == "ynet" and (args.maps is None or (args.dataset == "sdd" and args.sdd is None)):
        parser.error("Y-net needs --maps (and --sdd on sdd)")

    ethucy_scenes = None
    if args.dataset != "sdd":
        ethucy_scenes = load_ethucy_scenes(args.windows / ETHUCY_SCENES)
    table = pd.read_parquet(table_path(args.windows, args.dataset))
    bench = load_benchmark(table, args.dataset, windows.n_past, windows.n_future, ethucy_scenes)
    ks = settings.ks(args.dataset)

    if args.model == "ynet":
        maps = load_semantic_maps(args.maps)
        if ethucy_scenes is None:
            sizes = image_sizes(args.sdd, set(bench.train.scene_id) | set(bench.val.scene_id)
                                | set(bench.test.scene_id))
        else:
            sizes = {name: info.image_hw for name, info in ethucy_scenes.items()}
        classes = {m.shape[0] for m in maps.values()}
        if len(classes) != 1:
            raise ValueError(f"{args.maps}: maps of different channel counts {sorted(classes)}")
        model_settings = ynet_settings(load_profile(YnetSettings, "ynet", params), settings,
                                       args.dataset, windows.n_future, classes.pop())
        with Preemption(runtime.max_minutes) as preemption:
            facts, results = run_ynet(bench, maps, sizes, model_settings, windows.n_past,
                                      args.checkpoint_dir, settings, ks, device, preemption)
    else:
        seeds = load_section(TrainBaselineParams, "train_baseline", params)
        torch.set_num_threads(seeds.threads)
        config = replace(model_config(args.model, params),
                         epochs=settings.epochs[args.model][benchmark_of(args.dataset)])
        with Preemption(runtime.max_minutes) as preemption:
            facts, results = run_baseline(args.model, bench, config, args.checkpoint_dir,
                                          seeds.seed, settings, ks, device, preemption)
    record = {"dataset": args.dataset, "model": args.model, "profile": profile, "trained": True,
              "unit": bench.unit, "n_windows": len(bench.test), "rounds": settings.rounds, "ks": ks,
              **{f"k{k}": result for k, result in results.items()},
              "train_seconds": facts["train_seconds"], "eval_seconds": facts["eval_seconds"],
              "train": facts}
    write_json(record, args.metrics)
    main_k = results[ks[0]]
    print(f"short_term_models {args.dataset} {args.model}: K = {ks[0]} ADE "
          f"{main_k['ade']['mean']:.3f} FDE {main_k['fde']['mean']:.3f} {bench.unit} over "
          f"{len(bench.test)} test windows")


if __name__ == "__main__":
    main()
