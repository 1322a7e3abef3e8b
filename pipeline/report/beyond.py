"""The report's section "Beyond the paper's tables": the metrics stages `score_predictions` and
`score_short_term_predictions` compute from the stored predictions (`metrics/beyond/long_term.json`,
`ind.json`, `short_term.json`; layouts in `pipeline.harness.stored_scores`), read defensively as
the rest of the page is (`lookups`).

- a table at t_f = 30 s: every model on the horizon table's windows, then each model on another
  table of that horizon (Y-net on the release's windows) in rows of their own, the off-limits share
  and collision rate beside the ground truth's;
- a figure of small multiples, one panel per metric against the horizon, one line per model, the
  ground truth's share as a dashed reference, other tables' points as hollow stars;
- the files that were not scored, with the reason each gives;
- the short-term benchmarks (TrajNet SDD in pixels, the ETH/UCY folds in metres): one row per
  benchmark and model, the same metrics, each row's unit stated, and which windows had a mask;
- inD: its rows where it was scored, else one line saying why it is absent.
The long-term part and the short-term / inD parts are shown independently: either file may be
missing without hiding the other.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from pipeline.benchmarks.registry import scored
from pipeline.model_list import SHORT_TERM_MODELS, label, ours_first
from pipeline.report.lookups import Absent, Measured, MetricsStore, lookup

BEYOND_FILE = "beyond/long_term.json"  # relative to the metrics folder
SHORT_TERM_FILE = "beyond/short_term.json"
IND_FILE = "beyond/ind.json"


@dataclass(frozen=True)
class Metric:
    """A column of the table (and maybe a panel of the figure)."""

    key: str  # the record's metric name
    label: str
    part: str  # "metrics" (of the predictions) or "ground_truth"
    decimals: int


COLUMNS = (
    Metric("ade", "min-ADE (px)", "metrics", 2),
    Metric("fde", "min-FDE (px)", "metrics", 2),
    Metric("fde_joint", "joint FDE (px)", "metrics", 2),
    Metric("ade_best_endpoint", "best-endpoint ADE (px)", "metrics", 2),
    Metric("miss_rate", "miss rate", "metrics", 3),
    Metric("kde_nll", "KDE NLL", "metrics", 2),
    Metric("off_limits_share", "off-limits share", "metrics", 3),
    Metric("off_limits_share", "ground truth's off-limits share", "ground_truth", 3),
    Metric("collision_rate", "collision rate", "metrics", 3),
    Metric("collision_rate", "ground truth's collision rate", "ground_truth", 3),
)
PANELS = ("ade", "ade_best_endpoint", "miss_rate", "kde_nll", "off_limits_share",
          "collision_rate")  # the figure's, in reading order
PANEL_LABELS = {"ade": "min-ADE (px)", "ade_best_endpoint": "best-endpoint ADE (px)",
                "miss_rate": "miss rate", "kde_nll": "KDE NLL (mean over steps)",
                "off_limits_share": "off-limits share", "collision_rate": "collision rate"}
REFERENCE = ("off_limits_share", "collision_rate")  # panels with the ground truth's line


@dataclass(frozen=True)
class Row:
    """One model on one window table: its cells in `COLUMNS` order, or why it was not scored."""

    label: str
    table: str
    n_windows: Any
    rounds: Any
    cells: tuple[tuple[Measured | Absent, int], ...]  # (value, decimals)
    not_run: Absent | None = None
    unit: str | None = None  # px | m (rows of benchmarks in different units)


@dataclass(frozen=True)
class Curve:
    """One model's (or the ground truth's) values of one metric against the horizon."""

    key: str
    label: str
    points: tuple[tuple[int, Measured], ...]


def horizon_tables(tables: Mapping[str, Any]) -> list[tuple[int, str]]:
    """(t_f, name) of the horizon tables (`tf<H>`), by horizon."""
    return sorted((int(name[2:]), name) for name in tables if re.fullmatch(r"tf\d+", name))


def models_of(record: Mapping[str, Any], table: str) -> Mapping[str, Any]:
    node = record["tables"].get(table)
    return node.get("models", {}) if isinstance(node, dict) else {}


def value(store: MetricsStore, table: str, model: str, part: str, key: str) -> Measured | Absent:
    return lookup(store, BEYOND_FILE, ("tables", table, "models", model, part, key))


def row(store: MetricsStore, record: Mapping[str, Any], table: str, model: str, label: str
        ) -> Row:
    entry = models_of(record, table).get(model, {})
    reason = entry.get("not_run_reason") if isinstance(entry, dict) else None
    if isinstance(reason, str):
        return Row(label, table, None, None, (), Absent(reason, "status"))
    cells = tuple((value(store, table, model, c.part, c.key), c.decimals) for c in COLUMNS)
    return Row(label, table, entry.get("n_windows"), entry.get("rounds"), cells)


def rows_at(store: MetricsStore, record: Mapping[str, Any], t_f: int,
            models: Sequence[tuple[str, str]]) -> list[Row]:
    """Every model on the horizon table `tf<t_f>` (in `models` order), then every model on the
    other tables of horizon t_f, labelled with the table."""
    names = dict(models)
    out = [row(store, record, f"tf{t_f}", key, label) for key, label in models
           if key in models_of(record, f"tf{t_f}")]
    for table, node in record["tables"].items():
        if isinstance(node, dict) and node.get("t_f") == t_f and table != f"tf{t_f}":
            out += [row(store, record, table, key, f"{names.get(key, key)}, {table} windows")
                    for key in models_of(record, table)]
    return out


def not_scored(record: Mapping[str, Any]) -> list[tuple[str, str]]:
    """('<table>/<model>', reason) of every file that says why nothing was predicted."""
    return [(f"{table}/{model}", entry["not_run_reason"]) for table in record["tables"]
            for model, entry in models_of(record, table).items()
            if isinstance(entry, dict) and isinstance(entry.get("not_run_reason"), str)]


def curves(store: MetricsStore, record: Mapping[str, Any], metric: str,
           models: Sequence[tuple[str, str]]) -> tuple[list[Curve], Curve | None]:
    """Each model's values of `metric` on the horizon tables, and the ground truth's (from the
    first model scored at each horizon: every model there covers the same windows) where the
    metric has one."""
    horizons = horizon_tables(record["tables"])
    out = []
    for key, label in models:
        found = [(t_f, value(store, name, key, "metrics", metric)) for t_f, name in horizons
                 if key in models_of(record, name)]
        out.append(Curve(key, label, tuple((x, v) for x, v in found if isinstance(v, Measured))))
    if metric not in REFERENCE:
        return out, None
    truth = []
    for t_f, name in horizons:
        found = [value(store, name, key, "ground_truth", metric) for key in models_of(record, name)]
        truth += [(t_f, v) for v in found[:1] if isinstance(v, Measured)]
    return out, Curve("ground_truth", "ground truth", tuple(truth))


def other_points(store: MetricsStore, record: Mapping[str, Any], metric: str
                 ) -> list[tuple[int, Measured, str, str]]:
    """(t_f, value, model, table) of every model scored on a table other than the horizon ones."""
    horizon = {name for _, name in horizon_tables(record["tables"])}
    points = []
    for table, node in record["tables"].items():
        if table in horizon or not isinstance(node, dict) or not isinstance(node.get("t_f"), int):
            continue
        for key in models_of(record, table):
            found = value(store, table, key, "metrics", metric)
            if isinstance(found, Measured):
                points.append((node["t_f"], found, key, table))
    return points


def gapped(curve: Curve, xs: Sequence[int]) -> tuple[list[float], list[float]]:
    """(means, stds) of `curve` at every horizon `xs`, NaN where it has no point: the line breaks
    there instead of joining two distant horizons."""
    found = dict(curve.points)
    mean = [found[x].mean if x in found else float("nan") for x in xs]
    std = [(found[x].std or 0.0) if x in found else float("nan") for x in xs]
    return mean, std


def plot_panels(store: MetricsStore, record: Mapping[str, Any], models: Sequence[tuple[str, str]],
                colours: Mapping[str, str], path: Path) -> bool:
    """The small multiples (one panel per metric of `PANELS`); False (no file) when no model has
    a point."""
    panels = [(metric, *curves(store, record, metric, models), other_points(store, record, metric))
              for metric in PANELS]
    if not any(c.points for _, drawn, _, _ in panels for c in drawn):
        return False
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = dict(models)
    xs = [t_f for t_f, _ in horizon_tables(record["tables"])]
    fig, axes = plt.subplots(2, 3, figsize=(12.5, 7), dpi=100)
    for ax, (metric, drawn, truth, others) in zip(axes.flat, panels, strict=True):
        for c in (c for c in drawn if c.points):
            mean, std = gapped(c, xs)
            ax.errorbar(xs, mean, yerr=std, marker="o", markersize=4, capsize=2, label=c.label,
                        color=colours.get(c.key))
        if truth is not None and truth.points:
            ax.plot(xs, gapped(truth, xs)[0], "--", color="black", label="ground truth")
        for x, v, key, table in others:
            ax.plot([x], [v.mean], marker="*", markersize=11, linestyle="none",
                    markerfacecolor="none", color=colours.get(key),
                    label=f"{names.get(key, key)}, {table} windows")
        values = [v.mean for c in drawn for _, v in c.points] + [v.mean for _, v, _, _ in others]
        if values and min(values) > 0 and max(values) / min(values) > 20:
            ax.set_yscale("log")
        ax.set_title(PANEL_LABELS[metric], fontsize=10)
        ax.set_xlabel("t_f (s)", fontsize=9)
        ax.grid(alpha=0.3)
    handles = {}
    for ax in axes.flat:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, handle)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=4, fontsize=9)
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    fig.savefig(path)
    plt.close(fig)
    return True


def beyond_section(store: MetricsStore, t_f: int, models: Sequence[tuple[str, str]],
                   colours: Mapping[str, str], slot) -> dict[str, Any]:
    """What the template shows: the table at `t_f`, the figure (drawn through `slot`, as the page's
    other figures), the thresholds and the files not scored, or why there is nothing; and, each on
    its own, the short-term table and inD's rows or the reason it is absent."""
    others = {"short_term": short_term_section(store), "ind": ind_section(store, models)}
    record = store.record(BEYOND_FILE)
    if not isinstance(record, Absent) and not (isinstance(record, dict)
                                               and isinstance(record.get("tables"), dict)):
        record = Absent(f"{store.where(BEYOND_FILE)} has no tables", "invalid")
    if isinstance(record, Absent):
        return {"absent": record, **others}
    figure = slot("beyond_horizons.png")
    drawn = plot_panels(store, record, models, colours, figure.path)
    return {"absent": None, "t_f": t_f, "columns": COLUMNS,
            "rows": rows_at(store, record, t_f, models),
            "thresholds": record.get("thresholds") or {}, "unit": record.get("unit", "px"),
            "not_scored": not_scored(record), "src": figure.src if drawn else None,
            "source": store.where(BEYOND_FILE), **others}


# ---------------------------------------------------------------------------------------------
# Short-term benchmarks and inD (`score_benchmarks` layout: {"benchmarks": {name: {"unit",
# "scene_masks", "models": {model: record}}}})

# The long-term columns without their unit: each row states its own (decimals: `cell_decimals`).
BENCHMARK_COLUMNS = tuple(replace(c, label=c.label.removesuffix(" (px)")) for c in COLUMNS)
DISTANCES = frozenset({"ade", "fde", "fde_joint", "ade_best_endpoint"})  # in the row's unit
# (key, label) of the short-term models, Y-net first
SHORT_TERM_ROWS = tuple((name, label(name)) for name in ours_first(SHORT_TERM_MODELS))


def cell_decimals(metric: Metric, unit: Any) -> int:
    """Distances in metres get 3 decimals (ETH/UCY errors are tenths of a metre), pixels 2."""
    return 3 if metric.key in DISTANCES and unit == "m" else metric.decimals


def benchmark_label(name: str) -> str:
    """How a row names the benchmark a record calls `name` (its `Benchmark.label`, else `name`)."""
    benchmark = scored(name)
    return benchmark.label if benchmark is not None and benchmark.label else name


def benchmark_row(store: MetricsStore, rel: str, name: str, node: Mapping[str, Any], model: str,
                  label: str) -> Row:
    entry = node["models"].get(model)
    bench = benchmark_label(name)
    unit = node.get("unit")
    reason = entry.get("not_run_reason") if isinstance(entry, dict) else None
    if isinstance(reason, str):
        return Row(label, bench, None, None, (), Absent(reason, "status"), unit)
    cells = tuple((lookup(store, rel, ("benchmarks", name, "models", model, c.part, c.key)),
                   cell_decimals(c, unit)) for c in BENCHMARK_COLUMNS)
    entry = entry if isinstance(entry, dict) else {}
    return Row(label, bench, entry.get("n_windows"), entry.get("rounds"), cells, None, unit)


def mask_note(name: str, node: Mapping[str, Any]) -> str | None:
    """'SDD (TrajNet): 2829 of 2829 test windows inside a mask (hand labels ...)', or why none."""
    masks = node.get("scene_masks")
    if not isinstance(masks, dict):
        return None
    bench = benchmark_label(name)
    if "absent" in masks:
        return f"{bench}: no scene masks ({masks['absent']})"
    classes = ", ".join(masks.get("forbidden_classes") or [])
    without = masks.get("scenes_without_mask") or []
    return (f"{bench}: {masks.get('windows_with_mask')} of {masks.get('n_windows')} windows in a "
            f"scene with a mask, forbidden {classes}; {masks.get('source')}"
            + (f"; no mask for {', '.join(without)}" if without else ""))


def benchmark_table(store: MetricsStore, rel: str, models: Sequence[tuple[str, str]]
                    ) -> dict[str, Any]:
    """The rows of every benchmark of `rel` (benchmarks in the file's order, models in `models`
    order then any other), the files not scored, the mask notes; or {"absent": why}."""
    record = store.record(rel)
    if not isinstance(record, Absent) and not (isinstance(record, dict)
                                               and isinstance(record.get("benchmarks"), dict)):
        record = Absent(f"{store.where(rel)} has no benchmarks", "invalid")
    if isinstance(record, Absent):
        return {"absent": record}
    names = dict(models)
    rows, not_run, notes = [], [], []
    for name, node in record["benchmarks"].items():
        if not (isinstance(node, dict) and isinstance(node.get("models"), dict)):
            continue
        held = node["models"]
        order = [m for m, _ in models if m in held] + [m for m in held if m not in names]
        for model in order:
            row = benchmark_row(store, rel, name, node, model, names.get(model, model))
            rows.append(row)
            if row.not_run is not None:
                not_run.append((f"{name}/{model}", row.not_run.reason))
        note = mask_note(name, node)
        if note:
            notes.append(note)
    return {"absent": None, "rows": rows, "not_scored": not_run, "mask_notes": notes,
            "scored": any(r.not_run is None for r in rows),
            "thresholds": record.get("thresholds") or {}, "source": store.where(rel)}


def short_term_section(store: MetricsStore) -> dict[str, Any]:
    """The short-term table (`score_short_term_predictions`), or why there is none."""
    return {**benchmark_table(store, SHORT_TERM_FILE, SHORT_TERM_ROWS),
            "columns": BENCHMARK_COLUMNS}


def ind_section(store: MetricsStore, models: Sequence[tuple[str, str]]) -> dict[str, Any]:
    """inD's rows where any file was scored, else the reasons its files give (inD not provided:
    one reason for every model)."""
    table = benchmark_table(store, IND_FILE, models)
    if table["absent"] is None and not table["scored"]:
        reasons = sorted({reason for _, reason in table["not_scored"]})
        table["reasons"] = reasons
    return {**table, "columns": BENCHMARK_COLUMNS}
