"""Budget curves: does training longer close the gap to the paper? The study `budget_run`
(studies/dvc.yaml) trains a model afresh for 1x, 2x and 4x the profile's epochs and scores each
as its headline; its records are in studies/budget/<benchmark>_<model>_x<factor>.json.

Per curve (benchmark, model): the test ADE / FDE at each budget, drawn against the paper's number
(`plot_budget`), and for a table cell the `BudgetPoint` its cause reads: the longest run against
the 1x run of the same study (one machine), or against the headline where the study has no 1x.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TYPE_CHECKING

from pipeline.benchmarks.registry import studied
from pipeline.model_list import YNET, label
from pipeline.report.common import LONG_TERM_TF, paper_columns
from pipeline.report.figures import _pyplot
from pipeline.report.lookups import (YNET_MAIN, Measured, MetricsStore, dig, is_number,
                                     lookup_ynet_setting)
from pipeline.report.provenance import BudgetPoint

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.benchmarks.long_term import LongTermBenchmark
    from pipeline.benchmarks.short_term import ShortTermBenchmark

METRICS = ("ade", "fde")


@dataclass(frozen=True)
class BudgetRun:
    factor: int
    epochs: int
    values: Mapping[str, float]  # "ade", "fde": test, mean over evaluation rounds
    best_epoch: int | None
    cpu: str
    source: str


def run_values(record: Mapping[str, Any]) -> dict[str, float]:
    """Test ADE / FDE of a scoring record: a long-term baseline's ({"ade": {"mean"}}), the
    long-term Y-net's main setting ({"main": {"ade": {"mean"}}}) or a short-term one at its first
    K ({"k20": {"ade": {"mean"}}})."""
    ks = record.get("ks")
    node = (record.get(f"k{ks[0]}") if isinstance(ks, list) and ks
            else record.get("main", record))
    return {metric: float(dig(node, metric, "mean")) for metric in METRICS
            if is_number(dig(node, metric, "mean"))}


def kept_epoch(record: Mapping, model: str) -> int | None:
    """The epoch validation kept, counted from 1 as the page counts epochs: the first minimum of
    the run's validation curve (how Y-net's and the baselines' trainings keep their best weights),
    else the recorded one (the baselines record it from 0, long-term at the top, short-term
    under "train"; Y-net from 1)."""
    curve = record.get("val_ade_per_epoch")
    if isinstance(curve, list) and curve and all(is_number(v) for v in curve):
        return curve.index(min(curve)) + 1
    best = record.get("best_epoch", dig(record, "train", "best_epoch"))
    if not is_number(best):
        return None
    return int(best) if model == YNET else int(best) + 1


def budget_runs(studies: MetricsStore) -> dict[tuple[str, str], list[BudgetRun]]:
    """(benchmark, model) -> its runs by factor, from the records' names and contents."""
    curves: dict[tuple[str, str], list[BudgetRun]] = {}
    for rel, record in sorted(studies.files.items()):
        name = Path(rel).stem  # <benchmark>_<model>_x<factor>
        benchmark, _, rest = name.rpartition("_x")[0].rpartition("_")
        if not (isinstance(record, Mapping) and is_number(record.get("factor")) and benchmark):
            continue
        model = rest
        best = kept_epoch(record, model)
        curves.setdefault((benchmark, model), []).append(BudgetRun(
            int(record["factor"]), int(record.get("epochs", 0)), run_values(record),
            best,
            str(dig(record, "machine", "cpu") or "unknown"), studies.where(rel)))
    return {key: sorted(runs, key=lambda run: run.factor) for key, runs in curves.items()}


def budget_point(runs: list[BudgetRun], metric: str, headline: float | None) -> BudgetPoint | None:
    """The longest run against the study's own 1x (else `headline`); None without a longer run."""
    longest = max((run for run in runs if metric in run.values), key=lambda run: run.factor,
                  default=None)
    one_x = next((run.values[metric] for run in runs if run.factor == 1 and metric in run.values),
                 headline)
    if longest is None or longest.factor <= 1 or one_x is None:
        return None
    return BudgetPoint(longest.factor, longest.values[metric], one_x)


def budget_ticks(runs: list[BudgetRun], with_headline: bool) -> list[int]:
    """The budgets a curve's axis names: its runs', and 1x where the headline run is drawn there
    (a study without its own 1x)."""
    return sorted({run.factor for run in runs} | ({1} if with_headline else set()))


def plot_budget(runs: list[BudgetRun], paper: Mapping[str, float | None],
                headline: Mapping[str, float | None], title: str, unit: str, path: Path) -> bool:
    """Test ADE and FDE against the budget (x the profile's epochs), the paper's number as a
    dashed line and the headline run as a hollow marker at 1x. False (no file) without a run."""
    if not runs:
        return False
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), dpi=110)
    for ax, metric in zip(axes, METRICS):
        points = [(run.factor, run.values[metric]) for run in runs if metric in run.values]
        ax.plot([x for x, _ in points], [y for _, y in points], marker="o", color="#1f77b4",
                label="ours, this study")
        if headline.get(metric) is not None:
            ax.plot([1], [headline[metric]], marker="s", markerfacecolor="none", linestyle="none",
                    color="#555555", label="ours, headline run")
        if paper.get(metric) is not None:
            ax.axhline(paper[metric], linestyle="--", color="#d62728", label="paper")
        ax.set_xscale("log", base=2)
        factors = budget_ticks(runs, headline.get(metric) is not None)
        ax.set_xticks(factors, [f"{factor}x" for factor in factors])
        ax.set_xlabel("training budget (x the profile's epochs)")
        ax.set_ylabel(f"test {metric.upper()} ({unit})")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return True


def headline_value(value) -> float | None:
    return value.mean if isinstance(value, Measured) else None


def long_term_numbers(benchmark: LongTermBenchmark, model: str, paper: Mapping[str, Any],
                      store: MetricsStore) -> tuple[dict[str, Any], dict[str, Any]]:
    """Table 3's column of `benchmark` at K_a = 1; ours from its records at t_f = 30 s."""
    column = next((c for c in paper_columns(paper[benchmark.paper_table], benchmark)
                   if c.get("model") == model and c.get("k_a") == 1), {})
    rel, keys = benchmark.baseline_metrics(model, LONG_TERM_TF)
    ours = {m: headline_value(lookup_ynet_setting(store, benchmark.metrics_file, **YNET_MAIN,
                                                  metric=m))
            if model == YNET else dig(store.files.get(rel), *keys, m, "mean") for m in METRICS}
    return {m: column.get(m) for m in METRICS}, ours


def sdd_short_numbers(benchmark: ShortTermBenchmark, model: str, paper: Mapping[str, Any],
                      store: MetricsStore) -> tuple[dict[str, Any], dict[str, Any]]:
    """Table 1's K = 20 column; ours from the benchmark's summary at K = 20."""
    column = next((c for c in paper[benchmark.paper_table]["columns"]
                   if c.get("model") == model and c.get("k") == 20), {})
    ours = {m: dig(store.files.get(f"short_term/{benchmark.summary_file}"), "models", model,
                   "k20", m, "mean") for m in METRICS}
    return {m: column.get(m) for m in METRICS}, ours


def eth_ucy_numbers(benchmark: ShortTermBenchmark, model: str, paper: Mapping[str, Any],
                    store: MetricsStore) -> tuple[dict[str, Any], dict[str, Any]]:
    """Table 2's cell of the benchmark's scene; ours from its summary (its one K)."""
    entry = next((e for e in paper[benchmark.paper_table]["models"] if e.get("model") == model),
                 {})
    ours = {m: dig(store.files.get(f"short_term/{benchmark.summary_file}"), "models", model, m,
                   "mean") for m in METRICS}
    return {m: dig(entry, m, benchmark.paper_key) for m in METRICS}, ours


# How a curve's benchmark finds the paper's number and our headline, by its paper table.
NUMBERS_BY_TABLE = {"sdd_long": long_term_numbers, "sdd_short": sdd_short_numbers,
                    "eth_ucy": eth_ucy_numbers}


def paper_and_headline(benchmark: str, model: str, paper: Mapping[str, Any],
                       store: MetricsStore) -> tuple[dict[str, float | None], dict[str, float | None], str]:
    """The paper's numbers, our headline run's and the unit for a curve's benchmark (its name in
    the study's records): Table 3's SDD column at K_a = 1, Table 1's K = 20 column, or Table 2's
    fold; nothing for a benchmark the paper does not report."""
    found = studied(benchmark)
    if found is None or found.paper_table not in NUMBERS_BY_TABLE:
        return dict.fromkeys(METRICS), dict.fromkeys(METRICS), "" if found is None else found.unit
    paper_values, ours = NUMBERS_BY_TABLE[found.paper_table](found, model, paper, store)
    return paper_values, ours, found.unit


def budget_title(benchmark: str, model: str) -> str:
    """A curve's title: the model and where the paper reports the benchmark."""
    found = studied(benchmark)
    return f"{label(model)}, {found.in_paper if found and found.in_paper else benchmark}"


def budget_section(curves: Mapping[tuple[str, str], list[BudgetRun]], paper: Mapping[str, Any],
                   store: MetricsStore, slot) -> list[dict[str, Any]]:
    """Each curve drawn (`slot(name)` says where) and described: its runs, and per metric the
    share of the gap to the paper the longest run closes."""
    section = []
    for (benchmark, model), runs in sorted(curves.items()):
        paper_values, headline, unit = paper_and_headline(benchmark, model, paper, store)
        figure = slot(f"budget_{benchmark}_{model}.png")
        title = budget_title(benchmark, model)
        drawn = plot_budget(runs, paper_values, headline, title, unit, figure.path)
        closes = {}
        for metric in METRICS:
            point = budget_point(runs, metric, headline.get(metric))
            if point is not None and paper_values.get(metric) is not None:
                closes[metric] = (point.factor, point.closes(paper_values[metric]))
        section.append({"benchmark": benchmark, "model": model, "title": title, "unit": unit,
                        "runs": runs,
                        "paper": paper_values, "headline": headline, "closes": closes,
                        "src": figure.src if drawn else None})
    return section
