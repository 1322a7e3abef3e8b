"""Stage `train_short_term_baseline@<dataset>-<model>`: S-GAN or PECNet trained on one short-term
benchmark (paper Tables 1-2).

The model's `sgan` / `pecnet` settings with the epochs `short_term_models.<profile>.epochs` gives
this benchmark and its overrides `short_term_baselines.<profile>.<model>.<benchmark>`, trained in
the benchmark's unit (SDD pixels, ETH/UCY metres: `pipeline.runners.short_term_baselines`); the
epoch is selected on a seeded sample of `val_windows` validation windows
(`pipeline.runners.short_term`). Writes the checkpoint folder (its `best.pt` holds the model's
config; resumable, and SIGTERM / SIGINT or `runtime.max_minutes` checkpoint mid-epoch and exit
143 / 130 / 75) and the training record. Params: `profile`, `runtime.device`, `runtime.max_minutes`,
`short_term.n_past`, `short_term.n_future`, `train_baseline` (seed, threads), `<model>.<profile>`,
`short_term_models.<profile>`: `epochs.<model>`, `val_windows`, `seed`;
`short_term_baselines.<profile>.<model>.<benchmark>`.

    python -m pipeline.stages.train_short_term_baseline --dataset eth --model pecnet \
        --windows data/short_term --checkpoint-dir checkpoints/short_term/eth_pecnet \
        --metrics metrics/short_term/train/eth_pecnet.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from pipeline.benchmarks.registry import SHORT_TERM, short_term
from pipeline.config.loading import (active_profile, load_profile, load_section, profile_entry,
                                     read_params)
from pipeline.config.runtime import RuntimeParams
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.device import TRAINING, describe, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.model_list import TRAINED_BASELINES
from pipeline.preemption import Preemption, exit_when_stopped
from pipeline.runners.short_term import train_baseline, training_record
from pipeline.runners.baselines import config_class
from pipeline.runners.short_term_baselines import SECTION, BaselineOverrides, baseline_config


@exit_when_stopped
@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=SHORT_TERM)
    parser.add_argument("--model", required=True, choices=TRAINED_BASELINES)
    parser.add_argument("--windows", type=Path, required=True,
                        help="short_term_windows output folder (tables and ETH/UCY scene index)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True, help="training record (JSON)")
    args = parser.parse_args(argv)
    params = read_params()
    profile = active_profile(params)
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    runtime = load_section(RuntimeParams, "runtime", params)
    device = select_device(runtime.device, purpose=TRAINING)
    print(f"train_short_term_baseline: {args.model} on {describe(device)}")

    benchmark = short_term(args.dataset)
    bench = benchmark.load_in_unit(args.windows, windows.n_past, windows.n_future)
    seeds = load_section(TrainBaselineParams, "train_baseline", params)
    torch.set_num_threads(seeds.threads)
    config = baseline_config(args.model, args.dataset,
                             load_profile(config_class(args.model), args.model, params),
                             BaselineOverrides(profile, profile_entry(params, SECTION)),
                             benchmark.epochs(settings, args.model))
    with Preemption(runtime.max_minutes) as preemption:
        facts = train_baseline(args.model, bench, config, args.checkpoint_dir, seeds.seed,
                               settings.val_windows, settings.seed, device, preemption)
    facts["unit"] = bench.unit  # of the windows trained on, and of best_val_ade_px
    write_json(training_record(args.dataset, args.model, profile, facts), args.metrics)


if __name__ == "__main__":
    main()
