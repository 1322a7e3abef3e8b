"""Test scores of ETH/UCY PECNet checkpoint folders outside the pipeline, under our headline
protocol (per-window independent min-of-K ADE / FDE) and PECNet's own (ADE of the sample with the
best endpoint, min FDE), in metres.

    python -m docs.experiments.ethucy_pecnet_test_scores --checkpoints /tmp/ethucy_pecnet \
        --out /tmp/ethucy_pecnet/test_scores.json
    python -m docs.experiments.ethucy_pecnet_test_scores --stored data/predictions/short_term \
        --out /tmp/ethucy_pecnet/stored_scores.json

`--checkpoints ROOT` scores `ROOT/<fold>_pecnet` as the stage `evaluate_short_term_baseline`
does (`pipeline.runners.short_term.score_baseline`: the `raw` best epoch, the metre windows of
`ShortTermBenchmark.load_in_unit`, `short_term_models.<profile>`'s `k_ethucy`, `rounds` and `seed`,
`train_baseline.threads`); `--stored ROOT` re-scores the stage's stored predictions
`ROOT/<fold>/pecnet.parquet` instead (no model runs), which checks this script against the
stage's own numbers. Nothing is chosen here: run it once, on checkpoints chosen on validation.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from pipeline.benchmarks.registry import short_term
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.runners.baselines.common import BEST, load_checkpoint
from pipeline.harness.metrics import window_errors
from pipeline.harness.predictions import PredictionRounds, read_prediction_rounds
from pipeline.harness.scoring import best_endpoint_ade
from pipeline.runners.short_term import score_baseline

FOLDS = ("eth", "hotel", "univ", "zara1", "zara2")


def protocols(rounds: list[np.ndarray], truth: np.ndarray) -> dict[str, float]:
    """Means over windows, then over rounds, of each round's paths (N, K, n_f, 2) against truth
    (N, n_f, 2): 'ade' / 'fde' (independent minima), 'ade_best_endpoint' (PECNet's ADE)."""
    ade, fde, own = [], [], []
    for paths in rounds:
        errors = window_errors(paths, truth)
        ade.append(errors.ade.mean())
        fde.append(errors.fde.mean())
        own.append(best_endpoint_ade(paths, truth).mean())
    return {"ade": float(np.mean(ade)), "fde": float(np.mean(fde)),
            "ade_best_endpoint": float(np.mean(own)), "rounds": len(rounds)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--checkpoints", type=Path, help="folder of <fold>_pecnet checkpoints")
    source.add_argument("--stored", type=Path, help="folder of <fold>/pecnet.parquet predictions")
    parser.add_argument("--folds", nargs="+", default=list(FOLDS))
    parser.add_argument("--windows", type=Path, default=Path("data/short_term"))
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    params = read_params()
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    torch.set_num_threads(load_section(TrainBaselineParams, "train_baseline", params).threads)
    scores = {}
    for fold in args.folds:
        benchmark = short_term(fold)
        bench = benchmark.load_in_unit(args.windows, windows.n_past, windows.n_future)
        k = benchmark.ks(settings)[0]
        if args.checkpoints is not None:
            folder = args.checkpoints / f"{fold}_pecnet"
            kept = PredictionRounds(bench.test.window_id)
            results, seconds = score_baseline("pecnet", bench, folder, [k], settings.rounds,
                                              settings.seed, kept=kept)
            paths = [drawn[0] for drawn in kept.drawn]
            epoch = int(load_checkpoint(folder / BEST)["epoch"])
            fold_scores = {**protocols(paths, bench.truth), "best_epoch": epoch + 1,
                           "eval_seconds": seconds}
            assert abs(fold_scores["ade"] - results[k]["ade"]["mean"]) < 1e-12
        else:
            by_round, _ = read_prediction_rounds(args.stored / fold / "pecnet.parquet")
            for drawn in by_round.values():
                if not np.array_equal(drawn.window_ids, bench.test.window_id):
                    raise ValueError(f"{args.stored / fold}: windows differ from the test split")
            fold_scores = protocols([drawn.samples for drawn in by_round.values()], bench.truth)
        scores[fold] = {"k": k, "n_windows": len(bench.test), **fold_scores}
        ours = f"{fold_scores['ade']:.3f} / {fold_scores['fde']:.3f}"
        own = f"{fold_scores['ade_best_endpoint']:.3f} / {fold_scores['fde']:.3f}"
        print(f"{fold}: K = {k} ours {ours} m, own {own} m", flush=True)
    if len(scores) == len(FOLDS):
        scores["average"] = {key: float(np.mean([scores[f][key] for f in FOLDS]))
                             for key in ("ade", "fde", "ade_best_endpoint")}
        print("average: ours {ade:.3f} / {fde:.3f} m, own {ade_best_endpoint:.3f} / {fde:.3f} m"
              .format(**scores["average"]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(scores, indent=1))


if __name__ == "__main__":
    main()
