"""The figures' series: ADE per horizon (Figure 4) and per K_a (Figure 5) for every model with the
paper's points beside them, the rows `dvc plots` draws, and the section bracketing Table 3 (its
diagnostics, `pipeline.report.diagnostics` and `pipeline.report.compat`, beside the paper's
long-term cells).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.model_list import PECNET, YNET, label
from pipeline.report.common import HORIZON_MODELS, LONG_TERM_TF, paper_columns
from pipeline.report.compat import compat_rows
from pipeline.report.diagnostics import HEADLINE, TITLE as DIAGNOSTICS_TITLE, diagnostics_from_store
from pipeline.report.lookups import (Absent, Measured, MetricsStore, as_measured, is_number, lookup,
                                     lookup_ynet_setting)


@dataclass(frozen=True)
class Series:
    key: str
    label: str
    points: tuple[tuple[int, Measured], ...]
    missing: tuple[tuple[int | None, Absent], ...]


def split_points(key: str, label: str, found: Iterable[tuple[int | None, Measured | Absent]]) -> Series:
    found = list(found)
    return Series(key, label, tuple((x, v) for x, v in found if isinstance(v, Measured)),
                  tuple((x, v) for x, v in found if isinstance(v, Absent)))


def horizon_series(store: MetricsStore, horizons: Iterable[int],
                   models: Iterable[tuple[str, str]] = HORIZON_MODELS) -> list[Series]:
    """ADE per horizon for every model of the paper's horizon figure and every registered one
    (`models`: (key, label), `horizon_models`)."""
    horizons = list(horizons)
    out = []
    for key, label in models:
        found = []
        for h in horizons:
            if key == YNET:  # the main Y-net is the t_f = 30 point
                rel = "ynet_eval.json" if h == LONG_TERM_TF else f"ynet_horizons/tf{h}.json"
                found.append((h, lookup(store, rel, ("main", "ade"), t_f=h)))
            else:
                found.append((h, lookup(store, f"baselines/{key}_tf{h}.json", ("ade",), t_f=h)))
        out.append(split_points(key, label, found))
    return out


def ka_series(store: MetricsStore) -> list[Series]:
    """ADE against K_a: Y-net per K_e (ka_grid), PECNet with 20 x K_a samples."""
    return [*ynet_ka_series(store), pecnet_ka_series(store)]


def ynet_ka_series(store: MetricsStore) -> list[Series]:
    """One series per K_e of `ynet_eval.json`'s ka_grid, or one saying why there is none."""
    rel = "ynet_eval.json"
    record = store.record(rel)
    grid = record.get("ka_grid") if isinstance(record, dict) else None
    if isinstance(record, Absent) or not isinstance(grid, list):
        why = (record if isinstance(record, Absent)
               else Absent(f"{store.where(rel)} has no ka_grid", "invalid"))
        return [Series(YNET, label(YNET), (), ((None, why),))]
    rows = [row for row in grid
            if isinstance(row, dict) and is_number(row.get("k_e")) and is_number(row.get("k_a"))]
    out = []
    for k_e in sorted({row["k_e"] for row in rows}):
        k_as = sorted({row["k_a"] for row in rows if row["k_e"] == k_e})
        found = [(k_a, lookup_ynet_setting(store, rel, k_e, k_a, "ade")) for k_a in k_as]
        out.append(split_points(f"{YNET}_ke{k_e}", f"{label(YNET)} K_e = {k_e}", found))
    return out


def pecnet_ka_series(store: MetricsStore) -> Series:
    """PECNet's ADE per K_a from `baselines/pecnet_ka.json` (a list), noting a K other than 20 K_a."""
    rel, key, shown = "baselines/pecnet_ka.json", f"{PECNET}_k20ka", f"{label(PECNET)}, K = 20 K_a"
    record = store.record(rel)
    if not isinstance(record, list):
        why = record if isinstance(record, Absent) else Absent(f"{store.where(rel)} is not a list", "invalid")
        return Series(key, shown, (), ((None, why),))
    found = []
    for row in record:
        if isinstance(row, dict) and is_number(row.get("k_a")):
            note = "" if row.get("k") in (None, 20 * row["k_a"]) else f"K = {row['k']}, not 20 K_a"
            source = f"{store.where(rel)}: k_a = {row['k_a']}"
            value = as_measured(row.get("ade"), row.get("rounds"), source, note)
            found.append((int(row["k_a"]), value))
    return split_points(key, shown, sorted(found, key=lambda p: p[0]))


def paper_long_term_points(paper: Mapping) -> dict[str, float]:
    """Table 3's SDD ADE at t_f = 30 s, K_a = 1 per model: the only published horizon points."""
    return {c["model"]: c["ade"] for c in paper_columns(paper["sdd_long"], SDD_LONG_TERM)
            if c["k_a"] == 1}


def paper_long_term_cells(paper: Mapping) -> dict[str, dict[str, float]]:
    """Table 3's SDD ADE and FDE at t_f = 30 s, K_a = 1, per model."""
    return {c["model"]: {"label": c["label"], "ade": c["ade"], "fde": c["fde"]}
            for c in paper_columns(paper["sdd_long"], SDD_LONG_TERM) if c["k_a"] == 1}


def diagnostics_section(store: MetricsStore, paper: Mapping,
                        models: Iterable[tuple[str, str]]) -> dict[str, Any]:
    """What brackets Table 3 (t_f = 30 s), never in place of its headline: every model at K = 1
    beside K = 20, R-PECNet's compounding roll-out (`pipeline.report.diagnostics`) and PECNet's
    epochs selected on the test set as upstream does (`pipeline.report.compat`), with the paper's
    cells beside them. `models`: (key, label) of its rows' models (`common.table_models`)."""
    cells = paper_long_term_cells(paper)
    selection = store.record("pecnet_test_selection.json")
    return {"title": DIAGNOSTICS_TITLE, "t_f": LONG_TERM_TF, "paper": cells, "headline": HEADLINE,
            "rows": diagnostics_from_store(store, LONG_TERM_TF, tuple(models)),
            "compat": compat_rows(None if isinstance(selection, Absent) else selection,
                                  {LONG_TERM_TF: cells[PECNET]} if PECNET in cells else None),
            "compat_absent": selection if isinstance(selection, Absent) else None,
            "compat_source": store.where("pecnet_test_selection.json")}


def paper_ka_points(paper: Mapping) -> list[tuple[int, float]]:
    """Table 3's SDD Y-net ADE at K_e = 20 for each K_a."""
    return [(c["k_a"], c["ade"]) for c in paper_columns(paper["sdd_long"], SDD_LONG_TERM)
            if c["model"] == YNET]


def plot_rows(series: list[Series], x_name: str) -> list[dict[str, float]]:
    """Wide records for `dvc plots` ({x_name: x, <series key>: mean}); only measured values."""
    rows: dict[int, dict[str, float]] = {}
    for s in series:
        for x, value in s.points:
            rows.setdefault(x, {x_name: x})[s.key] = value.mean
    return [rows[x] for x in sorted(rows)]
