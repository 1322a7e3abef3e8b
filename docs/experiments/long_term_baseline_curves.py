"""Validation curves of the long-term (SDD, 1 FPS) S-GAN and PECNet past the `cpu` profile's epochs,
for choosing `sgan.cpu.epochs` / `pecnet.cpu.epochs` (validation windows only; the test split is
never read).

    python -m docs.experiments.long_term_baseline_curves --model pecnet --horizons 5 30 60 \
        --epochs 80 --out /tmp/lt_curves

Each run is the stage's own (`train_baseline@<model>-<t_f>`: `<model>.<profile>` with only `epochs`
raised, `train_baseline.seed` or --seed, `train_baseline.threads`, `windows.n_past`,
`data/horizon_windows/tf<t_f>.parquet`), trained into `<out>/<model>_tf<t_f>[_seed<S>]`. A fresh
folder starts from a copy of the stage's own checkpoint folder (`checkpoints/<model>_tf<t_f>`, or
`checkpoints/seeds/<model>_tf<t_f>_seed<S>` for an extra seed; --fresh: from scratch): its `last.pt`
continues exactly as a longer run would have (`pipeline.checkpoints`: only `epochs` may grow, no
learning-rate schedule depends on it), so the first epochs are the stage's very ones. The tracked
folders are only read.

The run is extended one epoch per call of the stage's training function, so that after every
epoch the script scores the epoch's weights (`last.pt`) on the validation windows exactly as the
training loop does (val_k samples from a generator seeded seed + 1): the min-of-K ADE (checked
against the loop's own) and the min-of-K FDE, which the loop does not record. Epochs already in the
copied checkpoint have only their ADE (their weights are gone), except the kept one (`best.pt`).
Resumable: rerun with more epochs to extend. Writes `<out>/<model>_tf<t_f>[_seed<S>].json` after
every epoch and prints a summary per run.

    python -m docs.experiments.long_term_baseline_curves --out /tmp/lt_curves --summary 40 60 80

compares epoch budgets over every run in `<out>` (`<out>/summary.json`): each budget's best epoch and
val ADE, and, since the lowest of more noisy epochs is lower by luck alone (15-23 validation windows
at 40-60 s), the split-half held-out ADE of the epoch it keeps (`pipeline.studies.epoch_selection`).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import time
from pathlib import Path

import numpy as np
import torch

from pipeline import checkpoints
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.data.window_table import load_windows, select_split
from pipeline.device import generator as seeded_generator
from pipeline.device import TRAINING, select_device
from pipeline.harness import epoch_selection
from pipeline.runners import baselines
from pipeline.runners.baselines import training
from pipeline.runners.baseline_runs import train
from pipeline.runners.baselines import config_class
from pipeline.runners.baselines.common import fit_result_from, load_checkpoint
from pipeline.harness.metrics import window_errors
from pipeline.io import write_json
from pipeline.studies.epoch_selection import split_half_study


def stage_folder(checkpoints_root: Path, model: str, horizon: int, seed: int, main_seed: int) -> Path:
    """The checkpoint folder the stage (`train_baseline` or `train_baseline_seed`) trained."""
    if seed == main_seed:
        return checkpoints_root / f"{model}_tf{horizon}"
    return checkpoints_root / "seeds" / f"{model}_tf{horizon}_seed{seed}"


def val_scores(model: str, weights: dict, config, val, n_past: int, n_future: int, seed: int,
               device: torch.device) -> tuple[float, float]:
    """Mean min-of-val_k ADE and FDE (px) of `weights` (module name -> state_dict) on `val`, drawn
    as the training loop's `validate` draws them."""
    predictor = baselines.get(model)(config, n_past, n_future, device)
    for name, state in weights.items():
        module = getattr(predictor, name)
        module.load_state_dict(state)
        module.eval()
    pred = predictor.predict(val, config.val_k, seeded_generator(device, seed + 1))  # (N, K, n_f, 2)
    errors = window_errors(pred, val.future)
    return float(errors.ade.mean()), float(errors.fde.mean())


def run_identity(config, seed: int, arrays) -> dict:
    """What `training.run_training` requires a `last.pt` to match before it continues it (the config
    up to `epochs`, the data and seed, the selection rules): as that function builds it."""
    return {**{k: v for k, v in dataclasses.asdict(config).items() if k not in training.RESUMABLE_CHANGES},
            "data_fingerprint": checkpoints.run_digest(str(seed), select_split(arrays, "train"),
                                                       select_split(arrays, "val")),
            "selection_rules": dict(epoch_selection.RULES)}


def extend(model: str, horizon: int, epochs: int, seed: int, out: Path, params: dict,
           tables: Path, checkpoints_root: Path, fresh: bool) -> dict:
    """Train (model, horizon, seed) to `epochs`, one epoch per call; returns the curve record."""
    settings = load_section(TrainBaselineParams, "train_baseline", params)
    n_past = load_section(WindowParams, "windows", params).n_past
    device = select_device(load_section(RuntimeParams, "runtime", params).device, purpose=TRAINING)
    torch.set_num_threads(settings.threads)
    name = f"{model}_tf{horizon}" + ("" if seed == settings.seed else f"_seed{seed}")
    folder, record_path = out / name, out / f"{name}.json"
    source = stage_folder(checkpoints_root, model, horizon, seed, settings.seed)
    arrays = load_windows(tables / f"tf{horizon}.parquet", n_past, horizon)
    val = select_split(arrays, "val")
    base_config = load_profile(config_class(model), model, params)
    record = json.loads(record_path.read_text()) if record_path.exists() else None
    if record is None:
        folder.mkdir(parents=True, exist_ok=True)
        start_from = "scratch"
        if not fresh:
            if not (source / checkpoints.LAST).exists():
                raise FileNotFoundError(f"{source / checkpoints.LAST}: absent; `dvc checkout {source}`"
                                        " or pass --fresh")
            for file in source.glob("*.pt"):
                shutil.copyfile(file, folder / file.name)  # copies: the tracked folder is only read
            start_from = str(source)
            why = checkpoints.stale_reason(checkpoints.load(folder / checkpoints.LAST),
                                           run_identity(base_config, seed, arrays), 10**6)
            if why is not None:  # the loop would start afresh: say so rather than mislabel the curve
                raise RuntimeError(f"{source / checkpoints.LAST} {why}: it cannot be extended; "
                                   "pass --fresh to train from scratch")
        copied = fit_result_from(folder) if not fresh else None
        record = {"model": model, "horizon": horizon, "seed": seed, "profile": params["profile"],
                  "threads": settings.threads, "start_from": start_from,
                  "stage_epochs": base_config.epochs, "n_train": int((arrays.split == "train").sum()),
                  "n_val": len(val), "val_k": base_config.val_k,
                  "config": {k: v for k, v in dataclasses.asdict(base_config).items() if k != "epochs"},
                  "curve": []}
        if copied is not None:
            kept = load_checkpoint(folder / checkpoints.BEST)
            ade, fde = val_scores(model, kept["modules"], base_config, val, n_past, horizon, seed, device)
            if abs(ade - copied.best_val_ade) > 1e-6 * max(1.0, copied.best_val_ade):
                raise RuntimeError(f"{source}/best.pt: val ADE {ade} here, {copied.best_val_ade} recorded")
            record["stage_kept"] = {"epoch": copied.best_epoch, "val_ade": ade, "val_fde": fde}
            record["curve"] = [{"epoch": e["epoch"], "val_ade": e["val_ade"], "val_fde": None,
                                "seconds": None} for e in copied.history]
            record["stage_train_seconds"] = copied.train_seconds
        record["train_seconds"] = copied.train_seconds if copied is not None else 0.0
    done = len(record["curve"])
    for target in range(done + 1, epochs + 1):
        config = dataclasses.replace(base_config, epochs=target)
        t0 = time.perf_counter()
        facts = train(model, arrays, config, folder, seed, device)
        seconds = time.perf_counter() - t0
        if facts["epochs"] != target:  # a stale copy would have started afresh
            raise RuntimeError(f"{folder}: {facts['epochs']} epochs after asking for {target}")
        history = fit_result_from(folder).history
        before = [e["val_ade"] for e in record["curve"]]
        if [e["val_ade"] for e in history[:len(before)]] != before:
            raise RuntimeError(f"{folder}: the first {len(before)} epochs' val ADE changed")
        last = checkpoints.read(folder / checkpoints.LAST).state["modules"]
        ade, fde = val_scores(model, last, base_config, val, n_past, horizon, seed, device)
        if abs(ade - history[-1]["val_ade"]) > 1e-6 * max(1.0, ade):
            raise RuntimeError(f"{folder}: epoch {target - 1} val ADE {ade} here, "
                               f"{history[-1]['val_ade']} in training")
        total = fit_result_from(folder).train_seconds  # the loop's own clock: training and val
        epoch_seconds, record["train_seconds"] = total - record["train_seconds"], total
        record["curve"].append({"epoch": target - 1, "val_ade": ade, "val_fde": fde,
                                "seconds": epoch_seconds, "call_seconds": seconds})
        write_json(record, record_path)
        print(f"{name} epoch {target}: val ADE {ade:.3f} FDE {fde:.3f} px, "
              f"{epoch_seconds:.2f} s training", flush=True)
    summarise(name, record)
    return record


def summarise(name: str, record: dict) -> None:
    """Print best epoch and val ADE within the stage's epochs and within all trained."""
    curve = np.array([e["val_ade"] for e in record["curve"]])
    cut = record["stage_epochs"]
    best_in = int(curve[:cut].argmin())
    best_all = int(curve.argmin())
    gain = (curve[best_all] - curve[best_in]) / curve[best_in]
    print(f"{name}: best within {cut} epochs {curve[best_in]:.3f} px at epoch {best_in + 1}; within "
          f"{len(curve)} {curve[best_all]:.3f} px at epoch {best_all + 1} ({100 * gain:+.1f} %; epochs "
          "counted from 1); "
          f"every 10: {[round(float(v), 2) for v in curve[9::10]]}", flush=True)


def budget_comparison(window_curves: np.ndarray, budgets: tuple[int, ...], n_splits: int = 200,
                      seed: int = 0) -> dict:
    """Best epoch and val ADE within each epoch budget, and the split-half held-out ADE of the epoch
    each budget keeps (`split_half_study`, rule `raw`, the same halvings for every
    budget): the lowest of more noisy epochs is lower by luck alone, the held-out half is not.

    window_curves: (E, N) validation ADE per epoch and window; budgets <= E."""
    curve = window_curves.mean(axis=1)  # (E,)
    out = {}
    for budget in budgets:
        study = split_half_study(window_curves[:budget], n_splits, seed, ("raw",))
        best = int(curve[:budget].argmin())
        out[str(budget)] = {"best_epoch": best, "best_val_ade": float(curve[best]),
                            "held_out_ade": study["held_out"]["raw"], "oracle_ade": study["oracle"]}
    return out


def summary(out: Path, budgets: tuple[int, ...]) -> dict:
    """One row per run folder in `out`: the curve every 5 epochs, each budget's best epoch, val ADE
    (and FDE where the weights were scored) and held-out ADE, seconds per epoch."""
    rows = {}
    records = {path: json.loads(path.read_text()) for path in out.glob("*_tf*.json")}
    for record_path, record in sorted(records.items(), key=lambda item: (
            item[1]["model"], item[1]["horizon"], item[1]["seed"])):
        history = fit_result_from(out / record_path.stem).history
        window_curves = np.array([e["val_window_ade"] for e in history], dtype=float)  # (E, N)
        usable = tuple(b for b in budgets if b <= len(history))
        compared = budget_comparison(window_curves, usable)
        fde = {e["epoch"]: e["val_fde"] for e in record["curve"]}
        fde[record["stage_kept"]["epoch"]] = record["stage_kept"]["val_fde"]
        for row in compared.values():
            row["best_val_fde"] = fde.get(row["best_epoch"])
        extended = [e["seconds"] for e in record["curve"] if e["seconds"] is not None]
        rows[record_path.stem] = {
            "model": record["model"], "horizon": record["horizon"], "seed": record["seed"],
            "n_val": record["n_val"], "epochs": len(history),
            "val_ade_every_5": {e + 1: round(float(window_curves[e].mean()), 2)
                                for e in range(4, len(history), 5)},
            "budgets": compared,
            "stage_seconds_per_epoch": record["stage_train_seconds"] / record["stage_epochs"],
            "extension_seconds_per_epoch": float(np.mean(extended)) if extended else None}
    write_json(rows, out / "summary.json")
    return rows


def markdown_rows(rows: dict, short: int, long: int) -> list[str]:
    """The note's table: per run the val ADE every 10 epochs, the best epoch and val ADE (FDE) within
    `short` and `long` epochs, their relative change, and the same for the held-out half."""
    lines = [f"| run | val ADE every 10 epochs (px) | best within {short}: epoch, ADE / FDE | within {long} "
             f"| change | held-out ADE {short} -> {long} | change |", "|---" * 7 + "|"]
    for name, row in rows.items():
        budgets = row["budgets"]
        if str(long) not in budgets:
            continue
        a, b = budgets[str(short)], budgets[str(long)]
        every_10 = " ".join(f"{v:.1f}" for e, v in row["val_ade_every_5"].items() if int(e) % 10 == 0)

        def kept(x: dict) -> str:
            fde = "-" if x["best_val_fde"] is None else f"{x['best_val_fde']:.1f}"
            return f"{x['best_epoch'] + 1}, {x['best_val_ade']:.1f} / {fde}"
        lines.append(f"| {name} | {every_10} | {kept(a)} | {kept(b)} | "
                     f"{100 * (b['best_val_ade'] / a['best_val_ade'] - 1):+.1f} % | "
                     f"{a['held_out_ade']:.1f} -> {b['held_out_ade']:.1f} | "
                     f"{100 * (b['held_out_ade'] / a['held_out_ade'] - 1):+.1f} % |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=baselines.TRAINABLE)
    parser.add_argument("--horizons", type=int, nargs="+")
    parser.add_argument("--epochs", type=int)
    parser.add_argument("--seed", type=int, default=None, help="training seed (default train_baseline.seed)")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--tables", type=Path, default=Path("data/horizon_windows"))
    parser.add_argument("--checkpoints", type=Path, default=Path("checkpoints"))
    parser.add_argument("--fresh", action="store_true",
                        help="train from scratch, not from the stage's checkpoint")
    parser.add_argument("--summary", type=int, nargs="+", metavar="BUDGET",
                        help="train nothing: compare these epoch budgets over every run in --out")
    args = parser.parse_args()
    if args.summary:
        for line in markdown_rows(summary(args.out, tuple(args.summary)), args.summary[0], args.summary[-1]):
            print(line)
        return
    if args.model is None or not args.horizons or args.epochs is None:
        parser.error("--model, --horizons and --epochs are required to train")
    params = read_params()
    main_seed = load_section(TrainBaselineParams, "train_baseline", params).seed
    seed = main_seed if args.seed is None else args.seed
    for horizon in args.horizons:
        extend(args.model, horizon, args.epochs, seed, args.out, params, args.tables, args.checkpoints,
               args.fresh)


if __name__ == "__main__":
    main()
