"""Table 3's PECNet FDE, screened on validation: does the spread of PECNet's endpoints (the
test-time truncation sigma, or the likelihood width it is trained with) explain ours being far
above the Y-net authors' retrain? Validation windows only: the test split is never read.

    # the test-time sigma of a trained folder (nothing trains)
    python -m docs.experiments.long_term_pecnet_screen sigma --folder checkpoints/pecnet_tf30 \
        --horizon 30 --sigmas 0.8 1.0 1.3 1.6 2.0 2.5 --rounds 5 --out /tmp/lt_pecnet/sigma.json
    # the stage's run (`train_baseline@pecnet-<t_f>`) with another likelihood width, from scratch
    python -m docs.experiments.long_term_pecnet_screen train --horizon 30 --kl-weight 0.00025 \
        --out /tmp/lt_pecnet/kl0.00025

`sigma` scores the kept weights (`best.pt`, rule `raw`, as the scoring stage loads them) on the
horizon table's validation windows at K = `pecnet.<profile>.val_k`, each round with the same latent
draws for every sigma (common random numbers: a sigma's effect is not another draw's): mean min-of-K
ADE and FDE per sigma and round.

`train` is the stage's training (`pecnet.<profile>`, `train_baseline.seed`, one thread,
`data/horizon_windows/tf<t_f>.parquet`) with only `kl_weight` (and `--data-scale`, `--epochs` if
given) changed, into a fresh folder `<out>`, and writes `<out>.json` with the validation curve and
the likelihood width sigma_px = sqrt(batch_size * kl_weight) / data_scale
(`pipeline.runners.baselines.pecnet`'s "Loss balance").
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
from pathlib import Path

import numpy as np
import torch

from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.data.window_table import load_windows, select_split
from pipeline.device import CPU
from pipeline.device import generator as seeded_generator
from pipeline.runners.baseline_runs import train
from pipeline.runners.baselines import config_class
from pipeline.runners.baselines.common import fit_result_from
from pipeline.runners.baselines.pecnet import Pecnet
from pipeline.harness.metrics import window_errors
from pipeline.io import write_json


def likelihood_width(config) -> float:
    """sigma_px: the standard deviation, in pixels, of the Gaussian likelihood PECNet's loss amounts
    to (MSE means over a batch beside a KL summed over it)."""
    return math.sqrt(config.batch_size * config.kl_weight) / config.data_scale


def horizon_windows(horizon: int, tables: Path, params: dict):
    """Every split of the horizon table the stage `train_baseline@pecnet-<t_f>` reads."""
    n_past = load_section(WindowParams, "windows", params).n_past
    return load_windows(tables / f"tf{horizon}.parquet", n_past, horizon)


def sigma_screen(folder: Path, horizon: int, sigmas: list[float], rounds: int, tables: Path,
                 params: dict) -> dict:
    """Mean min-of-K val ADE / FDE (px) of `folder`'s kept weights at each test-time sigma."""
    val = select_split(horizon_windows(horizon, tables, params), "val")
    model = Pecnet.load(folder, CPU, selection="raw")
    trained = model.config
    k = trained.val_k
    per_sigma = {}
    for sigma in sigmas:
        model.config = dataclasses.replace(trained, sigma=sigma)
        scores = []
        for round_ in range(rounds):
            pred = model.predict(val, k, seeded_generator(CPU, 1000 + round_))  # (N, K, n_f, 2)
            errors = window_errors(pred, val.future)
            scores.append((float(errors.ade.mean()), float(errors.fde.mean())))
        ade, fde = np.array(scores).T
        per_sigma[str(sigma)] = {"ade": float(ade.mean()), "fde": float(fde.mean()),
                                 "ade_rounds": ade.tolist(), "fde_rounds": fde.tolist()}
        print(f"{folder.name} sigma {sigma}: val ADE {ade.mean():.2f} FDE {fde.mean():.2f} px "
              f"(rounds {ade.min():.2f}-{ade.max():.2f} / {fde.min():.2f}-{fde.max():.2f})",
              flush=True)
    return {"folder": str(folder), "horizon": horizon, "k": k, "rounds": rounds, "n_val": len(val),
            "trained_sigma": trained.sigma, "kl_weight": trained.kl_weight,
            "data_scale": trained.data_scale, "sigma_px": likelihood_width(trained),
            "per_sigma": per_sigma}


def train_width(horizon: int, kl_weight: float, data_scale: float | None, epochs: int | None,
                seed: int | None, out: Path, tables: Path, params: dict) -> dict:
    """The stage's run with only the likelihood width (and epochs, the seed) changed; its
    validation curve. `seed` None: the stage's (`train_baseline.seed`)."""
    if seed is None:
        seed = load_section(TrainBaselineParams, "train_baseline", params).seed
    arrays = horizon_windows(horizon, tables, params)
    changes = {"kl_weight": kl_weight}
    if data_scale is not None:
        changes["data_scale"] = data_scale
    if epochs is not None:
        changes["epochs"] = epochs
    config = dataclasses.replace(load_profile(config_class("pecnet"), "pecnet", params), **changes)
    if out.exists():
        raise FileExistsError(f"{out}: exists; this screen trains from scratch into a fresh folder")
    t0 = time.perf_counter()
    facts = train("pecnet", arrays, config, out, seed, CPU)
    result = fit_result_from(out)
    record = {"horizon": horizon, "seed": seed, "kl_weight": config.kl_weight,
              "data_scale": config.data_scale, "batch_size": config.batch_size,
              "sigma_px": likelihood_width(config), "epochs": facts["epochs"],
              "best_epoch": result.best_epoch, "best_val_ade": result.best_val_ade,
              "val_ade": [e["val_ade"] for e in result.history],
              "train_seconds": result.train_seconds, "wall_seconds": time.perf_counter() - t0}
    print(f"{out.name}: sigma_px {record['sigma_px']:.1f}, "
          f"best val ADE {result.best_val_ade:.2f} px "
          f"at epoch {result.best_epoch} of {facts['epochs']}", flush=True)
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    sigma = commands.add_parser("sigma", help="score a trained folder at several test-time sigmas")
    sigma.add_argument("--folder", type=Path, required=True)
    sigma.add_argument("--sigmas", type=float, nargs="+", required=True)
    sigma.add_argument("--rounds", type=int, default=5)
    width = commands.add_parser("train", help="train the stage's run with another likelihood width")
    width.add_argument("--kl-weight", type=float, required=True)
    width.add_argument("--data-scale", type=float)
    width.add_argument("--epochs", type=int)
    width.add_argument("--seed", type=int, help="training seed (default train_baseline.seed)")
    for command in (sigma, width):
        command.add_argument("--horizon", type=int, default=30)
        command.add_argument("--tables", type=Path, default=Path("data/horizon_windows"))
        command.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    params = read_params()
    torch.set_num_threads(1)
    if args.command == "sigma":
        record = sigma_screen(args.folder, args.horizon, args.sigmas, args.rounds, args.tables,
                              params)
        write_json(record, args.out)
    else:
        record = train_width(args.horizon, args.kl_weight, args.data_scale, args.epochs, args.seed,
                             args.out, args.tables, params)
        write_json(record, args.out.parent / f"{args.out.name}.json")  # "kl0.004": no suffix cut


if __name__ == "__main__":
    main()
