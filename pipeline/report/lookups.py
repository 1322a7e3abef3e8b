"""Reading the metrics files defensively: every value the report shows is found here, or the reason
it is not (`Absent`: missing file, a stage's status record, an unreadable or mismatching value).

A metrics value is a number (measured once) or {"mean", "std", ...} over seeded rounds
(`pipeline.harness.metrics.seeded_rounds`); a file may also be a status record
{"status", "reason"} or carry {"not_run_reason"} where a stage (or one model in it) did not run.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class Absent:
    """A value we do not have, and why (shown in words in its place)."""
    reason: str
    kind: str = "missing"  # missing | status | invalid


@dataclass(frozen=True)
class Measured:
    """A number the pipeline measured: mean over evaluation rounds and its spread."""
    mean: float
    std: float | None
    rounds: int | None
    source: str
    note: str = ""
    mismatch: str = ""  # measured under other settings than the cell's (profile, K): not compared


@dataclass(frozen=True)
class MetricsStore:
    """Every metrics file found, parsed (or the reason it could not be), by relative path."""
    root: str
    files: Mapping[str, Any]

    def where(self, rel: str) -> str:
        return f"{self.root}/{rel}"

    def record(self, rel: str) -> Any:
        """The parsed file, or an `Absent` saying why there is none."""
        if rel not in self.files:
            return Absent(f"stage not yet run: {self.where(rel)} missing")
        value = self.files[rel]
        if isinstance(value, dict) and "status" in value and value["status"] not in ("ok", "done"):
            reason = value.get("reason") or str(value["status"])
            return Absent(f"{reason} ({self.where(rel)})", "status")
        return value


def load_metrics(folder: Path, name: str | None = None) -> MetricsStore:
    """Parse every `*.json` under `folder`; an unreadable file is recorded as an `Absent`."""
    files: dict[str, Any] = {}
    root = name or folder.as_posix()
    if folder.is_dir():
        for path in sorted(folder.rglob("*.json")):
            rel = path.relative_to(folder).as_posix()
            try:
                files[rel] = json.loads(path.read_text())
            except (OSError, ValueError) as e:
                files[rel] = Absent(f"{root}/{rel} unreadable: {e}", "invalid")
    return MetricsStore(root, files)


def is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def dig(node: Any, *keys: str) -> Any:
    """node[k1][k2]... or None where a level is missing (a record read as far as it goes)."""
    for key in keys:
        if not isinstance(node, Mapping) or key not in node:
            return None
        node = node[key]
    return node


def as_measured(node: Any, rounds: Any, source: str, note: str = "") -> Measured | Absent:
    """A metric node -> `Measured`: a number (no spread) or {"mean", "std"} over rounds. The std
    of a single round (0 by definition) is no measured spread and is dropped."""
    if isinstance(node, dict):
        mean, std, rounds = node.get("mean"), node.get("std"), node.get("rounds", rounds)
    else:
        mean, std = node, None
    if not is_number(mean):
        return Absent(f"{source} is not a finite number ({mean!r})", "invalid")
    rounds = int(rounds) if is_number(rounds) else None
    spread = float(std) if is_number(std) and rounds != 1 else None
    return Measured(float(mean), spread, rounds, source, note)


def horizon_mismatch(store: MetricsStore, rel: str, record: Any, t_f: int | None) -> Absent | None:
    """A file for another horizon than the cell's must not be compared with it."""
    if t_f is None or not isinstance(record, dict):
        return None
    found = record.get("t_f", record.get("horizon"))
    if found is not None and found != t_f:
        return Absent(f"{store.where(rel)} is for t_f = {found} s, not {t_f} s", "invalid")
    return None


def settings_mismatch(found: Mapping[str, Any], expected: Mapping[str, Any]) -> str:
    """"" when every setting a file records agrees with the cell's, else what differs (a setting
    the file does not record is not held against it)."""
    differ = [key for key, value in expected.items() if key in found and found[key] != value]
    if not differ:
        return ""
    return (f"measured with {', '.join(f'{k} = {found[k]}' for k in differ)}; this cell is for "
            f"{', '.join(f'{k} = {expected[k]}' for k in differ)}")


def horizon_checked(store: MetricsStore, rel: str, t_f: int | None) -> Any:
    """The record of `rel`, or an `Absent` when there is none or it is for another horizon."""
    record = store.record(rel)
    if isinstance(record, Absent):
        return record
    return horizon_mismatch(store, rel, record, t_f) or record


def lookup(store: MetricsStore, rel: str, path: tuple[str, ...], t_f: int | None = None,
           expect: Mapping[str, Any] | None = None) -> Measured | Absent:
    """The value at `path` in file `rel`, or why it is not there. `expect`: the settings the cell
    is for (e.g. profile, k, k_e); the file's own, read along the path (the innermost wins), must
    agree, or the value comes back marked with the `mismatch`."""
    record = horizon_checked(store, rel, t_f)
    if isinstance(record, Absent):
        return record
    node, rounds, found = record, None, {}
    for key in path:
        if isinstance(node, dict) and isinstance(node.get("not_run_reason"), str):
            return Absent(node["not_run_reason"], "status")  # a stage (or one model in it) said why
        if not isinstance(node, dict) or key not in node:
            return Absent(f"{store.where(rel)} has no {'.'.join(path)}", "invalid")
        rounds = node.get("rounds", rounds)  # the innermost count applies (an ablation may differ)
        found |= {name: node[name] for name in (expect or {}) if name in node}
        node = node[key]
    value = as_measured(node, rounds, f"{store.where(rel)}: {'.'.join(path)}")
    return with_mismatch(value, found, expect)


def with_mismatch(value: Measured | Absent, found: Mapping[str, Any],
                  expect: Mapping[str, Any] | None) -> Measured | Absent:
    """`value` marked with what of the settings `found` in its file differs from `expect`."""
    mismatch = settings_mismatch(found, expect or {})
    return replace(value, mismatch=mismatch) if mismatch and isinstance(value, Measured) else value


def lookup_grid(store: MetricsStore, rel: str, grid: str, match: Mapping[str, int], metric: str,
                t_f: int | None = None, expect: Mapping[str, Any] | None = None) -> Measured | Absent:
    """`metric` of the entry of list `grid` in `rel` whose keys equal `match` (e.g. k_e, k_a);
    `expect` as in `lookup` (read from the file, then the entry)."""
    record = horizon_checked(store, rel, t_f)
    if isinstance(record, Absent):
        return record
    rows = record.get(grid) if isinstance(record, dict) else record
    wanted = ", ".join(f"{key} = {value}" for key, value in match.items())
    if not isinstance(rows, list):
        return Absent(f"{store.where(rel)} has no list {grid}", "invalid")
    for row in rows:
        if isinstance(row, dict) and all(row.get(key) == value for key, value in match.items()):
            rounds = row.get("rounds", record.get("rounds") if isinstance(record, dict) else None)
            found = {name: node[name] for node in (record, row) if isinstance(node, dict)
                     for name in (expect or {}) if name in node}
            value = as_measured(row.get(metric), rounds, f"{store.where(rel)}: {grid}[{wanted}].{metric}")
            return with_mismatch(value, found, expect)
    return Absent(f"{store.where(rel)} has no {grid} entry with {wanted}", "invalid")


YNET_MAIN = {"k_e": 20, "k_a": 1}  # Y-net's main setting, scored over several rounds as "main"


def lookup_ynet_setting(store: MetricsStore, rel: str, k_e: int, k_a: int, metric: str,
                        t_f: int | None = None) -> Measured | Absent:
    """Y-net at (K_e, K_a) from a Y-net evaluation file: the main setting from its `main` entry
    (all its rounds; the grid re-scores only its first), the others from its `ka_grid`, so that
    one setting shows one number everywhere on the page."""
    if {"k_e": k_e, "k_a": k_a} == YNET_MAIN:
        return lookup(store, rel, ("main", metric), t_f=t_f)
    return lookup_grid(store, rel, "ka_grid", {"k_e": k_e, "k_a": k_a}, metric, t_f=t_f)

