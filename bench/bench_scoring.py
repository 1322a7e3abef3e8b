"""Seconds per metric of `pipeline.harness.scoring` on synthetic predictions the size of the
benchmarks, to check that scoring every stored prediction stays well under a minute on 2 cores.

Two cases:
- long-term SDD: 2,000 windows x K = 20 x 30 steps, pixels, 17 scenes of 1,900 x 1,400 px,
  windows cut every 35 steps from tracks walking at ~20 px/step (so some share frames);
- ETH/UCY univ: 24,334 windows x K = 20 x 12 steps, metres, 2 scenes of ~425 agents on ~48-step
  tracks (~40 agents per frame), windows cut at every step as the short-term benchmark does, so
  every frame holds ~450 future rows and collisions see ~10^8 candidate pairs.
Predictions are the truth plus noise growing with the step; masks are random blocks of classes.
The machine is usually shared: times are an upper bound; the load average is printed with them.

    OMP_NUM_THREADS=1 python -m bench.bench_scoring [--repeats 3] [--smoke]

`--smoke`: two scenes of a few agents per case, one run (seconds: the code path, not a measurement).
"""

from __future__ import annotations

import os
import statistics
import time
from dataclasses import dataclass

import numpy as np
from scipy.stats import gaussian_kde

from bench import common
from pipeline.benchmarks.base import class_values
from pipeline.harness import scoring

SMOKE = {"scenes": 2, "agents": 6, "max_windows": 40}  # what --smoke changes in each case


@dataclass(frozen=True)
class Case:
    """A synthetic test set: ground truth, K samples per window, and what scoring needs besides."""

    name: str
    pred: np.ndarray  # (N, K, T, 2)
    truth: np.ndarray  # (N, T, 2)
    scene: np.ndarray  # (N,) int
    agent: np.ndarray  # (N,) int, unique within a scene
    frames: np.ndarray  # (N, T) int
    masks: list[np.ndarray]  # per scene (H, W) class values
    to_pixels: float  # original image pixels per unit
    miss: float  # miss threshold, in the unit
    collide: float  # collision threshold, in the unit


def synthetic_case(name: str, *, scenes: int, agents: int, track_steps: int, frames_per_scene: int,
                   n_past: int, n_future: int, stride: int, speed: float, extent: float, k: int,
                   noise: float, max_windows: int, seed: int, to_pixels: float, miss: float,
                   collide: float) -> Case:
    """Agents entering at random frames on slowly turning walks; windows of n_past + n_future steps
    cut every `stride` steps of each track; predictions = future truth + N(0, (noise * step)^2)."""
    rng = np.random.default_rng(seed)
    truth, frames, scene_of, agent_of = [], [], [], []
    length = n_past + n_future
    for s in range(scenes):
        for a in range(agents):
            steps = max(length, int(rng.normal(track_steps, track_steps / 4)))
            heading = rng.uniform(0, 2 * np.pi) + np.cumsum(rng.normal(0, 0.1, steps))
            walk = np.cumsum(speed * np.stack([np.cos(heading), np.sin(heading)], -1), axis=0)
            xy = rng.uniform(0, extent, 2) + walk - walk[0]  # (steps, 2)
            start = rng.integers(0, max(1, frames_per_scene - steps))
            for w in range(0, steps - length + 1, stride):
                truth.append(xy[w + n_past:w + length])
                frames.append(start + np.arange(w + n_past, w + length))
                scene_of.append(s)
                agent_of.append(a)
    pick = np.sort(rng.permutation(len(truth))[:max_windows])
    truth = np.stack(truth)[pick]  # (N, T, 2)
    grow = noise * np.arange(1, n_future + 1)[None, None, :, None]  # (1, 1, T, 1)
    pred = truth[:, None] + rng.normal(size=(len(truth), k, n_future, 2)) * grow  # (N, K, T, 2)
    blocks = [rng.integers(1, 6, (14, 19)) for _ in range(scenes)]
    masks = [np.kron(b, np.ones((100, 100), dtype=np.int64)) for b in blocks]  # (1400, 1900)
    return Case(name, pred, truth, np.array(scene_of)[pick], np.array(agent_of)[pick],
                np.stack(frames)[pick], masks, to_pixels, miss, collide)


def cases(smoke: bool = False) -> list[Case]:
    """The two sizes (`smoke`: a few agents each); thresholds: miss 60 px / 2 m, collision 10 px /
    0.2 m."""
    small = SMOKE if smoke else {}
    long_term = synthetic_case("long-term SDD", **{
        "scenes": 17, "agents": 120, "track_steps": 80, "frames_per_scene": 600, "n_past": 5,
        "n_future": 30, "stride": 35, "speed": 20.0, "extent": 1500.0, "k": 20, "noise": 4.0,
        "max_windows": 2000, "seed": 0, "to_pixels": 1.0, "miss": 60.0, "collide": 10.0, **small})
    univ = synthetic_case("ETH/UCY univ", **{
        "scenes": 2, "agents": 425, "track_steps": 48, "frames_per_scene": 500, "n_past": 8,
        "n_future": 12, "stride": 1, "speed": 0.5, "extent": 15.0, "k": 20, "noise": 0.08,
        "max_windows": 24_334, "seed": 1, "to_pixels": 50.0, "miss": 2.0, "collide": 0.2, **small})
    return [long_term, univ]


def timed(fn, repeats: int) -> tuple[float, object]:
    """Median seconds of `repeats` calls, and the last result."""
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def scipy_kde_seconds(case: Case, steps: int = 1000) -> float:
    """What `kde_nll` would take as Trajectron++ computes it (a scipy.stats.gaussian_kde per window
    and step), extrapolated from the first `steps` of them."""
    n, _, t, _ = case.pred.shape
    cells = [(i, j) for i in range(n) for j in range(t)][:steps]
    start = time.perf_counter()
    for i, j in cells:
        gaussian_kde(case.pred[i, :, j].T).logpdf(case.truth[i, j])
    return (time.perf_counter() - start) / len(cells) * n * t


def main() -> None:
    parser = common.parser(__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    if args.smoke:
        args.repeats = 1
    forbidden = class_values()
    print(f"load average {os.getloadavg()[0]:.2f}; median of {args.repeats} runs, seconds")
    kde_steps = 20 if args.smoke else 1000
    for case in cases(args.smoke):
        n, k, t, _ = case.pred.shape
        print(f"\n{case.name}: {n} windows x K {k} x {t} steps, {len(case.masks)} scenes")
        pixels = case.pred * case.to_pixels
        metrics = {
            "min_ade_fde": lambda: scoring.min_ade_fde(case.pred, case.truth),
            "best_endpoint_ade": lambda: scoring.best_endpoint_ade(case.pred, case.truth),
            "miss": lambda: scoring.miss(case.pred, case.truth, case.miss),
            "kde_nll": lambda: scoring.kde_nll(case.pred, case.truth),
            "scene_compliance (pred + truth)": lambda: [
                scoring.forbidden_share(scoring.scene_compliance(xy, case.scene, case.masks,
                                                                 forbidden))
                for xy in (pixels, case.truth * case.to_pixels)],
            "collisions": lambda: scoring.collisions(case.pred, case.truth, case.scene, case.frames,
                                                     case.collide, agents=case.agent),
        }
        total = 0.0
        results = {}
        for name, fn in metrics.items():
            seconds, results[name] = timed(fn, args.repeats)
            total += seconds
            print(f"  {name:<34}{seconds:8.3f}")
        print(f"  {'(kde_nll, one scipy KDE per step)':<34}{scipy_kde_seconds(case, kde_steps):8.3f}"
              f"  extrapolated from {kde_steps:,} steps")
        per_window, _ = scoring.trajectory_scores(case.pred, case.truth, case.miss)
        seconds, _ = timed(lambda: scoring.aggregate(per_window, case.scene), args.repeats)
        total += seconds
        print(f"  {'aggregate (' + str(len(per_window)) + ' metrics)':<34}{seconds:8.3f}")
        print(f"  {'total':<34}{total:8.3f}")
        hits = results["collisions"]
        print(f"  (co-present windows {hits.copresent.mean():.2f}, colliding samples "
              f"{hits.pred_share.mean():.4f}, colliding truths {hits.truth.mean():.4f})")


if __name__ == "__main__":
    main()
