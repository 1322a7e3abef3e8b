"""The paper's Tables 1-4 cell by cell (paper, ours or why not, their relative difference coloured
by size; each paper cell's provenance and, where its source took the best of K otherwise than our
headline, ours under that protocol: `pipeline.report.provenance`), each table's summary, and the
headline metrics files `dvc metrics show` prints.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, TYPE_CHECKING

import numpy as np

from pipeline.benchmarks.registry import long_term
from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.model_list import YNET
from pipeline.models import ModelEntry
from pipeline.report.common import (LONG_TERM_KE, LONG_TERM_TF, METRICS, PIPELINE_MODELS,
                                    relative_difference)
from pipeline.report.lookups import Absent, Measured, MetricsStore, lookup, lookup_grid
from pipeline.report.provenance import (PROTOCOLS, BudgetPoint, CellSource, SourceNote, Why,
                                        difference_lines, glance_counts, long_term_score, mean_of,
                                        seed_range,
                                        short_term_score, source_notes, test_selected_score,
                                        under_protocol, why_differs, with_provenance)
from pipeline.report.budget import BudgetRun, budget_point
from pipeline.report.series import Series
from pipeline.report.short_term_seeds import ShortTermSeeds

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.report import ReportParams


@dataclass(frozen=True)
class Cell:
    """One table cell: the paper's value, ours (or why not), their relative difference. Where the
    paper's number was taken under another best-of-K protocol than our headline, ours under that
    protocol too, and the difference and colour are that one's."""
    paper: float | None
    ours: Measured | Absent | None  # None: a model this pipeline does not train
    diff: float | None = None  # the compared difference: under the cell's protocol where scored
    band: str = ""  # close | mid | far, for measured cells
    joint: Measured | None = None  # ADE/FDE both from the best-ADE sample, where recorded
    source: CellSource | None = None  # who measured the paper's number, and how
    own: Measured | Absent | None = None  # ours under the cell's protocol; None: the headline's
    headline_diff: float | None = None  # ours (headline protocol) against the paper
    why: Why | None = None  # for a compared cell: a match, or the cause of the difference
    name: str = ""  # "PECNet* (K = 20) ADE": how the lists under a table name the cell
    mark: str = ""  # its source's footnote mark: q1, q2 (quoted), a1 (the Y-net authors')
    test_selected: Measured | Absent | None = None  # compat: upstream's epochs chosen on test
    reason_mark: str = ""  # an absent cell's: its reason's mark in the list under the table

    @property
    def kind(self) -> str:
        if self.ours is None:
            return "paper-only"
        if isinstance(self.ours, Measured):
            if self.ours.mismatch:
                return "mismatch"
            return "measured" if self.paper is not None else "ours-only"  # a registered model
        return "absent"


@dataclass(frozen=True)
class Column:
    group: str
    label: str
    sub: str = ""
    key: str = ""  # its file name under reports/headline: model names as the model list spells them


@dataclass(frozen=True)
class Row:
    label: str
    cells: tuple[Cell, ...]


@dataclass(frozen=True)
class Table:
    key: str
    number: int
    title: str
    caption: str
    unit: str
    decimals: int
    columns: tuple[Column, ...]
    rows: tuple[Row, ...]
    paper_decimals: int = 2  # as the paper prints them
    sources: tuple[SourceNote, ...] = ()  # the footnotes of the cells' marks
    protocols: tuple[str, ...] = ()  # the protocols of its paper cells, for the caption
    differences: tuple[tuple[str, str, tuple[str, ...]], ...] = ()  # (cause, detail, cells)
    absent_reasons: tuple[tuple[str, str], ...] = ()  # (mark, why not measured), once each

    def cells(self) -> list[Cell]:
        return [cell for row in self.rows for cell in row.cells]

    def groups(self) -> list[tuple[str, int]]:
        """Header groups with their column spans (consecutive columns of one group merge)."""
        out: list[tuple[str, int]] = []
        for c in self.columns:
            if out and out[-1][0] == c.group:
                out[-1] = (c.group, out[-1][1] + 1)
            else:
                out.append((c.group, 1))
        return out

    @property
    def has_sub(self) -> bool:
        return any(c.sub for c in self.columns)


def band(diff: float | None, params: ReportParams) -> str:
    if diff is None:
        return ""
    size = abs(diff)
    return "close" if size <= params.close else "mid" if size <= params.far else "far"


def compare(paper: float | None, ours: Measured | Absent | None, params: ReportParams,
            joint: Measured | Absent | None = None) -> Cell:
    if not isinstance(ours, Measured) or ours.mismatch:  # nothing, or not comparable
        return Cell(paper, ours)
    diff = relative_difference(ours.mean, paper)
    return Cell(paper, ours, diff, band(diff, params), joint if isinstance(joint, Measured) else None,
                headline_diff=diff)


def paper_cell(paper: float | None, ours: Measured | Absent | None, params: ReportParams,
               source: CellSource | None, name: str, own: Measured | Absent | None = None,
               joint: Measured | Absent | None = None,
               seeds: tuple[float, float, int] | None = None,
               test_selected: Measured | Absent | None = None,
               budget: BudgetPoint | None = None) -> Cell:
    """`compare` on our headline, then under the cell's own protocol (`own`: the difference and
    colour follow it where it was scored) and whether the cell matches or why not (`seeds`: our
    range over training seeds, where trained; `test_selected`: ours with upstream's epochs
    selected on the test set, a compat diagnostic that only names a cause; `budget`: the cell's
    budget-curve point, the longest training against 1x, which may name the cause)."""
    cell = replace(compare(paper, ours, params, joint), source=source, name=name,
                   test_selected=test_selected)
    if cell.kind != "measured":
        return cell
    own_diff = relative_difference(own.mean, paper) if isinstance(own, Measured) else None
    diff = cell.diff if own_diff is None else own_diff
    selected_diff = (relative_difference(test_selected.mean, paper)
                     if isinstance(test_selected, Measured) else None)
    why = why_differs(paper, cell.diff, own_diff, params.far, source, seeds, selected_diff, budget)
    return replace(cell, own=own, diff=diff, band=band(diff, params), why=why)


def annotated(table: Table) -> Table:
    """`table` with its cells' source marks, the footnotes, its protocols and the list of why
    cells differ."""
    labelled = [(column.group if column.label in ("ADE", "FDE") else column.label, cell)
                for row in table.rows for column, cell in zip(table.columns, row.cells)]
    notes, marks = source_notes([(label, cell.source) for label, cell in labelled if cell.source])
    reasons = absent_reason_marks(table.cells())
    rows = tuple(Row(row.label, tuple(replace(cell, mark=marks.get(cell.source, ""),
                                              reason_mark=reasons.get(absent_reason(cell), ""))
                                      for cell in row.cells)) for row in table.rows)
    protocols = tuple(p for p in PROTOCOLS if any(cell.source and cell.source.protocol == p
                                                  for _, cell in labelled))
    differences = difference_lines([(cell.name, cell.why) for _, cell in labelled if cell.why])
    return replace(table, rows=rows, sources=notes, protocols=protocols, differences=differences,
                   absent_reasons=tuple((mark, reason) for reason, mark in reasons.items()))


def absent_reason(cell: Cell) -> str:
    return cell.ours.reason if isinstance(cell.ours, Absent) else ""


def absent_reason_marks(cells: list[Cell]) -> dict[str, str]:
    """Each distinct reason of the table's absent cells, in reading order, marked n1, n2 ...: the
    cells show the mark and the table lists each reason once."""
    reasons = dict.fromkeys(absent_reason(cell) for cell in cells if absent_reason(cell))
    return {reason: f"n{i}" for i, reason in enumerate(reasons, 1)}


def budget_for(budgets: Mapping[tuple[str, str], list[BudgetRun]] | None, benchmark: str,
               model: str, metric: str, ours: Measured | Absent | None) -> BudgetPoint | None:
    """The cell's budget point: its curve's longest run against the curve's 1x (or our headline)."""
    runs = (budgets or {}).get((benchmark, model))
    headline = ours.mean if isinstance(ours, Measured) else None
    return budget_point(runs, metric, headline) if runs else None


def ours_if_trained(model: str, find) -> Measured | Absent | None:
    """`find()` for a model this pipeline runs; None (paper only) for any other."""
    return find() if model in PIPELINE_MODELS else None


def expected(profile: str | None, **settings: int) -> dict[str, Any]:
    """The settings a cell is for: the profile the report's stages ran under (when known) and the
    table's K values."""
    return ({"profile": profile} if profile else {}) | settings


def table_sdd_short(spec: Mapping, store: MetricsStore, params: ReportParams,
                    profile: str | None = None, seeds: ShortTermSeeds | None = None,
                    budgets: Mapping[tuple[str, str], list[BudgetRun]] | None = None) -> Table:
    """Table 1: short-term SDD, K = 20 and K = 5 groups; `seeds`: the baselines' runs over
    training seeds (a cell's range for the cause "seed spread")."""
    cols = spec["columns"]
    rows = []
    for metric in METRICS:
        cells = []
        for c in cols:
            path = ("models", c["model"], f"k{c['k']}", metric)
            ours = ours_if_trained(c["model"], lambda p=path: lookup(store, "short_term/sdd.json", p,
                                                                     expect=expected(profile)))
            source = c["cells"][metric]
            own = under_protocol(source.protocol, metric, lambda key, c=c: short_term_score(
                store, "sdd", c["model"], key, c["k"]))
            spread = seeds.range("sdd", c["model"], c["k"], metric) if seeds else None
            budget = budget_for(budgets, "sdd", c["model"], metric, ours) if c["k"] == 20 else None
            cells.append(paper_cell(c[metric], ours, params, source,
                                    f"{c['label']} (K = {c['k']}) {metric.upper()}", own,
                                    seeds=spread, budget=budget))
        rows.append(Row(metric.upper(), tuple(cells)))
    return Table("sdd_short", spec["number"], spec["title"],
                 "t_p = 3.2 s, t_f = 4.8 s (TrajNet split). Ours: metrics/short_term/sdd.json; "
                 "under a cell's own protocol: metrics/beyond/short_term.json (the stored K = 20 "
                 "predictions).",
                 spec["unit"], 2,
                 tuple(Column(f"K = {c['k']}", c["label"], key=f"{c['model']}_k{c['k']}")
                       for c in cols), tuple(rows))


def average_cell(paper: float | None, scene_cells: list[Cell], params: ReportParams,
                 source: CellSource | None = None, name: str = "",
                 seeds: tuple[float, float, int] | None = None) -> Cell:
    """The AVG row: mean of our five scene means, only when all five were measured (and so under
    the cell's own protocol)."""
    if any(cell.ours is None for cell in scene_cells):
        return Cell(paper, None, source=source, name=name)
    absent = [cell.ours for cell in scene_cells if isinstance(cell.ours, Absent)]
    if absent:
        return Cell(paper, Absent(f"average needs all {len(scene_cells)} scenes; {absent[0].reason}",
                                  absent[0].kind), source=source, name=name)
    means = [cell.ours.mean for cell in scene_cells]
    ours = Measured(float(np.mean(means)), None, None, "mean of the scene means",
                    f"mean of {len(means)} scenes")
    own = mean_of([cell.own for cell in scene_cells], "mean of the scenes' values")
    selected = mean_of([cell.test_selected for cell in scene_cells],
                       "mean of the scenes' test-selected values (compat)")
    return paper_cell(paper, ours, params, source, name, own, seeds=seeds, test_selected=selected)


def table_eth_ucy(spec: Mapping, store: MetricsStore, params: ReportParams,
                  profile: str | None = None, seeds: ShortTermSeeds | None = None,
                  budgets: Mapping[tuple[str, str], list[BudgetRun]] | None = None) -> Table:
    """Table 2: ETH/UCY per scene (rows) and model x metric (columns), plus the average;
    `seeds`: the baselines' runs over training seeds, per fold and for the average."""
    columns, per_scene = [], {scene: [] for scene in spec["scenes"]}
    for m in spec["models"]:
        for metric in METRICS:
            columns.append(Column(m["label"], metric.upper(), key=m["model"]))
            for scene in spec["scenes"]:
                rel = f"short_term/ethucy_{scene}.json"
                ours = ours_if_trained(m["model"], lambda r=rel, mo=m["model"], me=metric:
                                       lookup(store, r, ("models", mo, me), expect=expected(profile)))
                source = m["cells"][metric][scene]
                own = under_protocol(source.protocol, metric, lambda key, s=scene, mo=m["model"]:
                                     short_term_score(store, s, mo, key, 20))
                selected = test_selected_score(store, scene, m["model"], metric, source.protocol)
                spread = seeds.range(scene, m["model"], 20, metric) if seeds else None
                per_scene[scene].append(paper_cell(
                    m[metric][scene], ours, params, source,
                    f"{m['label']} {metric.upper()} {spec['scene_labels'][scene]}", own,
                    seeds=spread, test_selected=selected,
                    budget=budget_for(budgets, scene, m["model"], metric, ours)))
    rows = [Row(spec["scene_labels"][s], tuple(cells)) for s, cells in per_scene.items()]
    in_column_order = [(m, metric) for m in spec["models"] for metric in METRICS]
    avg = [average_cell(m[metric].get("avg"), [per_scene[s][i] for s in spec["scenes"]], params,
                        m["cells"][metric]["avg"], f"{m['label']} {metric.upper()} AVG",
                        seeds.average(m["model"], metric) if seeds else None)
           for i, (m, metric) in enumerate(in_column_order)]
    rows.append(Row("AVG", tuple(avg)))
    return Table("eth_ucy", spec["number"], spec["title"],
                 "K = 20, leave one scene out. Ours: metrics/short_term/ethucy_<scene>.json; "
                 "under a cell's own protocol: metrics/beyond/short_term.json (the stored "
                 "predictions); our AVG is the mean of our five scene means. PECNet retrained with "
                 "upstream's epochs selected on test, on the folds the compat switch "
                 "short_term_pecnet_test_selection.folds lists (none by default; never shown as "
                 "ours, only named as a cause): metrics/short_term/pecnet_test_selection/<scene>.json.",
                 spec["unit"], 3, tuple(columns), tuple(rows))


def find_long_term(store: MetricsStore, c: Mapping, metric: str,
                   profile: str | None = None) -> Measured | Absent:
    """Table 3's cell: baselines where their benchmark keeps them (SDD: their t_f = 30 file; inD:
    ind_benchmark.json), Y-net by K_a from the benchmark's `metrics_file`."""
    benchmark = long_term(c["dataset"])
    model, k_a, rel = c["model"], c["k_a"], benchmark.metrics_file
    if model != YNET:
        baseline_rel, keys = benchmark.baseline_metrics(model, LONG_TERM_TF)
        return lookup(store, baseline_rel, (*keys, metric), t_f=LONG_TERM_TF,
                      expect={"k": LONG_TERM_KE})
    if k_a == 1:
        return lookup(store, rel, ("main", metric), t_f=LONG_TERM_TF,
                      expect=expected(profile, k_e=LONG_TERM_KE, k_a=1))
    return lookup_grid(store, rel, "ka_grid", {"k_e": LONG_TERM_KE, "k_a": k_a}, metric,
                       t_f=LONG_TERM_TF, expect=expected(profile))


def find_long_term_joint(store: MetricsStore, c: Mapping, metric: str,
                         profile: str | None = None) -> Measured | Absent:
    """The joint variant (ADE and FDE from one sample), shown under ours where recorded."""
    return find_long_term(store, c, f"{metric}_joint", profile)


def with_registered(spec: Mapping, registered: Mapping[str, ModelEntry]) -> dict:
    """Table 3's spec with a column per registered model after the paper's SDD columns (the
    benchmark they run on): no paper value (the paper never ran it), ours from
    `baselines/<name>_tf30.json` as for a baseline."""
    cols = list(spec["columns"])
    key = SDD_LONG_TERM.paper_key
    at = max((i + 1 for i, c in enumerate(cols) if c["dataset"] == key), default=len(cols))
    added = [{"dataset": key, "model": name, "label": entry.label, "k_a": 1, "ade": None,
              "fde": None, "registered": True} for name, entry in registered.items()]
    return {**spec, "columns": cols[:at] + added + cols[at:]}


def table_sdd_long(spec: Mapping, store: MetricsStore, params: ReportParams,
                   profile: str | None = None,
                   budgets: Mapping[tuple[str, str], list[BudgetRun]] | None = None) -> Table:
    """Table 3: long term (t_f = 30 s), SDD and inD, baselines and Y-net at K_a = 1, 2, 5, and any
    registered model (`with_registered`)."""
    cols = spec["columns"]
    rows = []
    for metric in METRICS:
        cells = []
        for c in cols:
            def find(c=c):
                return find_long_term(store, c, metric, profile)
            ours = find() if c.get("registered") else ours_if_trained(c["model"], find)
            source = (c.get("cells") or {}).get(metric)  # a registered model has no paper cell
            own = under_protocol(source.protocol, metric, lambda key, c=c: long_term_score(
                store, c["dataset"], c["model"], c["k_a"], key, LONG_TERM_TF)) if source else None
            benchmark = long_term(c["dataset"])
            studied = bool(benchmark.study_key) and c["k_a"] == 1  # seeds, test selection, budget
            seeds = seed_range(store, c["model"], LONG_TERM_TF, metric) if studied else None
            selected = (test_selected_score(store, f"tf{LONG_TERM_TF}", c["model"], metric,
                                            source.protocol) if studied and source else None)
            cells.append(paper_cell(
                c[metric], ours, params, source,
                f"{benchmark.label} {c['label']} (K_a = {c['k_a']}) {metric.upper()}", own,
                find_long_term_joint(store, c, metric, profile), seeds, selected,
                budget_for(budgets, benchmark.study_key, c["model"], metric, ours)
                if studied else None))
        rows.append(Row(metric.upper(), tuple(cells)))
    columns = tuple(Column(long_term(c["dataset"]).label, c["label"], f"K_a = {c['k_a']}",
                           f"{c['dataset']}_{c['model']}_ka{c['k_a']}") for c in cols)
    registered = [c["label"] for c in cols if c.get("registered")]
    return Table("sdd_long", spec["number"], spec["title"],
                 "t_f = 30 s, t_p = 5 s, K_e = 20 (baselines K = 20). Ours: SDD Y-net from "
                 "metrics/ynet_eval.json (main; ka_grid for K_a > 1), SDD baselines from "
                 "metrics/baselines/<model>_tf30.json, inD from metrics/ind_benchmark.json; under "
                 "a cell's own protocol, where it is not the headline's: metrics/beyond/"
                 "long_term.json and ind.json (the stored predictions, K_a = 1). Our spread over "
                 "training seeds: metrics/baseline_seed_spread.json."
                 + (f" {', '.join(registered)}: registered in params.yaml `models` (README \"Your "
                    "model here\"), from metrics/baselines/<model>_tf30.json; the paper has no "
                    "value for them (\u2014)." if registered else ""),
                 spec["unit"], 2, columns, tuple(rows))


def table_ttst(spec: Mapping, store: MetricsStore, params: ReportParams,
               profile: str | None = None) -> Table:
    """Table 4: Y-net with and without TTST and CWS, SDD and inD."""
    cols = spec["columns"]
    setting = expected(profile, k_e=LONG_TERM_KE, k_a=1)  # the table's: main setting, K_a = 1
    rows = []
    for metric in METRICS:
        cells = []
        for c in cols:
            benchmark, name = long_term(c["dataset"]), c["ablation"]
            rel = benchmark.metrics_file
            ours = lookup(store, rel, ("ablation", name, metric), t_f=LONG_TERM_TF, expect=setting)
            joint = lookup(store, rel, ("ablation", name, f"{metric}_joint"), t_f=LONG_TERM_TF,
                           expect=setting)
            seeds = (seed_range(store, YNET, LONG_TERM_TF, metric)  # seeds: the main setting's
                     if benchmark.study_key and name == "ttst_cws" else None)
            cells.append(paper_cell(c[metric], ours, params, c["cells"][metric],
                                    f"{benchmark.label} {name} {metric.upper()}",
                                    joint=joint, seeds=seeds))
        rows.append(Row(metric.upper(), tuple(cells)))
    tick = {True: "\u2713", False: "\u2717"}
    columns = tuple(Column(long_term(c["dataset"]).label,
                           f"TTST {tick[c['ttst']]}  CWS {tick[c['cws']]}",
                           key=f"{c['dataset']}_{c['model']}_{c['ablation']}") for c in cols)
    return Table("ttst", spec["number"], spec["title"],
                 "t_f = 30 s, K_e = 20, K_a = 1. Ours: metrics/ynet_eval.json and metrics/ind_benchmark.json, "
                 "key ablation.<none|cws|ttst_cws>.",
                 spec["unit"], 2, columns, tuple(rows))


TABLE_BUILDERS = {"sdd_short": table_sdd_short, "eth_ucy": table_eth_ucy,
                  "sdd_long": table_sdd_long, "ttst": table_ttst}
SHORT_TERM_TABLES = ("sdd_short", "eth_ucy")  # their baselines' seeds: studies/short_term_seeds
BUDGET_TABLES = ("sdd_short", "eth_ucy", "sdd_long")  # budget curves: studies/budget


def build_tables(paper: Mapping, store: MetricsStore, params: ReportParams,
                 profile: str | None = None,
                 registered: Mapping[str, ModelEntry] | None = None,
                 seeds: ShortTermSeeds | None = None,
                 budgets: Mapping[tuple[str, str], list[BudgetRun]] | None = None) -> list[Table]:
    """The paper's four tables with ours beside them; `profile`: the one the stages ran under (a
    file of another profile is shown as a mismatch, not compared); `registered`: the models of
    params.yaml `models`, each a column of Table 3 (`with_registered`). Table 4 is Y-net's own
    TTST / CWS ablation: no other model has those switches, so it has no column for them.
    `seeds`: Tables 1-2's baselines over training seeds; `budgets`: the budget curves' runs."""
    paper = with_provenance(paper)
    specs = {**paper, "sdd_long": with_registered(paper["sdd_long"], registered or {})}
    tables = [annotated(build(specs[key], store, params, profile,
                              **({"seeds": seeds} if key in SHORT_TERM_TABLES else {}),
                              **({"budgets": budgets} if key in BUDGET_TABLES else {})))
              for key, build in TABLE_BUILDERS.items()]
    return sorted(tables, key=lambda t: t.number)


@dataclass(frozen=True)
class TableSummary:
    table: Table
    counts: Mapping[str, int]  # close, mid, far, mismatch, absent, paper-only, ours-only
    reasons: tuple[str, ...]  # distinct reasons of the absent cells
    verdicts: Mapping[str, int] = field(default_factory=dict)  # match, then per cause (`why`)


def summarize(table: Table) -> TableSummary:
    """What a reviewer needs first: how many of the table's numbers we reproduce (by colour, and
    by whether they match under the headline protocol or why not), and gaps."""
    counts = {key: 0 for key in ("close", "mid", "far", "mismatch", "absent", "paper-only",
                                 "ours-only")}
    reasons: list[str] = []
    for cell in table.cells():
        key = cell.band or cell.kind
        counts[key] = counts.get(key, 0) + 1
        if isinstance(cell.ours, Absent) and cell.ours.reason not in reasons:
            reasons.append(cell.ours.reason)
    verdicts = glance_counts([cell.why.verdict for cell in table.cells() if cell.why])
    return TableSummary(table, counts, tuple(reasons), verdicts)


def headline_metrics(tables: Iterable[Table], horizons: Iterable[Series]) -> dict[str, dict[str, float]]:
    """The numbers `dvc metrics show` prints: {"<table>/<column>.json": {"ade": .., "fde": ..}}.

    One small file per model (table column) with our measured ADE and FDE, so the DVC table has
    two value columns and a row per model, named by the column's `key` (the model list's spelling:
    `sgan_k20`, `sdd_ynet_ka2`, `sdd_ynet_ttst_cws`); tables of one row per metric give that row's
    cells, the ETH/UCY table its AVG row. Y-net's horizon points are added as
    `figure4_horizons/ynet_tf<t>`.
    Unmeasured cells are left out; a registered model's (ours only) are in.
    """
    files: dict[str, dict[str, float]] = {}
    for table in tables:
        folder = f"table{table.number}_{table.key}"
        metric_rows = {row.label.lower(): row for row in table.rows if row.label.lower() in METRICS}
        keys = [column.key for column in table.columns]
        if not all(keys) or (metric_rows and len(set(keys)) < len(keys)):
            raise ValueError(f"table {table.number}: each column needs a headline file name of its "
                             f"own, got {keys}")
        if metric_rows:  # rows ADE, FDE; one column per model
            for i, column in enumerate(table.columns):
                for metric, row in metric_rows.items():
                    cell = row.cells[i]
                    if cell.kind in ("measured", "ours-only"):
                        name = f"{folder}/{column.key}.json"
                        files.setdefault(name, {})[metric] = cell.ours.mean
        else:  # rows per scene and AVG; columns model x metric
            average = next((row for row in table.rows if row.label == "AVG"), None)
            for column, cell in zip(table.columns, average.cells if average else ()):
                if cell.kind == "measured":
                    name = f"{folder}/{column.key}_avg.json"
                    files.setdefault(name, {})[column.label.lower()] = cell.ours.mean
    for series in horizons:
        if series.key == YNET:
            for t_f, value in series.points:
                files[f"figure4_horizons/{YNET}_tf{t_f}.json"] = {"ade": value.mean}
    return files
