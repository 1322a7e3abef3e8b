"""Where each of the paper's numbers came from, and why ours may differ from it.

A paper cell is measured by the Y-net authors or quoted from another paper, under one of the
best-of-K protocols of the upstream codebases (`PROTOCOLS`). `load_paper_values` reads
`paper_values.yaml` and gives every cell its `CellSource` (a field written once per model holds for
all of its cells), failing with the table and cell named when a field is missing or unknown.

Ours under a cell's own protocol comes from the stored-prediction scores (stage
`score_short_term_predictions`: `beyond/short_term.json`; `score_predictions`:
`beyond/long_term.json`, `beyond/ind.json`), "not scored" where the key is not there.
`why_differs` names the cause of a difference beyond the report's `far` band: `protocol` and
`seed spread` are computed from our metrics (`protocol` also where only upstream PECNet's epoch
selection on the test set, retrained as a compat diagnostic, brings ours within it); `source` and `budget` only where the yaml gives a
note; `unknown` otherwise.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

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
WRITTEN_CAUSES = ("source", "budget")  # only from a `differs_because` note
COMPUTED_CAUSES = ("protocol", "seed spread")  # only from our metrics
CAUSES = ("protocol", "seed spread", "source", "budget", "unknown")
VERDICTS = ("match", *CAUSES)  # "match": within `far` under the headline protocol
FIELDS = ("measured_by", "source", "protocol", "differs_because")
SHORT_TERM_SCORES = "beyond/short_term.json"
LONG_TERM_SCORES = "beyond/long_term.json"
IND_SCORES = "beyond/ind.json"
SEED_SPREAD_FILE = "baseline_seed_spread.json"
# Upstream PECNet's test-set epoch selection, retrained per ETH/UCY fold (a compat diagnostic).
TEST_SELECTION_FILE = "short_term/pecnet_test_selection/{benchmark}.json"
LONG_TERM_TEST_SELECTION_FILE = "pecnet_test_selection.json"
TEST_SELECTED_MODELS = ("pecnet",)
TEST_SELECTION_PROTOCOLS = {"pecnet_best_endpoint": "pecnet", "independent_min": "headline"}


class PaperValuesError(ValueError):
    """paper_values.yaml lacks a cell's provenance or has a value outside the allowed ones."""


@dataclass(frozen=True)
class Explanation:
    """A cause written in the yaml (`differs_because`), for a difference no metric can show."""
    cause: str
    note: str


@dataclass(frozen=True)
class CellSource:
    """Who measured one paper cell, where it was printed first, and under which protocol."""
    measured_by: str
    source: str
    protocol: str
    differs_because: Explanation | None = None

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
                    fields, ((metric, METRICS), (scene, scenes)),
                    f"{where}, {entry.get('label')} {metric.upper()} {scene}")
                    for scene in scenes} for metric in METRICS}
        else:
            for column in spec["columns"]:
                fields = model_fields(spec, column, where)
                name = column_name(column)
                column["cells"] = {metric: cell_source(fields, ((metric, METRICS),),
                                                       f"{where}, {name} {metric.upper()}")
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
    return {**shared, **{k: entry[k] for k in FIELDS if k in entry}}


def cell_source(fields: Mapping[str, Any], keys: tuple[tuple[str, tuple[str, ...]], ...],
                where: str) -> CellSource:
    """One cell's `CellSource`; `keys` (its metric, then scene, each with the allowed ones) pick
    its `differs_because`."""
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
    return CellSource(measured_by, source, one_of("protocol", PROTOCOLS),
                      explanation(fields.get("differs_because"), keys, where))


def explanation(node: Any, keys: tuple[tuple[str, tuple[str, ...]], ...],
                where: str) -> Explanation | None:
    """The `differs_because` note covering the cell of `keys`: given for every cell, or per
    metric, then per scene (a key outside the allowed ones fails: a typo would hide a note)."""
    for key, allowed in keys:
        if node is None or (isinstance(node, dict) and "cause" in node):
            break
        if not isinstance(node, dict) or not set(node) <= set(allowed):
            raise PaperValuesError(f"paper_values.yaml, {where}: differs_because is {node!r}; "
                                   f"give {{cause, note}} or key it by {', '.join(allowed)}")
        node = node.get(key)
    if node is None:
        return None
    if not isinstance(node, dict) or set(node) != {"cause", "note"}:
        raise PaperValuesError(f"paper_values.yaml, {where}: differs_because must be {{cause, "
                               f"note}} (for every cell, per metric or per scene), got {node!r}")
    if node["cause"] not in WRITTEN_CAUSES:
        computed = (" (computed from our metrics, never written)"
                    if node["cause"] in COMPUTED_CAUSES else "")
        raise PaperValuesError(f"paper_values.yaml, {where}: differs_because cause is "
                               f"{node['cause']!r}{computed}; written causes are "
                               f"{', '.join(WRITTEN_CAUSES)}")
    if not isinstance(node["note"], str) or not node["note"].strip():
        raise PaperValuesError(f"paper_values.yaml, {where}: differs_because has no note")
    return Explanation(node["cause"], node["note"])


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
    """Table 3's stored score: SDD baselines on the horizon table, Y-net on the release's windows
    (its main setting, K_a = 1 only), inD from its own file."""
    if k_a != 1:
        return Absent("scored at K_a = 1 only", "missing")
    if dataset == "ind":
        return stored_score(store, IND_SCORES, ("benchmarks", "ind", "models", model), key)
    table = f"release_tf{t_f}" if model == "ynet" else f"tf{t_f}"
    return stored_score(store, LONG_TERM_SCORES, ("tables", table, "models", model), key)


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
                test_selected_diff: float | None = None) -> Why:
    """How a cell stands. Where ours is scored under the cell's own protocol, that number decides
    (a headline within `far` does not make a match when the cell's own protocol does not);
    elsewhere the headline does. `match` when the deciding number is within `far` and so is the
    headline; `protocol` when only ours under the cell's own protocol is; otherwise the first
    cause that holds: `seed spread` (the paper's number lies within our range over training
    seeds), `protocol` where ours with upstream's epochs selected on the test set
    (`test_selected_diff`, a compat diagnostic) is within `far`, the yaml's note (with the compat
    figure where there is one), `unknown`."""
    protocol = source.protocol if source else HEADLINE_PROTOCOL
    own_scored = own_diff is not None and protocol not in (HEADLINE_PROTOCOL, "unknown")
    if within(own_diff if own_scored else headline_diff, far):
        if within(headline_diff, far):
            return Why("match")
        return Why("protocol", f"within {far:.0%} under {PROTOCOL_LABELS[protocol]} "
                               f"({own_diff * 100:+.1f} %)")
    if seeds is not None and seeds[0] <= paper <= seeds[1]:
        return Why("seed spread", f"paper {paper:g} within our {seeds[2]} training seeds' range "
                                  f"{seeds[0]:.2f}-{seeds[1]:.2f}")
    if within(test_selected_diff, far):
        return Why("protocol", f"within {far:.0%} only with epochs selected on the test set, as "
                               f"upstream's training loop selects them (compat diagnostic, "
                               f"{test_selected_diff * 100:+.1f} %)")
    selected = ("" if test_selected_diff is None else
                f"; {test_selected_diff * 100:+.1f} % with epochs selected on the test set (compat)")
    if source is not None and source.differs_because is not None:
        return Why(source.differs_because.cause, source.differs_because.note + selected)
    if own_scored and within(headline_diff, far):
        return Why("unknown", f"within {far:.0%} under our headline protocol, "
                              f"{own_diff * 100:+.1f} % under {PROTOCOL_LABELS[protocol]}{selected}")
    return Why("unknown", f"no protocol, seed or source explanation{selected}")


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
