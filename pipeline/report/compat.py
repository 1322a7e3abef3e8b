"""What the report shows of `metrics/pecnet_test_selection.json` (stage `pecnet_test_selection`):
a labelled compat diagnostic, never a headline number.

Upstream PECNet reports its best test ADE and best test FDE over all training epochs (selection on
the test set, each metric at its own epoch); our headline scores the epoch kept on validation.
`compat_rows(record, paper)` gives, per horizon and scoring protocol, one row for each: the epoch
kept on validation and upstream's test-set selection, with the share of the gap to the paper that
the test-set selection explains (`gap_share`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pipeline.model_list import PECNET

SELECTIONS = ("validation", "test")
PROTOCOL_LABELS = {"headline": "ours (min ADE, min FDE)",
                   PECNET: "PECNet's (ADE of the best endpoint, min FDE)"}


def gap_share(ours: float | None, compat: float | None, paper: float | None) -> float | None:
    """The share of our gap to the paper (ours - paper) that selecting on test removes
    (ours - compat): 1 closes it, 0 explains none of it. None where a value is absent or we are not
    above the paper (no gap to explain)."""
    if ours is None or compat is None or paper is None or ours <= paper:
        return None
    return (ours - compat) / (ours - paper)


def _t(name: str) -> int:
    return int(name.removeprefix("tf"))


def compat_rows(record: Mapping[str, Any] | None,
                paper: Mapping[int, Mapping[str, float]] | None = None) -> list[dict[str, Any]]:
    """Rows, per horizon (ascending) and protocol (`headline`, then `pecnet`), the validation row
    first:

        {"t_f": 30, "protocol": "pecnet", "protocol_label": ..., "selection": "validation" | "test",
         "label": "PECNet t_f=30 s: epoch kept on validation" |
                  "PECNet t_f=30 s: upstream's test-set selection (compat)",
         "ade": float, "ade_epoch": int, "fde": float, "fde_epoch": int,
         "ade_gap_share": float | None, "fde_gap_share": float | None}

    Epochs are 0-based (as `train_pecnet_tf<H>.json`'s `best_epoch`); the validation row has one
    epoch for both. `paper` ({t_f: {"ade", "fde"}}, e.g. {30: {"ade": 72.22, "fde": 118.13}})
    gives the test rows their `*_gap_share` (`gap_share`; None on validation rows, without a paper
    value, or with no gap). An absent record gives no rows."""
    rows: list[dict[str, Any]] = []
    per_horizon = (record or {}).get("per_horizon") or {}
    for name in sorted(per_horizon, key=_t):
        entry, t_f = per_horizon[name], _t(name)
        kept = entry["validation_selected"]
        for protocol, protocol_label in PROTOCOL_LABELS.items():
            ours = kept["test"][protocol]
            best = entry["compat"][protocol]
            common = {"t_f": t_f, "protocol": protocol, "protocol_label": protocol_label}
            rows.append({**common, "selection": "validation",
                         "label": f"PECNet t_f={t_f} s: epoch kept on validation",
                         "ade": ours["ade"], "ade_epoch": kept["epoch"],
                         "fde": ours["fde"], "fde_epoch": kept["epoch"],
                         "ade_gap_share": None, "fde_gap_share": None})
            target = (paper or {}).get(t_f) or {}
            rows.append({**common, "selection": "test",
                         "label": f"PECNet t_f={t_f} s: upstream's test-set selection (compat)",
                         "ade": best["best_ade"]["value"], "ade_epoch": best["best_ade"]["epoch"],
                         "fde": best["best_fde"]["value"], "fde_epoch": best["best_fde"]["epoch"],
                         **{f"{m}_gap_share": gap_share(ours[m], best[f"best_{m}"]["value"], target.get(m))
                            for m in ("ade", "fde")}})
    return rows
