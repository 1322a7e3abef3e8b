"""Which epoch a baseline keeps: selection rules over its validation curve, and the split-half study
that chooses between them on validation windows alone.

On the long horizons the validation sets are tiny (15-21 windows at 40-60 s), so the epoch with the
lowest validation ADE is partly chosen by which few windows happen to be there: re-trained on
another CPU, a baseline can keep an epoch that scores a third worse on test. A smoothed curve
averages that luck over neighbouring epochs. Rules (`RULES`, each a half-width h):

- `raw`: the epoch with the lowest mean validation ADE (h = 0; what the authors' code does);
- `mean3`, `mean5`, `mean7`: the epoch whose centred mean over 2h + 1 epochs is lowest. The window
  is cut short at the first epoch; the last h epochs are never candidates (their window is not yet
  complete), so a rule's choice never changes once made and training can keep the weights while it
  still has them (`pipeline.harness.baselines.common.run_training` keeps one `best` file per rule).

The study (`split_half_study`): for one training run's per-window validation curves (epochs x
windows), split the windows at random into halves A and B, let each rule choose an epoch on A and
score that epoch on B (and the other way round), many times over. A rule whose choice holds up on
windows it did not see is less noisy; the test windows are never read.
"""

from __future__ import annotations

import numpy as np

RULES: dict[str, int] = {"raw": 0, "mean3": 1, "mean5": 2, "mean7": 3}  # rule -> half-width
MAX_HALF_WIDTH = max(RULES.values())


def half_width(rule: str) -> int:
    """The half-width of `rule`, or a ValueError naming the known rules."""
    try:
        return RULES[rule]
    except KeyError:
        raise ValueError(f"unknown epoch selection rule {rule!r}; known: {sorted(RULES)}") from None


def centred_mean(curve: np.ndarray, epoch: int, width: int) -> float:
    """Mean of `curve` over epochs [epoch - width, epoch + width], cut at the ends."""
    return float(np.mean(curve[max(epoch - width, 0):epoch + width + 1]))


def candidates(n_epochs: int, width: int) -> range:
    """The epochs a rule of half-width `width` may choose after `n_epochs` epochs: those whose
    window is complete; all of them when no window is complete yet (a run of <= width epochs)."""
    return range(n_epochs - width) if n_epochs > width else range(n_epochs)


def selected_epoch(curve: np.ndarray, rule: str) -> int:
    """The epoch `rule` keeps for the validation curve `curve` (E,): the first lowest smoothed value
    among the candidates."""
    curve = np.asarray(curve, dtype=float)
    if curve.ndim != 1 or len(curve) == 0:
        raise ValueError(f"a validation curve is a non-empty 1-D array, got shape {curve.shape}")
    width = half_width(rule)
    epochs = candidates(len(curve), width)
    values = [centred_mean(curve, epoch, width) for epoch in epochs]
    return epochs[int(np.argmin(values))]


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
