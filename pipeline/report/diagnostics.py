"""The report's section "Table 3 bracketed: diagnostics": what brackets the paper's long-term
numbers (Table 3, t_f = 30 s) from below and above, never in place of the headline.

Per model at t_f = 30 s, from `metrics/beyond/long_term.json` (stage `score_predictions`):
its K = 20 headline (min-ADE / min-FDE, independent minima) and its K = 1 score (`ade_one_sample`
/ `fde_one_sample`: the expected error of one of its K stored samples drawn at random); and for
R-PECNet, from `metrics/rpecnet_rollouts.json` (stage `rpecnet_rollouts`), the roll-out variant
whose validation FDE / ADE came nearest the paper's, scored on the test windows: labelled
"diagnostic, not the headline", with that validation ratio. Either file may be missing (an
`Absent` or None): its rows then say why in their cells; the other file's rows stay.

`table3_diagnostics(long_term, rollouts, t_f)` takes the two parsed records;
`diagnostics_from_store(store, t_f)` reads them from the page's `MetricsStore`. Both return a list
of `DiagnosticRow`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pipeline.model_list import BY_NAME, PAPER_MODELS, RPECNET
from pipeline.report.lookups import Absent, Measured, MetricsStore, as_measured, dig, is_number

TITLE = "Table 3 bracketed: diagnostics"
LONG_TERM_FILE = "beyond/long_term.json"  # relative to the metrics folder
ROLLOUTS_FILE = "rpecnet_rollouts.json"
# The paper's Table 3 order, then the registered models; a model scored on another table of the horizon
# (Y-net on the release's windows) comes after the horizon table's, labelled with that table.
MODELS = tuple((model.name, model.label) for model in PAPER_MODELS)  # the page adds the registered
HEADLINE, ONE_SAMPLE, DIAGNOSTIC = ("K = 20 (headline)", "K = 1 (one sample)",
                                    "diagnostic, not the headline")
ROLLOUT_MODEL = RPECNET


@dataclass(frozen=True)
class DiagnosticRow:
    """One line of the section: a model, under one setting, on one window table."""

    model: str  # the record's key: sgan, pecnet, rpecnet, ynet, constant_velocity
    label: str  # "R-PECNet", "Y-net, release_tf30 windows", "R-PECNet, roll-out original_frame"
    table: str  # the window table: tf30, release_tf30
    setting: str  # HEADLINE, ONE_SAMPLE or DIAGNOSTIC
    ade: Measured | Absent  # px; mean and std over the stored rounds where there are several
    fde: Measured | Absent
    fde_over_ade: float | None  # ratio of the two means; None where either is absent
    note: str = ""  # DIAGNOSTIC: the variant's validation FDE / ADE and the target it was chosen by


def ratio(ade: Measured | Absent, fde: Measured | Absent) -> float | None:
    """FDE / ADE of the two means (as the paper's table gives them), None where one is absent."""
    if isinstance(ade, Measured) and isinstance(fde, Measured) and ade.mean > 0:
        return fde.mean / ade.mean
    return None


def usable(record: Any, source: str, needs: str) -> Mapping[str, Any] | Absent:
    """`record` if it is a mapping holding `needs`, else why not (None: the file is missing)."""
    if record is None:
        return Absent(f"stage not yet run: {source} missing")
    if isinstance(record, Absent):
        return record
    if not isinstance(record, Mapping) or not isinstance(record.get(needs), Mapping):
        return Absent(f"{source} has no {needs}", "invalid")
    return record


def metric(entry: Any, key: str, rounds: Any, source: str) -> Measured | Absent:
    """`entry["metrics"][key]` ({"mean", "std"}) as `Measured`, or why not."""
    node = entry.get("metrics", {}).get(key) if isinstance(entry, Mapping) else None
    if node is None:
        return Absent(f"{source} has no metrics.{key} (re-run its stage)", "invalid")
    return as_measured(node, rounds, f"{source}.metrics.{key}")


def model_rows(entry: Any, model: str, label: str, table: str, source: str
               ) -> list[DiagnosticRow]:
    """The K = 20 and K = 1 rows of one model's record on one table (`score_file`'s layout)."""
    where = f"{source}: tables.{table}.models.{model}"
    if isinstance(entry, Mapping) and isinstance(entry.get("not_run_reason"), str):
        why = Absent(entry["not_run_reason"], "status")
        return [DiagnosticRow(model, label, table, s, why, why, None)
                for s in (HEADLINE, ONE_SAMPLE)]
    rounds = entry.get("rounds") if isinstance(entry, Mapping) else None
    rows = []
    for setting, (ade_key, fde_key) in ((HEADLINE, ("ade", "fde")),
                                        (ONE_SAMPLE, ("ade_one_sample", "fde_one_sample"))):
        ade, fde = (metric(entry, k, rounds, where) for k in (ade_key, fde_key))
        rows.append(DiagnosticRow(model, label, table, setting, ade, fde, ratio(ade, fde)))
    return rows


def long_term_rows(record: Mapping[str, Any], t_f: int, models: Sequence[tuple[str, str]],
                   source: str) -> list[DiagnosticRow]:
    """Every model of `models` on the horizon table `tf<t_f>`, then on the other tables of that
    horizon (labelled with the table), two rows each."""
    names, horizon = dict(models), f"tf{t_f}"
    tables = [horizon] + [name for name, node in record["tables"].items()
                          if name != horizon and isinstance(node, Mapping)
                          and node.get("t_f") == t_f]
    rows = []
    for table in tables:
        node = record["tables"].get(table)
        scored = node.get("models", {}) if isinstance(node, Mapping) else {}
        for key, label in models if table == horizon else [(k, names.get(k, k)) for k in scored]:
            if key in scored:
                shown = label if table == horizon else f"{label}, {table} windows"
                rows += model_rows(scored[key], key, shown, table, source)
    return rows


def rollout_row(record: Mapping[str, Any] | Absent, t_f: int, label: str, source: str
                ) -> DiagnosticRow:
    """R-PECNet's chosen roll-out on the test windows (`rpecnet_rollouts` layout), or why not."""
    horizon = f"tf{t_f}"
    node = (record["horizons"].get(horizon) if not isinstance(record, Absent) else None)
    if isinstance(record, Absent) or not isinstance(node, Mapping):
        why = record if isinstance(record, Absent) else Absent(
            f"{source} has no horizons.{horizon}", "invalid")
        return DiagnosticRow(ROLLOUT_MODEL, f"{label}, compounding roll-out", horizon, DIAGNOSTIC,
                             why, why, None)
    chosen, where = node.get("chosen"), f"{source}: horizons.{horizon}.test"
    ade, fde = (as_measured(dig(node, "test", k), 1, f"{where}.{k}") for k in ("ade", "fde"))
    val = dig(node, "choice", "variants", str(chosen), "fde_over_ade")
    target = record.get("target_fde_over_ade")
    split = dig(node, "choice", "split") or "val"
    note = (f"chosen on {split}: FDE / ADE {val:.2f}" if is_number(val)
            else f"no {split} FDE / ADE recorded for {chosen}")
    if is_number(target):
        note += f" (the variant nearest {target:.2f})"
    return DiagnosticRow(ROLLOUT_MODEL, f"{label}, roll-out {chosen}", horizon, DIAGNOSTIC,
                         ade, fde, ratio(ade, fde), note)


def table3_diagnostics(long_term: Any, rollouts: Any, t_f: int = 30,
                       models: Sequence[tuple[str, str]] = MODELS,
                       long_term_source: str = f"metrics/{LONG_TERM_FILE}",
                       rollouts_source: str = f"metrics/{ROLLOUTS_FILE}"
                       ) -> list[DiagnosticRow]:
    """The section's rows: per model of `models` at `t_f` its HEADLINE and ONE_SAMPLE rows (from
    `long_term`, stage score_predictions' record), R-PECNet's DIAGNOSTIC row right after its own
    (from `rollouts`, stage rpecnet_rollouts' record). A record that is None (missing), an
    `Absent` or malformed gives rows whose cells are `Absent` with the reason: one row per model
    of `models` for the long-term part, so the section keeps its shape."""
    names = dict(models)
    lt = usable(long_term, long_term_source, "tables")
    if isinstance(lt, Absent):
        rows = [DiagnosticRow(key, label, f"tf{t_f}", setting, lt, lt, None)
                for key, label in models for setting in (HEADLINE, ONE_SAMPLE)]
    else:
        rows = long_term_rows(lt, t_f, models, long_term_source)
    rollout_label = names.get(ROLLOUT_MODEL, BY_NAME[ROLLOUT_MODEL].label)
    diagnostic = rollout_row(usable(rollouts, rollouts_source, "horizons"), t_f, rollout_label,
                             rollouts_source)
    at = [i for i, r in enumerate(rows) if r.model == ROLLOUT_MODEL and r.table == f"tf{t_f}"]
    position = at[-1] + 1 if at else len(rows)
    return rows[:position] + [diagnostic] + rows[position:]


def diagnostics_from_store(store: MetricsStore, t_f: int = 30,
                           models: Sequence[tuple[str, str]] = MODELS) -> list[DiagnosticRow]:
    """`table3_diagnostics` of the page's metrics folder (`beyond/long_term.json`,
    `rpecnet_rollouts.json`), each missing or unreadable file said in its rows."""
    return table3_diagnostics(store.record(LONG_TERM_FILE), store.record(ROLLOUTS_FILE), t_f,
                              models, store.where(LONG_TERM_FILE), store.where(ROLLOUTS_FILE))
