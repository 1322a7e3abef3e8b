"""Which epoch a baseline keeps: selection rules over its validation curve.

On the long horizons the validation sets are tiny (15-21 windows at 40-60 s), so the epoch with the
lowest validation ADE is partly chosen by which few windows happen to be there: re-trained on
another CPU, a baseline can keep an epoch that scores a third worse on test. A smoothed curve
averages that luck over neighbouring epochs. Rules (`RULES`, each a half-width h):

- `raw`: the epoch with the lowest mean validation ADE (h = 0; what the authors' code does);
- `mean3`, `mean5`, `mean7`: the epoch whose centred mean over 2h + 1 epochs is lowest. The window
  is cut short at the first epoch; the last h epochs are never candidates (their window is not yet
  complete), so a rule's choice never changes once made and training can keep the weights while it
  still has them (`pipeline.runners.baselines.training.run_training` keeps one `best` file per rule).

Which rule to score with is chosen by the split-half study of stage `epoch_selection`
(`pipeline.studies.epoch_selection`), on validation windows alone.
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
