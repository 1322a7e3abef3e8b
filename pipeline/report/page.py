"""The report: the HTML page a reviewer reads, the paper's numbers beside ours (stage `report`).

Reads every metrics file that exists (each one defensively: a missing or malformed file becomes an
explained absence, never a blank or a made-up number), the paper's values
(`pipeline/report/paper_values.yaml`), the params and the data manifests, and writes

- `reports/index.html` (jinja2, no scripts, no network): the paper's claims in words, each with
  ours and a verdict (`pipeline.report.claims`); Tables 1-4 cell by cell (paper, ours as
  mean and spread over evaluation rounds, relative difference coloured by size; every model
  registered in params.yaml `models`, README "Your model here", as a Table 3 column of its own,
  ours only: the paper has no value for it; each paper cell marked with who measured it and, where
  its source took the best of K otherwise than our headline, ours under that protocol beside it and
  compared, and why a cell differs: `pipeline.report.provenance`), the horizon and
  K_a figures, the training-seed spread (baselines and Y-net), the qualitative figure, "Beyond the paper's
  tables" (`pipeline.report.beyond`: the metrics of stages `score_predictions` and
  `score_short_term_predictions`: long-term SDD, the short-term benchmarks, inD), the data audit and
  counts, segmentation scores, provenance;
- its figures as PNG files (matplotlib, Agg) in `reports/figures/report/`;
- the figure series as JSON for `dvc plots` in `reports/plots/`;
- a section "Predictions, step by step" showing the animations stage `animations` wrote (its
  `index.json` in `--animations`; linked where they are, not copied), or why there are none.

Everything is written to a temporary path and renamed, so an interrupted run leaves the previous
report intact.

Metrics read (paths relative to `--metrics`; a record {"status": ..., "reason": ...} in place of
results is shown as its reason):
- `ynet_eval.json`: {"profile", "t_f", "rounds", "main": {"ade": {"mean", "std"}, "fde", "ade_joint",
  "fde_joint"}, "ablation": {"none"|"cws"|"ttst_cws": {...}}, "ka_grid": [{"k_e", "k_a", "ade", "fde"}]}
- `ynet_horizons/tf<H>.json`: {"main": {...}} or {"not_run_reason": "..."} (t_f = 30: ynet_eval.json);
  `baselines/<model>_tf<H>.json`: {"ade": {"mean", "std"}, "fde", ..., "rounds", "k", "horizon"};
  `baselines/pecnet_ka.json`: [{"k_a", "k", "ade": {"mean", "std"}, "fde"}]
- `baseline_seed_spread.json` (`pipeline.harness.seed_spread`): {"extra_seeds", "ynet_extra_seeds",
  "entries": [{"model", "horizon", "evaluation", "over_training_seeds": {"ade": {"mean", "std"}, ...},
  "main_round_std": {"ade", "fde"}, "per_seed": [{"seed", "ade", "fde", "best_epoch",
  "best_val_ade"}]}]}; an entry with "not_run_reason" (Y-net where the profile trains no extra seed)
  has no "over_training_seeds"
- `short_term/sdd.json`: {"rounds", "models": {<model>: {"k20"|"k5": {"ade": {"mean", "std"}, "fde"}}}}
- `short_term/ethucy_<scene>.json`: {"rounds", "models": {<model>: {"ade": {...}, "fde": {...}}}}
- `ind_benchmark.json`: as `ynet_eval.json` plus "baselines": {<model>: {"ade", "fde"}} (or a status record)
- `beyond/long_term.json`: {"thresholds", "tables": {<table>: {"t_f", "models": {<model>: {"rounds",
  "metrics": {<metric>: {"mean", "std"}}, "ground_truth": {<metric>: value}} or {"not_run_reason"}}}}}
  (`pipeline.harness.stored_scores`); `beyond/short_term.json` and `beyond/ind.json`: {"thresholds",
  "benchmarks": {<name>: {"unit", "scene_masks", "models": {<model>: the same model record}}}}
- `segmentation.json`: {"miou", "iou": {class: iou}}; the data files `windows.json`,
  `data_audit.json`, `horizon_windows.json`, `chain_bias.json`, and `sdd_sources.json` (stage
  `tracks`: {"copy": {"provided", "path"}, "videos": {<video>: {"origin", "file", "sha256",
  "pinned", "rows"}}, "reference_images": {<file>: {"sha256", "pinned"}}, "totals"}).
A value is a number (measured once) or {"mean", "std", ...} over seeded rounds
(`pipeline.harness.metrics.seeded_rounds`, the one layout every scoring stage writes).

The stage (`pipeline.stages.report`) calls `write_report`.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import importlib.metadata
import json
import os
import platform
import re
import subprocess
import sys
from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from pipeline.config import ReportParams
from pipeline.models import ModelEntry
from pipeline.report.beyond import beyond_section
from pipeline.report import horizons
from pipeline.report.compat import compat_rows
from pipeline.report.diagnostics import HEADLINE, TITLE as DIAGNOSTICS_TITLE, diagnostics_from_store
from pipeline.report.claims import claims_section
from pipeline.report.lookups import (Absent, Measured, MetricsStore, as_measured, is_number,
                                     load_metrics, lookup, lookup_grid)
from pipeline.report.provenance import (PROTOCOL_KEYS, PROTOCOL_LABELS, PROTOCOLS,
                                        SEED_SPREAD_FILE, CellSource, SourceNote, Why,
                                        difference_lines, glance_counts, load_paper_values,
                                        long_term_score, mean_of, seed_range, short_term_score,
                                        source_notes, test_selected_score, under_protocol,
                                        why_differs, with_provenance)
from pipeline.io import atomic_dir, write_text
from pipeline.splits import TEST_VIDEOS, TRAIN_VIDEOS, split_of

TEMPLATE = Path(__file__).parent / "templates" / "report.html.j2"
METRICS = ("ade", "fde")
# The paper's models this pipeline trains or evaluates with stages of their own; any other model
# of the paper is "paper only". Every model registered in params.yaml `models` (README "Your model
# here"; constant velocity is one) follows them: `horizon_models`, `model_colours`.
PIPELINE_MODELS = frozenset({"ynet", "sgan", "pecnet", "rpecnet"})
HORIZON_MODELS = (("ynet", "Y-net"), ("pecnet", "PECNet"), ("rpecnet", "R-PECNet"),
                  ("sgan", "S-GAN"))
MODEL_COLOURS = {"ynet": "#d62728", "pecnet": "#1f77b4", "rpecnet": "#9467bd", "sgan": "#2ca02c"}
DATASETS = {"sdd": "SDD", "ind": "inD"}
LONG_TERM_TF = 30  # the long-term tables' horizon (s)
LONG_TERM_KE = 20  # and their K_e (baselines: K)
QUALITATIVE_KEYS = ("scene_image", "past", "future", "goal_heatmap", "sampled_goals",
                    "trajectory_heatmap", "predictions")


def horizon_models(registered: Mapping[str, ModelEntry]) -> tuple[tuple[str, str], ...]:
    """(key, label) of every model with a series per horizon: the paper's, then the registered."""
    return (*HORIZON_MODELS, *((name, entry.label) for name, entry in registered.items()))


def model_colours(registered: Mapping[str, ModelEntry]) -> dict[str, str]:
    return {**MODEL_COLOURS, **{name: entry.colour for name, entry in registered.items()}}


# ---------------------------------------------------------------------------------------------
# Comparison tables


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


def relative_difference(ours: float, paper: float | None) -> float | None:
    """(ours - paper) / paper: signed, so 'lower than the paper' reads as negative."""
    if paper is None or paper == 0:
        return None
    return (ours - paper) / paper


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
               test_selected: Measured | Absent | None = None) -> Cell:
    """`compare` on our headline, then under the cell's own protocol (`own`: the difference and
    colour follow it where it was scored) and whether the cell matches or why not (`seeds`: our
    range over training seeds, where trained; `test_selected`: ours with upstream's epochs
    selected on the test set, a compat diagnostic that only names a cause)."""
    cell = replace(compare(paper, ours, params, joint), source=source, name=name,
                   test_selected=test_selected)
    if cell.kind != "measured":
        return cell
    own_diff = relative_difference(own.mean, paper) if isinstance(own, Measured) else None
    diff = cell.diff if own_diff is None else own_diff
    selected_diff = (relative_difference(test_selected.mean, paper)
                     if isinstance(test_selected, Measured) else None)
    why = why_differs(paper, cell.diff, own_diff, params.far, source, seeds, selected_diff)
    return replace(cell, own=own, diff=diff, band=band(diff, params), why=why)


def annotated(table: Table) -> Table:
    """`table` with its cells' source marks, the footnotes, its protocols and the list of why
    cells differ."""
    labelled = [(column.group if column.label in ("ADE", "FDE") else column.label, cell)
                for row in table.rows for column, cell in zip(table.columns, row.cells)]
    notes, marks = source_notes([(label, cell.source) for label, cell in labelled if cell.source])
    rows = tuple(Row(row.label, tuple(replace(cell, mark=marks.get(cell.source, ""))
                                      for cell in row.cells)) for row in table.rows)
    protocols = tuple(p for p in PROTOCOLS if any(cell.source and cell.source.protocol == p
                                                  for _, cell in labelled))
    differences = difference_lines([(cell.name, cell.why) for _, cell in labelled if cell.why])
    return replace(table, rows=rows, sources=notes, protocols=protocols, differences=differences)


def ours_if_trained(model: str, find) -> Measured | Absent | None:
    """`find()` for a model this pipeline runs; None (paper only) for any other."""
    return find() if model in PIPELINE_MODELS else None


def expected(profile: str | None, **settings: int) -> dict[str, Any]:
    """The settings a cell is for: the profile the report's stages ran under (when known) and the
    table's K values."""
    return ({"profile": profile} if profile else {}) | settings


def table_sdd_short(spec: Mapping, store: MetricsStore, params: ReportParams,
                    profile: str | None = None) -> Table:
    """Table 1: short-term SDD, K = 20 and K = 5 groups."""
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
            cells.append(paper_cell(c[metric], ours, params, source,
                                    f"{c['label']} (K = {c['k']}) {metric.upper()}", own))
        rows.append(Row(metric.upper(), tuple(cells)))
    return Table("sdd_short", spec["number"], spec["title"],
                 "t_p = 3.2 s, t_f = 4.8 s (TrajNet split). Ours: metrics/short_term/sdd.json; "
                 "under a cell's own protocol: metrics/beyond/short_term.json (the stored K = 20 "
                 "predictions).",
                 spec["unit"], 2, tuple(Column(f"K = {c['k']}", c["label"]) for c in cols), tuple(rows))


def average_cell(paper: float | None, scene_cells: list[Cell], params: ReportParams,
                 source: CellSource | None = None, name: str = "") -> Cell:
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
    return paper_cell(paper, ours, params, source, name, own, test_selected=selected)


def table_eth_ucy(spec: Mapping, store: MetricsStore, params: ReportParams,
                  profile: str | None = None) -> Table:
    """Table 2: ETH/UCY per scene (rows) and model x metric (columns), plus the average."""
    columns, per_scene = [], {scene: [] for scene in spec["scenes"]}
    for m in spec["models"]:
        for metric in METRICS:
            columns.append(Column(m["label"], metric.upper()))
            for scene in spec["scenes"]:
                rel = f"short_term/ethucy_{scene}.json"
                ours = ours_if_trained(m["model"], lambda r=rel, mo=m["model"], me=metric:
                                       lookup(store, r, ("models", mo, me), expect=expected(profile)))
                source = m["cells"][metric][scene]
                own = under_protocol(source.protocol, metric, lambda key, s=scene, mo=m["model"]:
                                     short_term_score(store, s, mo, key, 20))
                selected = test_selected_score(store, scene, m["model"], metric, source.protocol)
                per_scene[scene].append(paper_cell(
                    m[metric][scene], ours, params, source,
                    f"{m['label']} {metric.upper()} {spec['scene_labels'][scene]}", own,
                    test_selected=selected))
    rows = [Row(spec["scene_labels"][s], tuple(cells)) for s, cells in per_scene.items()]
    in_column_order = [(m, metric) for m in spec["models"] for metric in METRICS]
    avg = [average_cell(m[metric].get("avg"), [per_scene[s][i] for s in spec["scenes"]], params,
                        m["cells"][metric]["avg"], f"{m['label']} {metric.upper()} AVG")
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


def long_term_file(dataset: str) -> str:
    return "ynet_eval.json" if dataset == "sdd" else f"{dataset}_benchmark.json"


def find_long_term(store: MetricsStore, c: Mapping, metric: str,
                   profile: str | None = None) -> Measured | Absent:
    """Table 3's cell: baselines from their t_f = 30 file (SDD) or ind_benchmark.json, Y-net by K_a."""
    model, k_a, rel = c["model"], c["k_a"], long_term_file(c["dataset"])
    if model != "ynet":
        if c["dataset"] == "sdd":
            return lookup(store, f"baselines/{model}_tf{LONG_TERM_TF}.json", (metric,),
                          t_f=LONG_TERM_TF, expect={"k": LONG_TERM_KE})
        return lookup(store, rel, ("baselines", model, metric), t_f=LONG_TERM_TF,
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
    """Table 3's spec with a column per registered model after the paper's SDD columns: no paper
    value (the paper never ran it), ours from `baselines/<name>_tf30.json` as for a baseline."""
    cols = list(spec["columns"])
    at = max((i + 1 for i, c in enumerate(cols) if c["dataset"] == "sdd"), default=len(cols))
    added = [{"dataset": "sdd", "model": name, "label": entry.label, "k_a": 1, "ade": None,
              "fde": None, "registered": True} for name, entry in registered.items()]
    return {**spec, "columns": cols[:at] + added + cols[at:]}


def table_sdd_long(spec: Mapping, store: MetricsStore, params: ReportParams,
                   profile: str | None = None) -> Table:
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
            sdd = (c["dataset"], c["k_a"]) == ("sdd", 1)
            seeds = seed_range(store, c["model"], LONG_TERM_TF, metric) if sdd else None
            selected = (test_selected_score(store, f"tf{LONG_TERM_TF}", c["model"], metric,
                                            source.protocol) if sdd and source else None)
            cells.append(paper_cell(
                c[metric], ours, params, source,
                f"{DATASETS[c['dataset']]} {c['label']} (K_a = {c['k_a']}) {metric.upper()}", own,
                find_long_term_joint(store, c, metric, profile), seeds, selected))
        rows.append(Row(metric.upper(), tuple(cells)))
    columns = tuple(Column(DATASETS[c["dataset"]], c["label"], f"K_a = {c['k_a']}") for c in cols)
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
            rel, name = long_term_file(c["dataset"]), c["ablation"]
            ours = lookup(store, rel, ("ablation", name, metric), t_f=LONG_TERM_TF, expect=setting)
            joint = lookup(store, rel, ("ablation", name, f"{metric}_joint"), t_f=LONG_TERM_TF,
                           expect=setting)
            seeds = (seed_range(store, "ynet", LONG_TERM_TF, metric)  # seeds: the main setting's
                     if (c["dataset"], name) == ("sdd", "ttst_cws") else None)
            cells.append(paper_cell(c[metric], ours, params, c["cells"][metric],
                                    f"{DATASETS[c['dataset']]} {name} {metric.upper()}",
                                    joint=joint, seeds=seeds))
        rows.append(Row(metric.upper(), tuple(cells)))
    tick = {True: "\u2713", False: "\u2717"}
    columns = tuple(Column(DATASETS[c["dataset"]], f"TTST {tick[c['ttst']]}  CWS {tick[c['cws']]}")
                    for c in cols)
    return Table("ttst", spec["number"], spec["title"],
                 "t_f = 30 s, K_e = 20, K_a = 1. Ours: metrics/ynet_eval.json and metrics/ind_benchmark.json, "
                 "key ablation.<none|cws|ttst_cws>.",
                 spec["unit"], 2, columns, tuple(rows))


TABLE_BUILDERS = {"sdd_short": table_sdd_short, "eth_ucy": table_eth_ucy,
                  "sdd_long": table_sdd_long, "ttst": table_ttst}


def build_tables(paper: Mapping, store: MetricsStore, params: ReportParams,
                 profile: str | None = None,
                 registered: Mapping[str, ModelEntry] | None = None) -> list[Table]:
    """The paper's four tables with ours beside them; `profile`: the one the stages ran under (a
    file of another profile is shown as a mismatch, not compared); `registered`: the models of
    params.yaml `models`, each a column of Table 3 (`with_registered`). Table 4 is Y-net's own
    TTST / CWS ablation: no other model has those switches, so it has no column for them."""
    paper = with_provenance(paper)
    specs = {**paper, "sdd_long": with_registered(paper["sdd_long"], registered or {})}
    tables = [annotated(build(specs[key], store, params, profile))
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


def slug(*parts: str) -> str:
    """'SDD', 'Y-net', 'K_a = 2' -> 'sdd_y_net_k_a_2': a file name for a table column."""
    return re.sub(r"[^a-z0-9]+", "_", " ".join(p for p in parts if p).lower()).strip("_")


def headline_metrics(tables: Iterable[Table], horizons: Iterable[Series]) -> dict[str, dict[str, float]]:
    """The numbers `dvc metrics show` prints: {"<table>/<column>.json": {"ade": .., "fde": ..}}.

    One small file per model (table column) with our measured ADE and FDE, so the DVC table has
    two value columns and a row per model; tables of one row per metric give that row's cells, the
    ETH/UCY table its AVG row. Y-net's horizon points are added as `figure4_horizons/ynet_tf<t>`.
    Unmeasured cells are left out; a registered model's (ours only) are in.
    """
    files: dict[str, dict[str, float]] = {}
    for table in tables:
        folder = f"table{table.number}_{table.key}"
        metric_rows = {row.label.lower(): row for row in table.rows if row.label.lower() in METRICS}
        if metric_rows:  # rows ADE, FDE; one column per model
            for i, column in enumerate(table.columns):
                for metric, row in metric_rows.items():
                    cell = row.cells[i]
                    if cell.kind in ("measured", "ours-only"):
                        name = f"{folder}/{slug(column.group, column.label, column.sub)}.json"
                        files.setdefault(name, {})[metric] = cell.ours.mean
        else:  # rows per scene and AVG; columns model x metric
            average = next((row for row in table.rows if row.label == "AVG"), None)
            for column, cell in zip(table.columns, average.cells if average else ()):
                if cell.kind == "measured":
                    name = f"{folder}/{slug(column.group)}_avg.json"
                    files.setdefault(name, {})[column.label.lower()] = cell.ours.mean
    for series in horizons:
        if series.key == "ynet":
            for t_f, value in series.points:
                files[f"figure4_horizons/ynet_tf{t_f}.json"] = {"ade": value.mean}
    return files


# ---------------------------------------------------------------------------------------------
# Figure series


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
            if key == "ynet":  # the main Y-net is the t_f = 30 point
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
        return [Series("ynet", "Y-net", (), ((None, why),))]
    rows = [row for row in grid
            if isinstance(row, dict) and is_number(row.get("k_e")) and is_number(row.get("k_a"))]
    out = []
    for k_e in sorted({row["k_e"] for row in rows}):
        k_as = sorted({row["k_a"] for row in rows if row["k_e"] == k_e})
        found = [(k_a, lookup_grid(store, rel, "ka_grid", {"k_e": k_e, "k_a": k_a}, "ade")) for k_a in k_as]
        out.append(split_points(f"ynet_ke{k_e}", f"Y-net K_e = {k_e}", found))
    return out


def pecnet_ka_series(store: MetricsStore) -> Series:
    """PECNet's ADE per K_a from `baselines/pecnet_ka.json` (a list), noting a K other than 20 K_a."""
    rel, key, label = "baselines/pecnet_ka.json", "pecnet_k20ka", "PECNet, K = 20 K_a"
    record = store.record(rel)
    if not isinstance(record, list):
        why = record if isinstance(record, Absent) else Absent(f"{store.where(rel)} is not a list", "invalid")
        return Series(key, label, (), ((None, why),))
    found = []
    for row in record:
        if isinstance(row, dict) and is_number(row.get("k_a")):
            note = "" if row.get("k") in (None, 20 * row["k_a"]) else f"K = {row['k']}, not 20 K_a"
            source = f"{store.where(rel)}: k_a = {row['k_a']}"
            value = as_measured(row.get("ade"), row.get("rounds"), source, note)
            found.append((int(row["k_a"]), value))
    return split_points(key, label, sorted(found, key=lambda p: p[0]))


def paper_long_term_points(paper: Mapping) -> dict[str, float]:
    """Table 3's SDD ADE at t_f = 30 s, K_a = 1 per model: the only published horizon points."""
    return {c["model"]: c["ade"] for c in paper["sdd_long"]["columns"]
            if c["dataset"] == "sdd" and c["k_a"] == 1}


def paper_long_term_cells(paper: Mapping) -> dict[str, dict[str, float]]:
    """Table 3's SDD ADE and FDE at t_f = 30 s, K_a = 1, per model."""
    return {c["model"]: {"label": c["label"], "ade": c["ade"], "fde": c["fde"]}
            for c in paper["sdd_long"]["columns"]
            if c["dataset"] == "sdd" and c["k_a"] == 1}


def diagnostics_section(store: MetricsStore, paper: Mapping) -> dict[str, Any]:
    """What brackets Table 3 (t_f = 30 s), never in place of its headline: every model at K = 1
    beside K = 20, R-PECNet's compounding roll-out (`pipeline.report.diagnostics`) and PECNet's
    epochs selected on the test set as upstream does (`pipeline.report.compat`), with the paper's
    cells beside them."""
    cells = paper_long_term_cells(paper)
    selection = store.record("pecnet_test_selection.json")
    return {"title": DIAGNOSTICS_TITLE, "t_f": LONG_TERM_TF, "paper": cells, "headline": HEADLINE,
            "rows": diagnostics_from_store(store, LONG_TERM_TF),
            "compat": compat_rows(None if isinstance(selection, Absent) else selection,
                                  {LONG_TERM_TF: cells["pecnet"]} if "pecnet" in cells else None),
            "compat_absent": selection if isinstance(selection, Absent) else None,
            "compat_source": store.where("pecnet_test_selection.json")}


def paper_ka_points(paper: Mapping) -> list[tuple[int, float]]:
    """Table 3's SDD Y-net ADE at K_e = 20 for each K_a."""
    return [(c["k_a"], c["ade"]) for c in paper["sdd_long"]["columns"]
            if c["dataset"] == "sdd" and c["model"] == "ynet"]


def plot_rows(series: list[Series], x_name: str) -> list[dict[str, float]]:
    """Wide records for `dvc plots` ({x_name: x, <series key>: mean}); only measured values."""
    rows: dict[int, dict[str, float]] = {}
    for s in series:
        for x, value in s.points:
            rows.setdefault(x, {x_name: x})[s.key] = value.mean
    return [rows[x] for x in sorted(rows)]


# ---------------------------------------------------------------------------------------------
# Figures (matplotlib, Agg)


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def series_colours(keys: Iterable[str], models: Mapping[str, str] = MODEL_COLOURS) -> dict[str, Any]:
    """A model's colour (`models`: key -> colour) for its series; Y-net's K_e series in shades of
    its red, light to dark."""
    plt = _pyplot()
    keys = list(keys)
    shades = [k for k in keys if k.startswith("ynet_ke")]
    colours = {k: plt.cm.Reds(0.45 + 0.5 * i / max(len(shades) - 1, 1)) for i, k in enumerate(shades)}
    return {k: colours.get(k) or models.get(k.split("_k")[0] if k.startswith("pecnet_k") else k)
            for k in keys}


def plot_series(series: list[Series], paper_points: list[tuple[float, float, str, str, str]],
                xlabel: str, path: Path, models: Mapping[str, str] = MODEL_COLOURS) -> bool:
    """Lines with error bars (std over rounds) per series, plus labelled paper points.

    `paper_points`: (x, y, series key for the colour, legend label, name written beside the
    point). Returns False (no file) when no series has a measured point: the page then says why
    instead of an empty plot.
    """
    drawn = [s for s in series if s.points]
    if not drawn:
        return False
    plt = _pyplot()
    colours = series_colours([s.key for s in series] + [key for _, _, key, _, _ in paper_points],
                             models)
    fig, ax = plt.subplots(figsize=(7, 4.2), dpi=110)
    for s in drawn:
        xs = [x for x, _ in s.points]
        ys = [v.mean for _, v in s.points]
        err = [v.std or 0.0 for _, v in s.points]
        ax.errorbar(xs, ys, yerr=err, marker="o", capsize=3, label=f"{s.label} (ours)",
                    color=colours[s.key])
    for x, y, key, _, name in paper_points:
        ax.plot([x], [y], marker="D", markersize=8, linestyle="none", markerfacecolor="none",
                markeredgewidth=1.6, color=colours[key] or "black")
        if name:
            ax.annotate(name, (x, y), xytext=(7, -3), textcoords="offset points", fontsize=7,
                        color=colours[key] or "black")
    for label in dict.fromkeys(label for _, _, _, label, _ in paper_points):  # one black legend entry
        ax.plot([], [], marker="D", linestyle="none", markerfacecolor="none", color="black", label=label)
    values = [v.mean for s in drawn for _, v in s.points] + [y for _, y, _, _, _ in paper_points]
    if min(values) > 0 and max(values) / min(values) > 20:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("ADE (px, best of K)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True


@dataclass(frozen=True)
class Qualitative:
    examples: tuple[Mapping[str, np.ndarray], ...]
    problems: tuple[str, ...]


def load_qualitative(path: Path) -> Qualitative | Absent:
    """The Y-net evaluation's qualitative arrays, grouped by example index, shapes checked."""
    if not path.exists():
        return Absent(f"stage not yet run: {path.as_posix()} missing (written by the Y-net evaluation)")
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
    except (OSError, ValueError, EOFError) as e:  # EOFError: an empty file
        return Absent(f"{path.as_posix()} unreadable: {e}", "invalid")
    indices = sorted({int(m.group(1)) for name in arrays if (m := re.search(r"_(\d+)$", name))})
    examples, problems = [], []
    for i in indices:
        example = {key: arrays.get(f"{key}_{i}") for key in QUALITATIVE_KEYS}
        missing = [key for key, value in example.items() if value is None]
        problem = (f"example {i}: missing {', '.join(missing)}" if missing
                   else qualitative_shape_problem(example))
        if problem:
            problems.append(problem if problem.startswith("example") else f"example {i}: {problem}")
        else:  # optional `scene_id_<i>` (a string) names the row
            example["title"] = str(arrays.get(f"scene_id_{i}", f"example {i}"))
            examples.append(example)
    if not examples:
        return Absent(f"{path.as_posix()} holds no complete example"
                      + (f" ({'; '.join(problems)})" if problems else ""), "invalid")
    return Qualitative(tuple(examples), tuple(problems))


def qualitative_shape_problem(ex: Mapping[str, np.ndarray]) -> str:
    """'' when the arrays have the contract's shapes, else what is wrong."""
    checks = [
        ("scene_image", ex["scene_image"].ndim == 3 and ex["scene_image"].shape[2] == 3, "(H, W, 3)"),
        ("past", ex["past"].ndim == 2 and ex["past"].shape[1] == 2, "(n_p, 2)"),
        ("future", ex["future"].ndim == 2 and ex["future"].shape[1] == 2, "(n_f, 2)"),
        ("goal_heatmap", ex["goal_heatmap"].ndim == 2, "(H, W)"),
        ("sampled_goals", ex["sampled_goals"].ndim == 2 and ex["sampled_goals"].shape[1] == 2, "(K_e, 2)"),
        ("trajectory_heatmap", ex["trajectory_heatmap"].ndim == 2, "(H, W)"),
        ("predictions", ex["predictions"].ndim == 3 and ex["predictions"].shape[2] == 2, "(K, n_f, 2)"),
    ]
    bad = [f"{name} has shape {ex[name].shape}, expected {want}" for name, ok, want in checks if not ok]
    return "; ".join(bad)


def plot_qualitative(examples: Iterable[Mapping[str, np.ndarray]], path: Path) -> None:
    """The paper's Figure 6 layout: past | goal heatmap + goals | path heatmap | predictions."""
    examples = list(examples)
    plt = _pyplot()
    fig, axes = plt.subplots(len(examples), 4, figsize=(14, 3.6 * len(examples)), dpi=90, squeeze=False)
    titles = ("past (blue)", "goal heatmap, sampled goals", "trajectory heatmap for one goal",
              "predictions (red), ground truth (green)")
    for row, ex in zip(axes, examples, strict=True):
        image = ex["scene_image"]
        h, w = image.shape[:2]
        extent = (0, w, h, 0)  # heatmaps stretched over the image if their size differs
        for ax, title in zip(row, titles, strict=True):
            ax.imshow(image, extent=extent)
            ax.set_title(f"{ex['title']}: {title}" if ax is row[0] else title, fontsize=9)
            ax.set_axis_off()
        past, future = ex["past"], ex["future"]
        row[0].plot(past[:, 0], past[:, 1], "-o", color="#1f4fff", markersize=3)
        row[1].imshow(ex["goal_heatmap"], extent=extent, cmap="inferno", alpha=0.55)
        row[1].scatter(ex["sampled_goals"][:, 0], ex["sampled_goals"][:, 1], marker="*", s=40,
                       color="#ffe600", edgecolors="black", linewidths=0.4)
        row[2].imshow(ex["trajectory_heatmap"], extent=extent, cmap="inferno", alpha=0.55)
        for pred in ex["predictions"]:
            row[3].plot(pred[:, 0], pred[:, 1], "-", color="#e00000", linewidth=0.8, alpha=0.7)
        row[3].plot(future[:, 0], future[:, 1], "-", color="#00b000", linewidth=2)
        for ax in (row[2], row[3]):
            ax.plot(past[:, 0], past[:, 1], "-", color="#1f4fff", linewidth=2)
        for ax in row:
            ax.set_xlim(0, w)
            ax.set_ylim(h, 0)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
# Training-seed spread of the baselines and the main Y-net




@dataclass(frozen=True)
class SeedSpreadRow:
    """One model at one horizon: ADE / FDE over training seeds (mean and std, `Measured` with
    the seed count as its rounds), the main model's std over evaluation rounds, and each seed's
    (seed, ADE, FDE, kept epoch, its validation ADE); or, with `not_run`, why no extra seed was
    trained (Y-net in the `cpu` profile), the main seed's values still listed."""
    model: str
    horizon: int
    ade: Measured | Absent
    fde: Measured | Absent
    ade_round_std: float | None
    fde_round_std: float | None
    per_seed: tuple[tuple[Any, Any, Any, Any, Any], ...]
    not_run: str | None = None


def seed_spread_row(entry: Any, source: str) -> SeedSpreadRow | Absent:
    """A row from one entry of `baseline_seed_spread.json`, or why it cannot be one."""
    if not isinstance(entry, dict) or not all(key in entry for key in ("model", "horizon", "per_seed")):
        return Absent(f"{source}: an entry without model, horizon or per_seed", "invalid")
    over, main = entry.get("over_training_seeds") or {}, entry.get("main_round_std") or {}
    seeds = entry["per_seed"] if isinstance(entry["per_seed"], list) else []
    where = f"{source}: {entry['model']} t_f = {entry['horizon']}"
    per_seed = tuple((s.get("seed"), s.get("ade"), s.get("fde"), s.get("best_epoch"), s.get("best_val_ade"))
                     for s in seeds if isinstance(s, dict))
    if entry.get("not_run_reason"):
        why = str(entry["not_run_reason"])
        return SeedSpreadRow(
            model=dict(HORIZON_MODELS).get(entry["model"], str(entry["model"])), horizon=entry["horizon"],
            ade=Absent(why, "status"), fde=Absent(why, "status"), ade_round_std=None,
            fde_round_std=None, per_seed=per_seed, not_run=why)
    return SeedSpreadRow(
        model=dict(HORIZON_MODELS).get(entry["model"], str(entry["model"])), horizon=entry["horizon"],
        ade=as_measured(over.get("ade"), len(per_seed), f"{where}: ade over training seeds"),
        fde=as_measured(over.get("fde"), len(per_seed), f"{where}: fde over training seeds"),
        ade_round_std=main.get("ade") if is_number(main.get("ade")) else None,
        fde_round_std=main.get("fde") if is_number(main.get("fde")) else None,
        per_seed=per_seed)


def seed_spread_section(store: MetricsStore) -> dict[str, Any]:
    """The table "Training-seed spread" (stage `baseline_seed_spread`), or why there is none."""
    record = store.record(SEED_SPREAD_FILE)
    none = {"absent": None, "rows": [], "problems": [], "extra_seeds": None, "evaluation": {},
            "ynet_extra_seeds": None, "ynet_evaluation": {}}
    if isinstance(record, Absent):
        return {**none, "absent": record}
    if not isinstance(record, dict) or not isinstance(record.get("entries"), list):
        return {**none, "absent": Absent(f"{store.where(SEED_SPREAD_FILE)} has no list entries", "invalid")}
    found = [seed_spread_row(entry, store.where(SEED_SPREAD_FILE)) for entry in record["entries"]]
    evaluation = next((e["evaluation"] for e in record["entries"] if isinstance(e, dict)
                       and isinstance(e.get("evaluation"), dict)
                       and {"split", "k", "rounds", "seed"} <= set(e["evaluation"])), {})
    ynet_evaluation = next((e["evaluation"] for e in record["entries"] if isinstance(e, dict)
                            and e.get("model") == "ynet" and isinstance(e.get("evaluation"), dict)
                            and {"k_e", "k_a", "rounds"} <= set(e["evaluation"])), {})
    return {**none, "rows": [row for row in found if isinstance(row, SeedSpreadRow)],
            "problems": [row.reason for row in found if isinstance(row, Absent)],
            "extra_seeds": record.get("extra_seeds"), "evaluation": evaluation,
            "ynet_extra_seeds": record.get("ynet_extra_seeds"), "ynet_evaluation": ynet_evaluation}


# ---------------------------------------------------------------------------------------------
# Data and segmentation sections


def horizon_keys(mapping: Mapping) -> list[str]:
    """'tf5', 'tf10', ... in numeric order."""
    return sorted((k for k in mapping if re.fullmatch(r"tf\d+", k)), key=lambda k: int(k[2:]))


def window_count_rows(windows: Any, horizon_windows: Any) -> list[dict[str, Any]]:
    """Per horizon: raw windows per split (and outside it), release-chain windows per split."""
    raw = windows.get("raw", {}) if isinstance(windows, dict) else {}
    chain = horizon_windows if isinstance(horizon_windows, dict) else {}
    keys = sorted(set(horizon_keys(raw)) | set(horizon_keys(chain)), key=lambda k: int(k[2:]))
    rows = []
    for key in keys:
        r = raw.get(key, {})
        c = chain.get(key, {})
        rows.append({"t_f": int(key[2:]),
                     "raw": {s: r.get(s) for s in ("train", "val", "test", "outside_split")},
                     "chain": {s: c.get(s, {}).get("release_chain") for s in ("train", "val", "test")}})
    return rows


def chain_bias_rows(record: Any) -> list[dict[str, Any]]:
    """Per horizon: CV errors on raw windows vs release-style chains, and the relative bias."""
    if not isinstance(record, dict):
        return []
    rows = []
    for key in horizon_keys(record):
        entry = record[key]
        raw, chain = entry.get("raw", {}), entry.get("release_chain", {})
        bias = (relative_difference(chain["cv_ade"], raw["cv_ade"])
                if is_number(chain.get("cv_ade")) and is_number(raw.get("cv_ade")) else None)
        rows.append({"t_f": int(key[2:]), "raw": raw, "chain": chain,
                     "kept_fraction": entry.get("kept_fraction"), "ade_bias": bias})
    return rows


def scene_count_rows(per_scene: Any) -> tuple[list[str], list[dict[str, Any]]]:
    """Windows per video: columns '<source> t_f', rows videos with their counts."""
    if not isinstance(per_scene, dict):
        return [], []
    columns, counts = [], {}
    for source in sorted(per_scene):
        for key in horizon_keys(per_scene[source]):
            column = f"{source} {key[2:]} s"
            columns.append(column)
            for split, videos in per_scene[source][key].items():
                for video, n in videos.items():
                    counts.setdefault(video, {"split": split})[column] = n
    rows = [{"video": v, **counts[v]} for v in sorted(counts, key=video_sort_key)]
    return columns, rows


def video_sort_key(name: str) -> tuple[str, int]:
    scene, _, k = name.rpartition("_")
    return (scene, int(k)) if k.isdigit() else (name, -1)


def segmentation_scores(store: MetricsStore) -> dict[str, Any]:
    """mIoU and per-class IoU (no paper counterpart: the paper prints no segmentation score)."""
    record = store.record("segmentation.json")
    if isinstance(record, Absent):
        return {"absent": record, "miou": record, "classes": [], "extra": [], "no_classes": None}
    where = store.where("segmentation.json")
    miou = lookup(store, "segmentation.json", ("miou",))
    per_class = record.get("iou", record.get("per_class_iou"))
    classes = ([(name, as_measured(v, record.get("rounds"),
                                   f"{where}: per_class_iou.{name}"))
                for name, v in per_class.items()] if isinstance(per_class, dict) else [])
    extra = [(k, v) for k, v in record.items()
             if is_number(v) and k not in ("miou", "rounds") and "seconds" not in k]  # times: provenance
    return {"absent": None, "miou": miou, "classes": classes, "extra": extra,
            "no_classes": None if classes else f"{where} has no per-class IoU (key `iou`)"}


def segmentation_gallery(folder: Path, videos: Iterable[str], slot) -> dict[str, Any]:
    """Figures of `folder` (one subfolder per kind, e.g. predictions) per test video.

    Each is copied beside the page as a compact JPEG (`slot(name)` says where), so the committed
    report stays small and still opens without the stage outputs.
    """
    if not folder.is_dir():
        return {"absent": f"stage not yet run: {folder.as_posix()} missing (the segmentation stages "
                          "draw these figures)", "kinds": [], "rows": [], "other": []}
    kinds = sorted({p.parent for p in folder.rglob("*.png")}, key=lambda p: p.as_posix())
    kind_names = [k.relative_to(folder).as_posix() if k != folder else folder.name for k in kinds]
    rows, used = [], set()
    for video in sorted(videos, key=video_sort_key):
        pattern = re.compile(rf"^{re.escape(video)}(?!\d)")
        images = []
        for kind, kind_name in zip(kinds, kind_names):
            match = sorted(p for p in kind.glob("*.png") if pattern.match(p.stem))
            images.append(compact_copy(match[0], slot(f"segmentation_{kind_name}_{video}.jpg"))
                          if match else None)
            used.update(match[:1])
        if any(images):
            rows.append({"video": video, "images": images})
    other = [compact_copy(p, slot(f"segmentation_{p.stem}.jpg")) for p in sorted(folder.rglob("*.png"))
             if p not in used and p.parent == folder]
    return {"absent": None, "kinds": kind_names, "rows": rows, "other": other}


GALLERY_MAX_WIDTH = 1200
GALLERY_JPEG_QUALITY = 80


def compact_copy(image_path: Path, slot: "FigureSlot") -> str:
    """`image_path` as a JPEG at most GALLERY_MAX_WIDTH wide at `slot.path`; its <img> src."""
    image = cv2.imread(str(image_path), cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError(f"{image_path}: not a readable image")
    if image.shape[1] > GALLERY_MAX_WIDTH:
        scale = GALLERY_MAX_WIDTH / image.shape[1]
        image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    slot.path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(slot.path), image, [cv2.IMWRITE_JPEG_QUALITY, GALLERY_JPEG_QUALITY]):
        raise OSError(f"could not write {slot.path}")
    return slot.src


def rel_src(path: Path, html_dir: Path) -> str:
    """An <img src> relative to the page, so it opens from the file system."""
    return Path(os.path.relpath(path.resolve(), html_dir.resolve())).as_posix()


# ---------------------------------------------------------------------------------------------
# Provenance


def porcelain_paths(lines: Iterable[str]) -> list[str]:
    """The paths of `git status --porcelain` lines ("XY path" or "XY old -> new": the new one)."""
    return [line[3:].split(" -> ")[-1].strip('"') for line in lines if len(line) > 3]


def read_lock(lock_path: Path) -> Mapping[str, Any] | Absent:
    """dvc.lock parsed once (about a second of YAML at this size) for everything the page takes
    from it, or why it cannot be."""
    if not lock_path.exists():
        return Absent(f"{lock_path.as_posix()} missing (no stage has run)")
    try:
        return yaml.safe_load(lock_path.read_text()) or {}
    except (OSError, yaml.YAMLError) as e:
        return Absent(f"{lock_path.as_posix()} unreadable: {e}", "invalid")


def lock_stages(lock: Mapping[str, Any] | Absent) -> Iterable[Mapping[str, Any]]:
    return [] if isinstance(lock, Absent) else (lock.get("stages") or {}).values()


def lock_outputs(lock: Mapping[str, Any] | Absent) -> list[str]:
    """Every output path dvc.lock records (nothing if it is missing or unreadable)."""
    return [str(out["path"]) for stage in lock_stages(lock) for out in stage.get("outs") or []
            if "path" in out]


def is_output(path: str, outputs: Iterable[str]) -> bool:
    """`path` (a file or, untracked, a folder ending in "/") is dvc.lock or lies in an output, or
    is an output's temporary file or staging folder (`.<name>.tmp<pid>...`, `pipeline.io`)."""
    path = path.rstrip("/")
    staged = re.match(r"^(.*/)?\.([^/]+?)\.tmp\d+[^/]*$", path)
    if staged:
        path = (staged[1] or "") + staged[2]
    return path == "dvc.lock" or any(path == out.rstrip("/") or path.startswith(out.rstrip("/") + "/")
                                     or out.startswith(path + "/") for out in outputs)


def classify_changes(paths: Iterable[str], outputs: Iterable[str]) -> dict[str, Any]:
    """Changed paths split into code, params.yaml and pipeline outputs: only the first two mean
    the numbers may not come from the commit (outputs change whenever a stage runs)."""
    outputs = list(outputs)
    paths = list(paths)
    code = [p for p in paths if p != "params.yaml" and not is_output(p, outputs)]
    return {"code_changes": code, "params_changed": "params.yaml" in paths,
            "output_changes": sum(1 for p in paths if p != "params.yaml" and is_output(p, outputs))}


def git_state(repo: Path, outputs: Iterable[str] = ()) -> dict[str, Any]:
    """Commit, and whether code or params.yaml differ from it, read-only (no index refresh), or
    why it is unknown. `outputs`: paths that only the pipeline writes (never make it "dirty")."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "--no-optional-locks", "-C", str(repo), *args], check=True,
                              capture_output=True, text=True, timeout=30).stdout
    try:
        commit = git("rev-parse", "HEAD").strip()
        changes = classify_changes(porcelain_paths(git("status", "--porcelain").splitlines()), outputs)
    except (OSError, subprocess.SubprocessError) as e:
        return {"error": f"git state unknown: {e.__class__.__name__}: {str(e).strip()[:200]}",
                "commit": None, "dirty": None, "code_changes": [], "params_changed": None,
                "output_changes": 0}
    return {"error": None, "commit": commit,
            "dirty": bool(changes["code_changes"]) or changes["params_changed"], **changes}


def machine() -> dict[str, Any]:
    """Where this report (and, on one machine, the stages) ran."""
    cpu = platform.processor() or ""
    try:
        names = re.findall(r"^model name\s*:\s*(.+)$", Path("/proc/cpuinfo").read_text(), re.M)
        cpu = names[0] if names else cpu
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return {"cpu": cpu or "unknown", "cores": os.cpu_count(), "usable_cores": usable,
            "platform": platform.platform(), "python": sys.version.split()[0],
            "packages": {name: package_version(name) for name in ("torch", "numpy", "pandas", "dvc")}}


def package_version(name: str) -> str:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def manifest_checksums(folder: Path) -> list[dict[str, Any]]:
    """Each manifest's own SHA-256 (it pins every raw file's SHA-256) and how many files it lists."""
    if not folder.is_dir():
        return []
    return [{"name": p.name, "sha256": sha256_file(p),
             "files": sum(1 for line in p.read_text().splitlines() if line.strip())}
            for p in sorted(folder.glob("*.sha256"))]


def sdd_sources(store: MetricsStore, val_videos: Iterable[str]) -> dict[str, Any]:
    """Where the SDD raw annotations came from (stage `tracks`' `sdd_sources.json`): videos per
    origin, the files of your copy the manifest does not pin (with their SHA-256), and per video
    whether the horizon benchmark's windows are raw or cut from chained release windows (stage
    `horizon_windows` cuts raw windows on every TrajNet video with raw annotations, chains on the
    others; raw videos outside the split give none)."""
    record = store.record("sdd_sources.json")
    if isinstance(record, Absent):
        return {"absent": record}
    if not isinstance(record, dict):
        return {"absent": Absent(f"{store.where('sdd_sources.json')}: not a mapping", "invalid")}

    def part(key: str) -> dict:
        return record[key] if isinstance(record.get(key), dict) else {}

    videos, images, copy = part("videos"), part("reference_images"), part("copy")
    by_video = sorted(videos.items(), key=lambda item: video_sort_key(item[0]))
    fingerprinted = ([{"file": v.get("file", name), "sha256": v.get("sha256", "n/a")}
                      for name, v in by_video if isinstance(v, dict) and not v.get("pinned")]
                     + [{"file": rel, "sha256": i.get("sha256", "n/a")} for rel, i in sorted(images.items())
                        if isinstance(i, dict) and not i.get("pinned")])
    trajnet = TRAIN_VIDEOS | TEST_VIDEOS
    rows = []
    for name in sorted(trajnet | set(videos), key=video_sort_key):
        entry = videos.get(name)
        rows.append({"video": name, "split": split_of(name, set(val_videos)) or "outside the split",
                     "origin": entry.get("origin", "n/a") if isinstance(entry, dict) else "none",
                     "horizon": ("none (outside the TrajNet split)" if name not in trajnet
                                 else "raw" if entry is not None else "release-chained")})
    return {"absent": None, "provided": bool(copy.get("provided")), "path": copy.get("path", ""),
            "n_videos": len(videos),
            "origins": dict(sorted(Counter(str(v.get("origin", "n/a")) for _, v in by_video
                                           if isinstance(v, dict)).items())),
            "fingerprinted": fingerprinted, "rows": rows,
            "n_raw": sum(r["horizon"] == "raw" for r in rows),
            "n_chained": sum(r["horizon"] == "release-chained" for r in rows)}


def raw_data_hashes(lock: Mapping[str, Any] | Absent) -> list[dict[str, Any]] | Absent:
    """The md5 DVC recorded for each data/raw/<source> output."""
    if isinstance(lock, Absent):
        return lock
    found = {}
    for stage in lock_stages(lock):
        for out in stage.get("outs") or []:
            if str(out.get("path", "")).startswith("data/raw/"):
                found[out["path"]] = {"path": out["path"], "md5": out.get("md5"),
                                      "files": out.get("nfiles"), "size": out.get("size")}
    return [found[k] for k in sorted(found)]


def stage_timings(store: MetricsStore) -> dict[str, Any]:
    """Every top-level `*seconds*` number of the metrics files, one row per file, one column per key."""
    rows = []
    for rel, record in sorted(store.files.items()):
        if isinstance(record, dict):
            times = {k: float(v) for k, v in record.items() if "seconds" in k and is_number(v)}
            if times:
                rows.append({"file": store.where(rel), "seconds": times})
    keys = sorted({k for row in rows for k in row["seconds"]})
    return {"keys": keys, "rows": rows}


def stage_profile(path: Path | None) -> dict[str, Any] | Absent:
    """Where the pipeline's time goes: the stages `tools/timed_repro.py` clocked (`make repro`),
    longest first, each with its share of their sum, and the last run's record."""
    if path is None or not path.exists():
        return Absent("no stage times yet: `make repro` (tools/timed_repro.py) writes "
                      f"{'reports/stage_times.json' if path is None else path.as_posix()}")
    try:
        record = json.loads(path.read_text())
        stages = {str(name): float(entry["seconds"]) for name, entry in record["stages"].items()}
        if not stages:
            return Absent(f"{path.as_posix()}: no stage clocked yet (`make repro` fills it)")
        last_run = {"jobs": 1, **record["last_run"]}  # runs before --jobs ran one stage at a time
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
        return Absent(f"{path.as_posix()} unreadable: {e.__class__.__name__}: {e}", "invalid")
    total = sum(stages.values())
    rows = [{"stage": name, "seconds": seconds, "share": seconds / total if total else 0.0,
             "run_started": record["stages"][name].get("run_started")}
            for name, seconds in sorted(stages.items(), key=lambda item: -item[1])]
    return {"rows": rows, "total": total, "last_run": last_run}


def lock_params(lock: Mapping[str, Any] | Absent) -> dict[str, Any]:
    """The params.yaml values the stages ran with, as dvc.lock records them (each stage its keys),
    merged into one nested mapping: what the numbers on the page were computed with."""
    merged: dict[str, Any] = {}
    for stage in lock_stages(lock):
        for key, value in ((stage.get("params") or {}).get("params.yaml") or {}).items():
            node = merged
            *parents, leaf = str(key).split(".")
            for part in parents:
                node = node.setdefault(part, {})
            node[leaf] = value
    return merged


def profiles(params: Mapping, store: MetricsStore) -> dict[str, list[str]]:
    """Every `profile` value -> where it is set: the params in dvc.lock (any depth) and the
    metrics files."""
    found = []

    def walk(node: Any, where: str) -> None:
        if isinstance(node, dict):
            for key, value in node.items():
                path = f"{where}.{key}" if where else str(key)
                if key == "profile" and isinstance(value, str):
                    found.append((f"dvc.lock params: {path}", value))
                else:
                    walk(value, path)
    walk(params, "")
    found += [(store.where(rel), record["profile"]) for rel, record in sorted(store.files.items())
              if isinstance(record, dict) and isinstance(record.get("profile"), str)]
    grouped: dict[str, list[str]] = {}
    for where, value in found:
        grouped.setdefault(value, []).append(where)
    return grouped


# ---------------------------------------------------------------------------------------------
# Rendering


def fmt_number(value: Any, decimals: int = 2) -> str:
    return f"{value:,.{decimals}f}" if is_number(value) else "n/a"


def fmt_pct(value: Any) -> str:
    return f"{value * 100:+.1f} %" if is_number(value) else "n/a"


def fmt_duration(seconds: Any) -> str:
    if not is_number(seconds):
        return "n/a"
    if seconds < 120:
        return f"{seconds:.1f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.2f} h"


def render_html(context: Mapping[str, Any], template: Path = TEMPLATE) -> str:
    import jinja2
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(template.parent), autoescape=True,
                             undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True)
    env.filters.update(num=fmt_number, pct=fmt_pct, dur=fmt_duration)
    env.tests.update(absent=lambda v: isinstance(v, Absent), measured=lambda v: isinstance(v, Measured))
    return env.get_template(template.name).render(**context)


@dataclass(frozen=True)
class Inputs:
    """Where everything the report reads lives (the stage's arguments)."""
    metrics: Path
    paper: Path
    scene_counts: Path
    segmentation_figures: Path
    qualitative: Path
    manifests: Path
    repo: Path = field(default_factory=Path.cwd)
    own_outputs: tuple[str, ...] = ()  # the report's outputs, relative to `repo`
    stage_times: Path | None = None  # tools/timed_repro.py's record of `make repro`
    animations: Path | None = None  # stage animations' folder (index.json and the animations)
    horizon_figures: Path | None = None  # stage horizon_analysis' figures folder


@dataclass(frozen=True)
class FigureSlot:
    """Where a figure is drawn (the staged folder) and how the page will refer to it."""
    path: Path
    src: str


def figure_sections(paper: Mapping, store: MetricsStore, horizons: list[int], qualitative_path: Path,
                    slot, registered: Mapping[str, ModelEntry] | None = None) -> tuple[dict, dict]:
    """Figures 4-6 drawn (when there is something to draw) and described; the dvc plots series.
    Figure 4 has a line for every `registered` model too."""
    registered = registered or {}
    models, colours = horizon_models(registered), model_colours(registered)
    h_series, k_series = horizon_series(store, horizons, models), ka_series(store)
    names = dict(models)
    h_paper = [(LONG_TERM_TF, y, key, "paper, Table 3 (t_f = 30 s)", f"{names.get(key, key)} (paper)")
               for key, y in paper_long_term_points(paper).items()]
    k_paper = [(x, y, f"ynet_ke{LONG_TERM_KE}", "paper, Table 3 (Y-net K_e = 20)", "")
               for x, y in paper_ka_points(paper)]
    h_slot, k_slot, q_slot = slot("horizon_ade.png"), slot("ka_ade.png"), slot("qualitative.png")
    h_drawn = plot_series(h_series, h_paper, "prediction horizon t_f (s)", h_slot.path, colours)
    k_drawn = plot_series(k_series, k_paper, "K_a (paths per goal)", k_slot.path, colours)
    qualitative = load_qualitative(qualitative_path)
    if isinstance(qualitative, Qualitative):
        plot_qualitative(qualitative.examples, q_slot.path)
    sections = {
        "figures_note": paper.get("figures", {}),
        "horizon": {"series": h_series, "horizons": horizons, "src": h_slot.src if h_drawn else None},
        "ka": {"series": k_series, "src": k_slot.src if k_drawn else None},
        "qualitative": {"absent": qualitative if isinstance(qualitative, Absent) else None,
                        "problems": qualitative.problems if isinstance(qualitative, Qualitative) else (),
                        "src": q_slot.src if isinstance(qualitative, Qualitative) else None},
    }
    plots = {"horizon_ade.json": plot_rows(h_series, "t_f"), "ka_ade.json": plot_rows(k_series, "k_a")}
    return sections, plots


def animation_section(folder: Path | None, html_dir: Path) -> dict[str, Any]:
    """Stage `animations`' benchmarks as its index.json lists them, each window's <img> src
    relative to the page (the animations stay in the stage's folder, beside the page's)."""
    if folder is None:
        return {"absent": Absent("no --animations folder given"), "benchmarks": []}
    index = read_json(folder / "index.json")
    if isinstance(index, Absent):
        return {"absent": index, "benchmarks": []}
    try:
        benchmarks = [{**entry, "windows": [
            {**w, "src": rel_src(folder / w["file"], html_dir), "found": (folder / w["file"]).is_file()}
            for w in entry["windows"]]} for entry in index["benchmarks"]]
    except (KeyError, TypeError) as e:
        return {"absent": Absent(f"{(folder / 'index.json').as_posix()}: not the animations index "
                                 f"({type(e).__name__}: {e})", "invalid"), "benchmarks": []}
    return {"absent": None, "benchmarks": benchmarks}


def horizon_analysis_section(store: MetricsStore, folder: Path | None,
                             html_dir: Path) -> dict[str, Any]:
    """Stage `horizon_analysis`' record as `pipeline.report.horizons.section` reads it, its
    figures' <img> src relative to the page (they stay in the stage's folder)."""
    record = store.record("horizon_analysis.json")
    if isinstance(record, Absent):
        return {"absent": record}
    content = horizons.section(record)
    figures = [{"src": rel_src(folder / name, html_dir), "found": (folder / name).is_file()}
               for name in content["figures"]] if folder is not None else []
    return {"absent": None, "source": store.where("horizon_analysis.json"), **content,
            "figures": figures, "labels": horizons.LABELS}


def data_section(store: MetricsStore, scene_counts: Path) -> dict[str, Any]:
    """The audit, window counts, chain bias and per-video counts, as the data stages wrote them."""
    windows, horizon_windows = store.record("windows.json"), store.record("horizon_windows.json")
    per_scene = read_json(scene_counts)
    scene_columns, scene_rows = scene_count_rows(per_scene)
    return {"audit": store.record("data_audit.json"), "windows": windows,
            "horizon_windows": horizon_windows, "counts": window_count_rows(windows, horizon_windows),
            "chain_bias": store.record("chain_bias.json"),
            "chain_rows": chain_bias_rows(store.record("chain_bias.json")),
            "scene_columns": scene_columns, "scene_rows": scene_rows,
            "scene_absent": per_scene if isinstance(per_scene, Absent) else None}


def provenance_section(inputs: Inputs, lock: Mapping[str, Any] | Absent, params: Mapping[str, Any],
                       store: MetricsStore) -> dict[str, Any]:
    params_text = (yaml.safe_dump(params, sort_keys=True, default_flow_style=None, width=100)
                   if params else "(dvc.lock records no params yet)")
    outputs = [*lock_outputs(lock), *inputs.own_outputs]
    return {"git": git_state(inputs.repo, outputs), "params_text": params_text,
            "profiles": profiles(params, store), "manifests": manifest_checksums(inputs.manifests),
            "raw_hashes": raw_data_hashes(lock), "machine": machine(),
            "sdd_sources": sdd_sources(store, (params.get("split") or {}).get("val_videos") or []),
            "timings": stage_timings(store), "stage_profile": stage_profile(inputs.stage_times),
            "metrics_files": sorted(store.where(rel) for rel in store.files)}


def build_context(inputs: Inputs, lock: Mapping[str, Any] | Absent, report_params: ReportParams,
                  figures_dir: Path, final_figures_dir: Path, html_dir: Path,
                  registered: Mapping[str, ModelEntry] | None = None) -> tuple[dict, dict, dict]:
    """Everything the template shows, the dvc plots series and the headline metrics files; figures
    drawn into `figures_dir`. `lock`: dvc.lock as `read_lock` gives it (the params the stages ran
    with, the outputs, the raw data's hashes); `registered`: params.yaml `models`, shown in Table
    3, Figure 4 and "Beyond the paper's tables" beside the paper's models.

    `final_figures_dir` is where those figures will be after the rename (for the <img> paths).
    """
    registered = registered or {}
    paper = load_paper_values(inputs.paper)
    params = lock_params(lock)
    store = load_metrics(inputs.metrics, inputs.metrics.as_posix())
    tables = build_tables(paper, store, report_params, params.get("profile"), registered)
    horizons = (params.get("windows") or {}).get("horizons") or []

    def slot(name: str) -> FigureSlot:
        return FigureSlot(figures_dir / name, rel_src(final_figures_dir / name, html_dir))

    figures, plots = figure_sections(paper, store, horizons, inputs.qualitative, slot, registered)
    context = {
        "generated": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "bands": report_params,
        "protocol_labels": PROTOCOL_LABELS, "protocol_lines": PROTOCOLS,
        "protocol_keys": PROTOCOL_KEYS,
        "summaries": [summarize(t) for t in tables],
        "claims": claims_section(store, paper),
        "tables": tables,
        "diagnostics": diagnostics_section(store, paper),
        **figures,
        "beyond": beyond_section(store, LONG_TERM_TF, horizon_models(registered),
                                 model_colours(registered), slot),
        "seed_spread": seed_spread_section(store),
        "horizon_analysis": horizon_analysis_section(store, inputs.horizon_figures, html_dir),
        "animations": animation_section(inputs.animations, html_dir),
        "data": data_section(store, inputs.scene_counts),
        "n_test_videos": len(TEST_VIDEOS),
        "segmentation": {**segmentation_scores(store),
                         "gallery": segmentation_gallery(inputs.segmentation_figures, TEST_VIDEOS, slot)},
        "provenance": provenance_section(inputs, lock, params, store),
    }
    return context, plots, headline_metrics(tables, figures["horizon"]["series"])


def read_json(path: Path) -> Any:
    if not path.exists():
        return Absent(f"stage not yet run: {path.as_posix()} missing")
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as e:
        return Absent(f"{path.as_posix()} unreadable: {e}", "invalid")


def read_text(path: Path) -> str:
    try:
        return path.read_text()
    except OSError as e:
        return f"(unreadable: {e})"


def write_report(inputs: Inputs, lock: Mapping[str, Any] | Absent, report_params: ReportParams,
                 out: Path, figures: Path, plots: Path, headline: Path,
                 template: Path = TEMPLATE,
                 registered: Mapping[str, ModelEntry] | None = None) -> None:
    """Render everything into temporary places, then rename figures, plots, headline metrics and
    the page (folders 0755 and the page 0644, readable by other users)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    with (atomic_dir(figures, mode=0o755) as staged_figures, atomic_dir(plots, mode=0o755) as staged_plots,
          atomic_dir(headline, mode=0o755) as staged_headline):
        context, series, numbers = build_context(inputs, lock, report_params, staged_figures, figures,
                                                 out.parent, registered)
        html = render_html(context, template)
        for name, rows in series.items():
            (staged_plots / name).write_text(json.dumps(rows, indent=1) + "\n")
        for name, values in numbers.items():
            (staged_headline / name).parent.mkdir(parents=True, exist_ok=True)
            (staged_headline / name).write_text(json.dumps(values, indent=2, sort_keys=True) + "\n")
    write_text(out, html, mode=0o644)