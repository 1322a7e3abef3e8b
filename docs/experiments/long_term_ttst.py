"""Which TTST settings suit the trained long-term Y-net, on its validation windows?

Not a test: prints numbers. The authors' long-term TTST (temperature 1.8, relative threshold
0.002, `ttst` in params.yaml) was tuned for their fully trained model; the `cpu` model, trained on
about 1/100 of their samples, has other goal heatmaps. The trained model (`data/ynet/model.pt`,
stage train_ynet) scores the release's *validation* windows (never the test set) at the main
setting (K_e x K_a from `eval.cpu`, TTST and CWS, `cws` from params.yaml) for every temperature x
threshold of the grid, the params' own first, all in one pass (each batch is encoded once; every
setting draws with the same seeds, as scoring would), and prints ADE / FDE (px) as scoring
computes them, averaged over `--rounds` sampling seeds, with the spread between the rounds: a
setting's gain means something only where it is larger than that.
Written up in docs/experiments/cpu-profile-against-the-paper.md.

    python -m docs.experiments.long_term_ttst --temperatures 1 1.4 1.8 2.4 --thresholds 0.002 \
        --rounds 3
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from bench.bench_ynet import keep_freed_memory
from docs.experiments import long_term_validation
from docs.experiments.short_term_ttst import ttst_grid
from pipeline.config.ttst import TtstParams
from pipeline.harness.metrics import window_errors
from pipeline.runners.ynet_scoring import Sampling, predict_samplings, sampling_options


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    long_term_validation.add_arguments(parser)
    parser.add_argument("--temperatures", type=float, nargs="+", default=[1.0, 1.8, 3.0])
    parser.add_argument("--thresholds", type=float, nargs="+", default=[0.002])
    parser.add_argument("--rounds", type=int, default=2,
                        help="sampling seeds per setting (seed, seed + 1, ...), errors averaged")
    args = parser.parse_args()
    keep_freed_memory()

    trained = long_term_validation.load(args)
    eval_params, ttst, val = trained.eval_params, trained.ttst, trained.val
    grid = ttst_grid(args.temperatures, args.thresholds, (ttst.temperature, ttst.rel_threshold))
    seeds = [eval_params.seed + r for r in range(args.rounds)]
    samplings = [Sampling(sampling_options(eval_params.k_e, eval_params.k_a,
                                           TtstParams(temperature=t, rel_threshold=r), trained.cws,
                                           True, True), seed)
                 for t, r in grid for seed in seeds]
    began = time.perf_counter()
    sampled, _ = predict_samplings(trained.model, trained.scenes, trained.settings, samplings,
                                   eval_params, len(val),
                                   f"Y-net K_e={eval_params.k_e} K_a={eval_params.k_a}")
    seconds = time.perf_counter() - began
    print(f"{len(val)} val windows, K_e {eval_params.k_e} x K_a {eval_params.k_a} (TTST + CWS), "
          f"{len(grid)} TTST settings x {len(seeds)} sampling seeds from {eval_params.seed} in "
          f"{seconds:.0f} s, {args.threads} thread(s), model {args.model}; ADE / FDE px, mean over "
          "the seeds (FDE: min - max over them)")
    for number, (temperature, threshold) in enumerate(grid):
        drawn = sampled[number * len(seeds):(number + 1) * len(seeds)]
        errors = [window_errors(d.paths, val.future, d.goals) for d in drawn]
        ade = np.array([e.ade.mean() for e in errors])
        fde = np.array([e.fde.mean() for e in errors])
        mark = "  (params)" if number == 0 else ""
        print(f"  T = {temperature:<5g} threshold {threshold:<7g} {ade.mean():7.2f} / "
              f"{fde.mean():7.2f}  ({fde.min():.2f} - {fde.max():.2f}){mark}")


if __name__ == "__main__":
    main()
