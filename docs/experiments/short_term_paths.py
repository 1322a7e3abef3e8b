"""Does a trained short-term Y-net's trajectory decoder earn its keep at K = 20?

Not a test: prints numbers. On a fixed seeded sample of the benchmark's *validation* windows (never
the test set; 0 = all of them) it samples K goals as scoring does (TTST with the profile's
temperature and threshold, one seed) and compares, best of K, in original pixels:
- the trajectory decoder's paths towards those goals (what the benchmark scores), and
- straight lines from the last observed position to the same goals, at even steps.
Where the straight lines win, the trajectory decoder loses accuracy that the goals already had. It
also prints the error per future step of the best path (chosen on ADE) of each, and how far each
decoded path ends from the goal it was given.
Written up in docs/profiles.md (where the K = 20 error comes from).

    python -m docs.experiments.short_term_paths --dataset sdd --windows-sample 0
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from bench import short_term_validation
from pipeline.benchmarks.registry import short_term
from pipeline.harness.metrics import step_errors, window_errors
from pipeline.runners.short_term import ynet_options
from pipeline.runners.ynet_scoring import Sampling, predict_samplings


def straight_paths(last_observed: np.ndarray, goals: np.ndarray, n_future: int) -> np.ndarray:
    """(N, 2) last observed positions, (N, K, 2) goals -> (N, K, n_f, 2): even steps to each goal."""
    fractions = np.arange(1, n_future + 1) / n_future  # (n_f,)
    start = last_observed[:, None, None]  # (N, 1, 1, 2)
    return start + (goals[:, :, None] - start) * fractions[None, None, :, None]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    short_term_validation.add_arguments(parser)
    parser.add_argument("--k", type=int, default=20)
    args = parser.parse_args()
    trained = short_term_validation.load_from_arguments(args, "short_term_paths")
    stage, val, settings = trained.stage, trained.val, trained.settings
    options = ynet_options(stage, short_term(args.dataset), args.k)  # as the stage samples
    began = time.perf_counter()
    (sampled,), _ = predict_samplings(
        trained.model, trained.scenes, settings, [Sampling(options, stage.seed)],
        stage.eval_params(), len(val), f"Y-net K_e={args.k}", settings.crop, settings.crop_lead_steps)
    seconds = time.perf_counter() - began
    lines = straight_paths(val.past[:, -1], sampled.goals, val.future.shape[1])
    rows = np.arange(len(val))
    print(f"{args.dataset}: {len(val)} val windows, K = {args.k} (TTST T = {options.temperature}, "
          f"threshold {options.rel_threshold}, seed {stage.seed}), original pixels, {seconds:.0f} s")
    goals_fde = window_errors(sampled.paths, val.future, sampled.goals).fde  # (N,) as scored
    print(f"  goals: FDE (best of K) {goals_fde.mean():6.2f}")
    for name, paths in (("Y-net paths", sampled.paths), ("straight lines", lines)):
        best = window_errors(paths, val.future)  # its best_ade_sample: the best path on ADE
        steps = step_errors(paths, val.future)[rows, best.best_ade_sample]  # (N, n_f)
        print(f"  {name:15s} ADE (best of K) {best.ade.mean():6.2f}  per step of the best: "
              + " ".join(f"{v:5.1f}" for v in steps.mean(0)))
    ends = np.linalg.norm(sampled.paths[:, :, -1] - sampled.goals, axis=-1)
    print(f"  Y-net paths end {ends.mean():.2f} px from the goal they were given (mean over all K)")


if __name__ == "__main__":
    main()
