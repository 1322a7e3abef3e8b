"""Stage `evaluate_short_term_baseline@<dataset>-<model>`: S-GAN or PECNet scored on one short-term
benchmark (paper Tables 1-2).

Loads the best epoch of `train_short_term_baseline` (its config from the checkpoint) and scores it
on every test window at each K of `k_sdd` / `k_ethucy`, over `rounds` seeded rounds, in the unit it
was trained in (SDD pixels, ETH/UCY metres: `pipeline.runners.short_term_baselines`). Also writes every round of the first K's test predictions
in the benchmark's unit (window ids of the dataset's table in `--windows`;
`pipeline.harness.predictions`). Params: `profile`, `runtime.device`,
`short_term.n_past`, `short_term.n_future`, `train_baseline.threads`,
`short_term_models.<profile>`: `k_sdd` / `k_ethucy`, `rounds`, `seed`.

    python -m pipeline.stages.evaluate_short_term_baseline --dataset eth --model pecnet \
        --windows data/short_term --checkpoint-dir checkpoints/short_term/eth_pecnet \
        --train-metrics metrics/short_term/train/eth_pecnet.json \
        --metrics metrics/short_term/runs/eth_pecnet.json \
        --predictions data/predictions/short_term/eth/pecnet.parquet
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from pipeline.benchmarks.registry import SHORT_TERM, short_term
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.device import SCORING, describe, select_device
from pipeline.harness.predictions import PredictionRounds
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.model_list import TRAINED_BASELINES
from pipeline.runners.short_term import run_record, score_baseline


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=SHORT_TERM)
    parser.add_argument("--model", required=True, choices=TRAINED_BASELINES)
    parser.add_argument("--windows", type=Path, required=True,
                        help="short_term_windows output folder (tables and ETH/UCY scene index)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True,
                        help="of train_short_term_baseline")
    parser.add_argument("--train-metrics", type=Path, required=True,
                        help="of train_short_term_baseline")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--predictions", type=Path, required=True,
                        help="every round of the first K's test predictions (parquet)")
    args = parser.parse_args(argv)
    trained = json.loads(args.train_metrics.read_text())
    params = read_params()
    profile = active_profile(params)
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    device = select_device(load_section(RuntimeParams, "runtime", params).device, purpose=SCORING)
    print(f"evaluate_short_term_baseline: {args.model} on {describe(device)}")

    benchmark = short_term(args.dataset)
    bench = benchmark.load_in_unit(args.windows, windows.n_past, windows.n_future)
    torch.set_num_threads(load_section(TrainBaselineParams, "train_baseline", params).threads)
    ks = benchmark.ks(settings)
    kept = PredictionRounds(bench.test.window_id)
    results, seconds = score_baseline(args.model, bench, args.checkpoint_dir, ks, settings.rounds,
                                      settings.seed, device, kept)
    kept.write(args.predictions, benchmark.prediction_metadata(
        args.windows, args.model, ks, checkpoint_dir=str(args.checkpoint_dir)))
    facts = {**trained["train"], "eval_seconds": seconds}
    write_json(run_record(args.dataset, args.model, profile, bench, settings.rounds, ks, results,
                          facts), args.metrics)
    main_k = results[ks[0]]
    print(f"evaluate_short_term_baseline {args.dataset} {args.model}: K = {ks[0]} ADE "
          f"{main_k['ade']['mean']:.3f} FDE {main_k['fde']['mean']:.3f} {bench.unit} over "
          f"{len(bench.test)} test windows")


if __name__ == "__main__":
    main()
