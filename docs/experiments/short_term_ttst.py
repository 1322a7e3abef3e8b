"""Which TTST settings suit a trained short-term Y-net, on its validation windows?

Not a test: prints numbers. The authors' short-term TTST (temperature 1.0, relative threshold
0.01) was tuned for their fully trained model; a `cpu` model trained on 1/200 of the samples has
other heatmaps. On a fixed seeded sample of the benchmark's *validation* windows (never the test
set; 0 = all of them) it samples K goals for every temperature x threshold of the grid, all in one
pass (each batch is encoded once; every setting draws with the same seed, as scoring would), and
prints best-of-K ADE / FDE as scoring computes them (FDE of the sampled goals) in the benchmark's
unit (original pixels; metres for ETH/UCY) beside the profile's own setting, averaged over
`--rounds` sampling seeds. A setting is worth adopting only if it wins on validation for
more than one training seed. Written up in docs/profiles.md (the TTST settings).

    python -m docs.experiments.short_term_ttst --dataset sdd --windows-sample 0 \
        --temperatures 0.5 1 2 --thresholds 0.001 0.01 0.05
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import time

import numpy as np

from bench import short_term_validation
from pipeline.benchmarks.ethucy import to_metres
from pipeline.benchmarks.registry import short_term
from pipeline.harness.metrics import window_errors
from pipeline.runners.short_term import ynet_options
from pipeline.runners.ynet_scoring import Sampling, predict_samplings


def ttst_grid(temperatures: list[float], thresholds: list[float],
              profile: tuple[float, float]) -> list[tuple[float, float]]:
    """Every (temperature, threshold) of the grid, the profile's own first, each once."""
    grid = [profile] + list(itertools.product(temperatures, thresholds))
    return list(dict.fromkeys(grid))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    short_term_validation.add_arguments(parser)
    parser.add_argument("--k", type=int, default=20)
    parser.add_argument("--temperatures", type=float, nargs="+", default=[0.5, 1.0, 2.0])
    parser.add_argument("--thresholds", type=float, nargs="+", default=[0.01])
    parser.add_argument("--rounds", type=int, default=1,
                        help="sampling seeds per setting (seed, seed + 1, ...), errors averaged")
    args = parser.parse_args()
    trained = short_term_validation.load_from_arguments(args, "short_term_ttst")
    stage, val, settings = trained.stage, trained.val, trained.settings
    benchmark = short_term(args.dataset)
    grid = ttst_grid(args.temperatures, args.thresholds,
                     (stage.temperature, benchmark.rel_threshold(stage)))
    seeds = [stage.seed + r for r in range(args.rounds)]
    samplings = [Sampling(ynet_options(dataclasses.replace(
        stage, temperature=t, rel_threshold={**stage.rel_threshold, benchmark.settings_key: r}),
        benchmark, args.k), seed)
        for t, r in grid for seed in seeds]  # scoring's options, the TTST pair replaced
    began = time.perf_counter()
    sampled, _ = predict_samplings(trained.model, trained.scenes, settings, samplings,
                                   stage.eval_params(), len(val), f"Y-net K_e={args.k}",
                                   settings.crop, settings.crop_lead_steps)
    seconds = time.perf_counter() - began
    unit = benchmark.unit

    def in_unit(points: np.ndarray) -> np.ndarray:  # (N, ..., 2) original pixels -> unit
        return to_metres(points, val.scene_id, trained.scenes_info) if unit == "m" else points

    future = in_unit(val.future)
    print(f"{args.dataset}: {len(val)} val windows, K = {args.k}, {len(grid)} TTST settings x "
          f"{len(seeds)} sampling seeds from {stage.seed} in {seconds:.0f} s; best of K ADE / FDE "
          f"({unit}; FDE of the sampled goals, as scored), mean over the seeds")
    for number, (temperature, threshold) in enumerate(grid):
        drawn = sampled[number * len(seeds):(number + 1) * len(seeds)]
        errors = [window_errors(in_unit(d.paths), future, in_unit(d.goals)) for d in drawn]
        ade = np.mean([e.ade.mean() for e in errors])
        fde = np.mean([e.fde.mean() for e in errors])
        mark = "  (profile)" if number == 0 else ""
        print(f"  T = {temperature:<5g} threshold {threshold:<7g} {ade:7.3f} / {fde:7.3f}{mark}")

if __name__ == "__main__":
    main()
