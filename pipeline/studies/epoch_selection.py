"""The split-half study of the epoch selection rules (stage `epoch_selection`): which rule of
`pipeline.harness.epoch_selection` the long-term baselines are scored with, judged on validation
windows alone.

For one training run's per-window validation curves (epochs x windows), `split_half_study` splits
the windows at random into halves A and B, lets each rule choose an epoch on A and scores that epoch
on B (and the other way round), many times over. A rule whose choice holds up on windows it did not
see is less noisy; the test windows are never read. `epoch_selection_study` runs it over every
trained long-term baseline (`long_term_runs`) and `summarise` pools the runs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.runners.baselines import TRAINABLE
from pipeline.runners.baselines.common import fit_result_from
from pipeline.harness.epoch_selection import RULES, selected_epoch


def split_half_study(window_curves: np.ndarray, n_splits: int, seed: int,
                     rules: tuple[str, ...] = tuple(RULES)) -> dict:
    """Held-out validation ADE of each rule's choice, averaged over `n_splits` random halvings of the
    windows (each half chooses once and is scored on the other).

    window_curves: (E, N) validation ADE of each window after each epoch, N >= 2. Returns
    {"held_out": {rule: mean ADE on the half that did not choose}, "oracle": mean of the held-out
    half's own lowest epoch (the floor), "n_windows": N, "n_epochs": E, "n_splits": n_splits}.
    """
    curves = np.asarray(window_curves, dtype=float)
    if curves.ndim != 2 or curves.shape[1] < 2 or curves.shape[0] < 1:
        raise ValueError(f"need (epochs, windows) validation errors with >= 2 windows, got {curves.shape}")
    rng = np.random.default_rng(seed)
    n_windows = curves.shape[1]
    held_out = {rule: [] for rule in rules}
    oracle = []
    for _ in range(n_splits):
        order = rng.permutation(n_windows)
        halves = (order[:n_windows // 2], order[n_windows // 2:])
        for choosing, scoring in (halves, halves[::-1]):
            choosing_curve = curves[:, choosing].mean(axis=1)  # (E,)
            scoring_curve = curves[:, scoring].mean(axis=1)  # (E,)
            oracle.append(scoring_curve.min())
            for rule in rules:
                held_out[rule].append(scoring_curve[selected_epoch(choosing_curve, rule)])
    return {"held_out": {rule: float(np.mean(values)) for rule, values in held_out.items()},
            "oracle": float(np.mean(oracle)), "n_windows": n_windows, "n_epochs": curves.shape[0],
            "n_splits": n_splits}


def summarise(runs: list[dict], rules: tuple[str, ...] = tuple(RULES)) -> dict:
    """Pool per-run studies: for each rule the mean ratio of its held-out ADE to `raw`'s (below 1:
    better than the authors' rule) and how many runs it beats `raw` on, overall and per horizon;
    `recommended` is the rule with the lowest mean ratio. Each run: a `split_half_study` result
    with its "model", "horizon" and "seed"."""
    if not runs:
        raise ValueError("no training runs to pool")

    def pooled(group: list[dict]) -> dict:
        out = {}
        for rule in rules:
            ratios = np.array([run["held_out"][rule] / run["held_out"]["raw"] for run in group])
            out[rule] = {"mean_ratio_to_raw": float(ratios.mean()),
                         "runs_better_than_raw": int((ratios < 1 - 1e-12).sum()),
                         "runs_worse_than_raw": int((ratios > 1 + 1e-12).sum()), "runs": len(group)}
        return out

    overall = pooled(runs)
    horizons = sorted({run["horizon"] for run in runs})
    return {"overall": overall,
            "per_horizon": {str(h): pooled([run for run in runs if run["horizon"] == h]) for h in horizons},
            "recommended": min(rules, key=lambda rule: (overall[rule]["mean_ratio_to_raw"], RULES[rule]))}


def long_term_runs(checkpoints: Path, horizons: list[int], main_seed: int,
                   extra_seeds: list[int]) -> list[tuple[str, int, int, Path]]:
    """Every trained long-term baseline run as (model, horizon, training seed, checkpoint folder):
    `<model>_tf<H>` for the main seed (stage `train_baseline`), `seeds/<model>_tf<H>_seed<S>` for
    the extra ones (`train_baseline_seed`), the folders of dvc.yaml's `epoch_selection` deps."""
    runs = []
    for model in TRAINABLE:
        for horizon in horizons:
            runs.append((model, horizon, main_seed, Path(checkpoints) / f"{model}_tf{horizon}"))
            runs += [(model, horizon, seed, Path(checkpoints) / "seeds" / f"{model}_tf{horizon}_seed{seed}")
                     for seed in extra_seeds]
    return runs


def epoch_selection_study(runs: list[tuple[str, int, int, Path]], n_splits: int, seed: int) -> dict:
    """The split-half study of every trained run (model, horizon, training seed, checkpoint folder):
    per run, each rule's held-out validation ADE (`split_half_study`) and the epoch it keeps on the
    whole validation set; pooled, each rule against `raw` (`summarise`, whose `recommended` rule is
    the one to score with)."""
    records = []
    for model, horizon, train_seed, folder in runs:
        result = fit_result_from(folder)
        if not result.history or "val_window_ade" not in result.history[0]:
            raise ValueError(f"{folder}/last.pt: no per-window validation errors (trained before they "
                             "were recorded): re-run its training stage")
        curves = result.window_curves()  # (E, N)
        study = split_half_study(curves, n_splits, seed)
        records.append({"model": model, "horizon": horizon, "seed": train_seed, **study,
                        "kept_epochs": dict(result.selected)})
    return {"rules": dict(RULES), "n_splits": n_splits, "seed": seed,
            "summary": summarise(records), "runs": records}
