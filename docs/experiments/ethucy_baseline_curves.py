"""Validation curves of S-GAN and PECNet on ETH/UCY folds, trained in metres with the params'
`short_term_baselines` overrides, for choosing the `cpu` epochs (validation windows only; the test
split is never read).

    python -m docs.experiments.ethucy_baseline_curves --model pecnet --epochs 30 \
        --folds eth hotel univ zara1 zara2 --out /tmp/curves --threads 1

Trains each fold into `<out>/<fold>_<model>` (resumable: rerun with more epochs to extend) and
prints, per epoch, the mean validation min-of-K ADE (m) on the stage's seeded sample of
`short_term_models.<profile>.val_windows` windows, and the seconds per epoch; writes
`<out>/<model>_curves.json`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from pipeline.benchmarks.registry import short_term
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.runners.baselines.common import fit_result_from
from pipeline.runners.short_term import train_baseline
from pipeline.runners.short_term_baselines import baseline_config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, choices=["sgan", "pecnet"])
    parser.add_argument("--epochs", type=int, required=True)
    parser.add_argument("--folds", nargs="+", default=["eth", "hotel", "univ", "zara1", "zara2"])
    parser.add_argument("--windows", type=Path, default=Path("data/short_term"))
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                        help="extra config changes for a trial, e.g. batch_size=256")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    params = read_params()
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    seeds = load_section(TrainBaselineParams, "train_baseline", params)
    curves = {}
    for fold in args.folds:
        bench = short_term(fold).load_in_unit(args.windows, windows.n_past, windows.n_future)
        config = baseline_config(args.model, fold, params, args.epochs)
        for item in args.set:
            key, value = item.split("=", 1)
            config = type(config)(**{**config.__dict__, key: type(getattr(config, key))(value)})
        folder = args.out / f"{fold}_{args.model}"
        facts = train_baseline(args.model, bench, config, folder, seeds.seed,
                               settings.val_windows, settings.seed)
        history = fit_result_from(folder).history
        curve = [round(entry["val_ade"], 4) for entry in history]
        curves[fold] = {"val_ade": curve, "seconds_per_epoch": facts["train_seconds"] / len(curve),
                        "train_windows": facts["train_windows"], "config": {
                            k: v for k, v in config.__dict__.items() if not isinstance(v, list)}}
        print(f"{fold} {args.model}: {len(curve)} epochs, "
              f"{facts['train_seconds'] / len(curve):.1f} s/epoch, best {min(curve):.4f} m at "
              f"epoch {curve.index(min(curve))}; curve {curve}", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"{args.model}_curves.json").write_text(json.dumps(curves, indent=1))


if __name__ == "__main__":
    main()
