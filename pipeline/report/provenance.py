"""Where each of the paper's numbers came from, and why ours may differ from it.

A paper cell is measured by the Y-net authors or quoted from another paper, under one of the
best-of-K protocols of the upstream codebases (`PROTOCOLS`). `load_paper_values` reads
`paper_values.yaml` and gives every cell its `CellSource` (a field written once per model holds for
all of its cells), failing with the table and cell named when a field is missing or unknown.

Ours under a cell's own protocol comes from the stored-prediction scores (stage
`score_short_term_predictions`: `beyond/short_term.json`; `score_predictions`:
`beyond/long_term.json`, `beyond/ind.json`), "not scored" where the key is not there.
`why_differs` names the cause of a difference beyond the report's `far` band, each from a number
this pipeline measured and shown with it: `protocol` (ours under the cell's own protocol is within
`far`; for PECNet also ours retrained with upstream's epochs selected on the test set, a compat
diagnostic), `seed spread` (the paper's number lies in our range over training seeds), `budget`
(more epochs close at least half of the gap: `BudgetPoint`); `unexplained` otherwise, with what was
measured and did not explain it. No cause is ever written in paper_values.yaml: a sentence there
explains nothing. A `source` cause (the quoted number's own setting accounts for the difference)
would need a measurement of that setting, such as the quoted paper's released model scored here;
the pipeline has none yet, so no cell can say so.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from pipeline.benchmarks.registry import long_term
from pipeline.model_list import PECNET, YNET
from pipeline.report.lookups import Absent, Measured, MetricsStore, as_measured, dig, is_number

METRICS = ("ade", "fde")
TABLE_KEYS = ("sdd_short", "eth_ucy", "sdd_long", "ttst")
MEASURED_BY = {"ynet_authors": "measured by the Y-net authors",
               "quoted": "quoted by the Y-net paper from another paper"}
PROTOCOLS = {  # one line each, as the tables' captions say them
    "independent_min": "min over K of ADE and of FDE separately, per window (Y-net's test.py; our "
                       "headline)",
    "sgan_sequence": "per sequence of co-observed pedestrians, one minimum over samples of their "
                     "summed error (S-GAN's evaluate_model.py)",
    "pecnet_best_endpoint": "ADE of the sample with the best endpoint, min FDE (PECNet's training "
                            "loop, which also reports the best test ADE and FDE over epochs: "
                            "epochs selected on the test set)",
    "unknown": "not stated in anything we hold; compared with our headline",
}
PROTOCOL_LABELS = {"independent_min": "independent min", "sgan_sequence": "S-GAN per sequence",
                   "pecnet_best_endpoint": "PECNet best endpoint", "unknown": "unknown protocol"}
HEADLINE_PROTOCOL = "independent_min"
# The stored-prediction scores' key of each metric under each protocol it can be scored in.
PROTOCOL_KEYS = {"independent_min": {"ade": "ade", "fde": "fde"},
                 "pecnet_best_endpoint": {"ade": "ade_best_endpoint", "fde": "fde"},
                 "sgan_sequence": {"ade": "ade_sgan_sequence", "fde": "fde_sgan_sequence"}}
CAUSES = ("protocol", "seed spread", "budget", "unexplained")  # each from a measurement but the last
VERDICTS = ("match", *CAUSES)  # "match": within `far` under the headline protocol
FIELDS = ("measured_by", "source", "protocol")
BUDGET_CLOSES = 0.5  # "budget" names the cause where the longest run closes at least this share
SHORT_TERM_SCORES = "beyond/short_term.json"
SEED_SPREAD_FILE = "baseline_seed_spread.json"
# Upstream PECNet's test-set epoch selection, retrained per ETH/UCY fold (a compat diagnostic).
TEST_SELECTION_FILE = "short_term/pecnet_test_selection/{benchmark}.json"
LONG_TERM_TEST_SELECTION_FILE = "pecnet_test_selection.json"
TEST_SELECTED_MODELS = (PECNET,)
TEST_SELECTION_PROTOCOLS = {"pecnet_best_endpoint": PECNET, "independent_min": "headline"}


class PaperValuesError(ValueError):
    """paper_values.yaml lacks a cell's provenance or has a value outside the allowed ones."""


@dataclass(frozen=True)
class CellSource:
    """Who measured one paper cell, where it was printed first, and under which protocol."""
    measured_by: str
    source: str
    protocol: str

    @property
    def quoted(self) -> bool:
        return self.measured_by == "quoted"


@dataclass(frozen=True)
class SourceNote:
    """A table's footnote: the mark its cells carry, who measured them, where, and how."""
    mark: str
    measured_by: str
    source: str
    protocol: str
    labels: tuple[str, ...]  # the table's columns (models) it covers


@dataclass(frozen=True)
class BudgetPoint:
    """Ours after a longer training than the profile's (`factor` x its epochs, the schedule
    stretched), beside ours at 1x: the share of the gap to the paper it closes."""
    factor: int
    ours: float  # at factor x the epochs
    ours_1x: float

    def closes(self, paper: float) -> float | None:
        """(ours at 1x - ours at factor x) / (ours at 1x - paper); None without a gap."""
        gap = self.ours_1x - paper
        return None if gap == 0 else (self.ours_1x - self.ours) / gap


@dataclass(frozen=True)
class Why:
    """How a compared cell stands: `match`, or the cause of its difference, with the detail."""
    verdict: str  # one of VERDICTS
    detail: str = ""


# ---------------------------------------------------------------------------------------------
# Reading paper_values.yaml


def load_paper_values(path: Path) -> dict:
    """paper_values.yaml, every cell with its `CellSource` (`with_provenance`)."""
    return with_provenance(yaml.safe_load(path.read_text()))


def with_provenance(paper: Mapping) -> dict:
    """A copy of the paper values where each column (Tables 1, 3, 4) has `cells: {metric:
    CellSource}` and each Table 2 model `cells: {metric: {scene: CellSource}}` (scenes and avg),
    from its own fields over its table's `provenance` of its model. Reads only the written
    fields, so it may be applied again."""
    out = copy.deepcopy(dict(paper))
    for key in TABLE_KEYS:
        spec = out[key]
        where = f"Table {spec.get('number', '?')} ({key})"
        if key == "eth_ucy":
            scenes = [*spec["scenes"], "avg"]
            for entry in spec["models"]:
                fields = model_fields(spec, entry, where)
                entry["cells"] = {metric: {scene: cell_source(
                    fields, f"{where}, {entry.get('label')} {metric.upper()} {scene}")
                    for scene in scenes} for metric in METRICS}
        else:
            for column in spec["columns"]:
                fields = model_fields(spec, column, where)
                name = column_name(column)
                column["cells"] = {metric: cell_source(fields, f"{where}, {name} {metric.upper()}")
                                   for metric in METRICS}
        unused = set(spec.get("provenance") or {}) - {e.get("model") for e in entries_of(spec)}
        if unused:
            raise PaperValuesError(f"{where}: provenance for {sorted(unused)}, a model the table "
                                   "does not have")
    return out


def column_name(column: Mapping) -> str:
    """'SDD R-PECNet (K_a = 1)', 'S-GAN (K = 20)', 'SDD Y-net (ablation ttst_cws)': for errors."""
    settings = ", ".join(f"{k} = {column[k]}" for k in ("k", "k_a", "ablation") if k in column)
    dataset = f"{str(column['dataset']).upper()} " if "dataset" in column else ""
    return f"{dataset}{column.get('label', column.get('model'))} ({settings})"


def entries_of(spec: Mapping) -> list[Mapping]:
    return list(spec.get("models") or spec.get("columns") or [])


def model_fields(spec: Mapping, entry: Mapping, where: str) -> dict[str, Any]:
    """The provenance fields of one column or model: its own over its table's for its model."""
    shared = (spec.get("provenance") or {}).get(entry.get("model")) or {}
    unknown = set(shared) - set(FIELDS)
    if unknown:
        raise PaperValuesError(f"{where}, provenance of {entry.get('model')}: unknown fields "
                               f"{sorted(unknown)} (allowed: {', '.join(FIELDS)})")
    if "differs_because" in entry:
        raise PaperValuesError(f"{where}, {entry.get('label', entry.get('model'))}: differs_because "
                               "is not read: a cause is computed by the report from a measurement, "
                               "never written (see pipeline/report/provenance.py)")
    return {**shared, **{k: entry[k] for k in FIELDS if k in entry}}


def cell_source(fields: Mapping[str, Any], where: str) -> CellSource:
    """One cell's `CellSource`, its fields checked."""
    def one_of(name: str, allowed) -> str:
        value = fields.get(name)
        if value not in allowed:
            raise PaperValuesError(f"paper_values.yaml, {where}: {name} is {value!r}, not one of "
                                   f"{', '.join(allowed)}")
        return value
    measured_by = one_of("measured_by", MEASURED_BY)
    source = fields.get("source")
    if not isinstance(source, str) or not source.strip():
        raise PaperValuesError(f"paper_values.yaml, {where}: no source (which paper or run the "
                               "number comes from)")
    return CellSource(measured_by, source, one_of("protocol", PROTOCOLS))


# ---------------------------------------------------------------------------------------------
# Ours under a cell's own protocol


def metric_key(protocol: str, metric: str) -> str | None:
    """The stored scores' key of `metric` under `protocol`; None where it cannot be scored."""
    return PROTOCOL_KEYS.get(protocol, {}).get(metric)


def under_protocol(protocol: str, metric: str,
                   find: Callable[[str], Measured | Absent]) -> Measured | Absent | None:
    """Ours under the cell's protocol where it is not the headline's: `find(key)` reads the
    stored scores' `key`. None for the headline protocol (nothing to add)."""
    if protocol == HEADLINE_PROTOCOL:
        return None
    key = metric_key(protocol, metric)
    if key is None:
        return Absent("compared with our headline", "unknown")
    return find(key)


def stored_score(store: MetricsStore, rel: str, path: tuple[str, ...], key: str,
                 k: int | None = None) -> Measured | Absent:
    """`metrics.<key>` of the model record at `path` in a stored-scores file; "not scored yet"
    where the record has no such key, "scored at K = .. only" where its K is not the cell's."""
    record = store.record(rel)
    node = record
    for part in path:
        if isinstance(node, Absent):
            return node
        if isinstance(node, dict) and isinstance(node.get("not_run_reason"), str):
            return Absent(node["not_run_reason"], "status")
        if not isinstance(node, dict) or part not in node:
            return Absent(f"not scored ({store.where(rel)} has no {'.'.join(path)})", "missing")
        node = node[part]
    if isinstance(node, dict) and isinstance(node.get("not_run_reason"), str):
        return Absent(node["not_run_reason"], "status")
    if not isinstance(node, dict):
        return Absent(f"{store.where(rel)}: {'.'.join(path)} is not a model record", "invalid")
    if k is not None and is_number(node.get("k")) and node["k"] != k:
        return Absent(f"scored at K = {node['k']} only", "missing")
    metrics = node.get("metrics")
    if not isinstance(metrics, dict) or key not in metrics:
        return Absent("not scored yet", "missing")  # the producer has no such metric yet
    return as_measured(metrics[key], node.get("rounds"),
                       f"{store.where(rel)}: {'.'.join(path)}.metrics.{key}")


def short_term_score(store: MetricsStore, benchmark: str, model: str, key: str,
                     k: int) -> Measured | Absent:
    """A short-term benchmark's (sdd, eth, hotel, ...) stored score of `model`."""
    path = ("benchmarks", benchmark, "models", model)
    return stored_score(store, SHORT_TERM_SCORES, path, key, k)


def test_selected_score(store: MetricsStore, benchmark: str, model: str, metric: str,
                        protocol: str) -> Measured | Absent | None:
    """Ours with upstream PECNet's selection of epochs on the TEST set (a compat diagnostic): the
    lowest test `metric` over a retrain's epochs under the cell's `protocol`. `benchmark`: an
    ETH/UCY fold (stage `short_term_pecnet_test_selection`) or `tf<t_f>`, long-term SDD (stage
    `pecnet_test_selection`). None for a model upstream did not train that way, a protocol the
    diagnostic does not score, or a benchmark it does not cover."""
    if benchmark.startswith("tf"):
        rel, path = LONG_TERM_TEST_SELECTION_FILE, ("per_horizon", benchmark)
    else:
        rel, path = TEST_SELECTION_FILE.format(benchmark=benchmark), ()
    compat_protocol = TEST_SELECTION_PROTOCOLS.get(protocol)
    if model not in TEST_SELECTED_MODELS or compat_protocol is None or rel not in store.files:
        return None
    record = store.record(rel)
    if isinstance(record, Absent):
        return record
    run = dig(record, *path)
    if run is None or "not_run_reason" in run:  # a fold the compat switch leaves off
        return None
    best = dig(run, "compat", compat_protocol, f"best_{metric}")
    where = ".".join([*path, "compat", compat_protocol, f"best_{metric}"])
    if not isinstance(best, Mapping) or not is_number(best.get("value")):
        return Absent(f"{store.where(rel)} has no {where}", "invalid")
    return Measured(float(best["value"]), None, 1, f"{store.where(rel)}: {where}",
                    f"epoch {int(best.get('epoch', -1)) + 1} of {run.get('epochs')}, "
                    "selected on test (compat)")


def long_term_score(store: MetricsStore, dataset: str, model: str, k_a: int, key: str,
                    t_f: int) -> Measured | Absent:
    """Table 3's stored score (`dataset`: its column's) where the benchmark keeps it: SDD
    baselines on the horizon table, Y-net on the release's windows (its main setting, K_a = 1
    only), inD from its own file."""
    if k_a != 1:
        return Absent("scored at K_a = 1 only", "missing")
    table = f"release_tf{t_f}" if model == YNET else f"tf{t_f}"
    rel, path = long_term(dataset).stored_scores(model, table)
    return stored_score(store, rel, path, key)


def mean_of(values: list[Measured | Absent | None], what: str) -> Measured | Absent | None:
    """Table 2's AVG under a protocol: the mean of the scenes' values, when all were scored."""
    if any(v is None for v in values):
        return None
    absent = next((v for v in values if isinstance(v, Absent)), None)
    if absent is not None:
        return absent
    means = [v.mean for v in values]
    return Measured(sum(means) / len(means), None, None, what, f"mean of {len(means)} scenes")


# ---------------------------------------------------------------------------------------------
# Why a cell differs


def seed_range(store: MetricsStore, model: str, horizon: int,
               metric: str) -> tuple[float, float, int] | None:
    """(min, max, number of seeds) of `metric` over training seeds (stage baseline_seed_spread,
    Y-net's from metrics/ynet_seeds/); None where fewer than two seeds were trained."""
    record = store.record(SEED_SPREAD_FILE)
    entries = record.get("entries") if isinstance(record, dict) else None
    for entry in entries if isinstance(entries, list) else []:
        if not isinstance(entry, dict) or (entry.get("model"), entry.get("horizon")) != (
                model, horizon):
            continue
        spread = (entry.get("over_training_seeds") or {}).get(metric) or {}
        seeds = entry.get("seeds") or []
        if is_number(spread.get("min")) and is_number(spread.get("max")) and len(seeds) > 1:
            return float(spread["min"]), float(spread["max"]), len(seeds)
    return None


def within(diff: float | None, far: float) -> bool:
    return diff is not None and abs(diff) <= far


def why_differs(paper: float, headline_diff: float | None, own_diff: float | None, far: float,
                source: CellSource | None, seeds: tuple[float, float, int] | None = None,
                test_selected_diff: float | None = None,
                budget: BudgetPoint | None = None) -> Why:
    """How a cell stands. Where ours is scored under the cell's own protocol, that number decides
    (a headline within `far` does not make a match when the cell's own protocol does not);
    elsewhere the headline does. `match` when the deciding number is within `far` and so is the
    headline; `protocol` when only ours under the cell's own protocol is; otherwise the first
    cause that holds: `seed spread` (the paper's number lies within our range over training
    seeds, ends included), `protocol` where ours with upstream's epochs selected on the test set
    (`test_selected_diff`, a compat diagnostic) is within `far`, `budget` where the longer run
    closes at least BUDGET_CLOSES of the gap; else `unexplained`, listing what was measured."""
    protocol = source.protocol if source else HEADLINE_PROTOCOL
    own_scored = own_diff is not None and protocol not in (HEADLINE_PROTOCOL, "unknown")
    if within(own_diff if own_scored else headline_diff, far):
        if within(headline_diff, far):
            return Why("match")
        return Why("protocol", f"within {far:.0%} under {PROTOCOL_LABELS[protocol]} "
                               f"({own_diff * 100:+.1f} %)")
    if seeds is not None and seeds[0] <= paper <= seeds[1]:
        return Why("seed spread", f"paper {paper:g} within our {seeds[2]} training seeds' range "
                                  f"{seeds[0]:.3g}-{seeds[1]:.3g}")
    if within(test_selected_diff, far):
        return Why("protocol", f"within {far:.0%} only with epochs selected on the test set, as "
                               f"upstream's training loop selects them (compat diagnostic, "
                               f"{test_selected_diff * 100:+.1f} %)")
    closes = budget.closes(paper) if budget is not None else None
    budget_line = (f"{budget.factor}x the epochs closes {closes:.0%} of the gap "
                   f"({budget.ours_1x:.3g} -> {budget.ours:.3g})" if closes is not None else "")
    if closes is not None and closes >= BUDGET_CLOSES:
        return Why("budget", budget_line)
    return Why("unexplained", "; ".join(measured_lines(
        headline_diff, own_diff if own_scored else None, protocol, far, paper, seeds,
        test_selected_diff, budget_line)))


def measured_lines(headline_diff: float | None, own_diff: float | None, protocol: str, far: float,
                   paper: float, seeds: tuple[float, float, int] | None,
                   test_selected_diff: float | None, budget_line: str) -> list[str]:
    """What was measured for an unexplained cell and did not bring it within `far`."""
    lines = []
    if own_diff is not None:
        lines.append(f"{own_diff * 100:+.1f} % under {PROTOCOL_LABELS[protocol]}, "
                     f"{headline_diff * 100:+.1f} % under our headline")
    if seeds is not None:
        lines.append(f"paper {paper:g} outside our {seeds[2]} training seeds' range "
                     f"{seeds[0]:.3g}-{seeds[1]:.3g}")
    else:
        lines.append("one training seed")
    if test_selected_diff is not None:
        lines.append(f"{test_selected_diff * 100:+.1f} % with epochs selected on the test set "
                     "(compat)")
    lines.append(budget_line or "no longer training measured")
    return lines


def glance_counts(verdicts: list[str]) -> dict[str, int]:
    """Compared cells per verdict ("match", then each cause), every verdict listed."""
    return {verdict: verdicts.count(verdict) for verdict in VERDICTS}


# ---------------------------------------------------------------------------------------------
# A table's footnotes and its list of differences


def source_notes(cells: list[tuple[str, CellSource]]
                 ) -> tuple[tuple[SourceNote, ...], dict[CellSource, str]]:
    """One footnote per (measured_by, source, protocol) of a table's cells, (column label,
    source) in reading order, marked q1, q2 ... where quoted and a1, a2 ... where the Y-net
    authors measured; and each cell source's mark."""
    notes: dict[tuple[str, str, str], SourceNote] = {}
    marks: dict[CellSource, str] = {}
    for label, source in cells:
        key = (source.measured_by, source.source, source.protocol)
        if key not in notes:
            prefix = "q" if source.quoted else "a"
            number = 1 + sum(note.mark.startswith(prefix) for note in notes.values())
            notes[key] = SourceNote(f"{prefix}{number}", *key, ())
        note = notes[key]
        if label not in note.labels:
            notes[key] = note = SourceNote(note.mark, *key, (*note.labels, label))
        marks[source] = note.mark
    return tuple(notes.values()), marks


def difference_lines(cells: list[tuple[str, Why]]) -> tuple[tuple[str, str, tuple[str, ...]], ...]:
    """(cause, detail, the cells' names) for every cell that differs, cells of one cause and
    detail together, causes in the order of CAUSES."""
    grouped: dict[tuple[str, str], list[str]] = {}
    for name, why in cells:
        if why.verdict != "match":
            grouped.setdefault((why.verdict, why.detail), []).append(name)
    order = sorted(grouped, key=lambda key: CAUSES.index(key[0]))
    return tuple((cause, detail, tuple(grouped[(cause, detail)])) for cause, detail in order)
