"""Stage `short_term_tables`: the per-run short-term metrics merged into the files the report reads.

Reads `<runs>/<dataset>_<model>.json` (one per run of `evaluate_short_term_ynet` / `evaluate_short_term_baseline`) and writes into
`<out>` the layout `pipeline.report.page` documents for Tables 1 and 2:

- one file a benchmark (its `summary_file`): `sdd.json`: {"profile", "unit": "px", "rounds",
  "models": {<model>: {"k20": {"ade": {"mean", "std", "rounds"}, "fde", "ade_joint",
  "fde_joint"}, "k5": {...}}}}: every K scored, by K;
- `ethucy_<fold>.json`, one per fold (= the scene the paper's row names): {"profile", "unit": "m",
  "rounds", "models": {<model>: {"ade": {...}, "fde": {...}, "ade_joint", "fde_joint"}}}: the
  one K of the benchmark's `table_k` (Table 2's K = 20).

A run that recorded why it did not happen is kept as {"not_run_reason": ...} under its model; a
missing run file leaves its model out (the report then says the value is absent). Only the summary
numbers are copied: per-round values, timings and training facts stay in the run files.

    python -m pipeline.stages.short_term_tables --runs metrics/short_term/runs --out metrics/short_term
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pipeline.benchmarks.registry import SHORT_TERM, short_term
from pipeline.benchmarks.short_term import ShortTermBenchmark
from pipeline.harness.metrics import METRIC_KEYS
from pipeline.io import write_json
from pipeline.model_list import SHORT_TERM_MODELS_OURS_FIRST

SUMMARY_KEYS = ("mean", "std", "min", "max")


def run_file(runs: Path, dataset: str, model: str) -> Path:
    return Path(runs) / f"{dataset}_{model}.json"


def cell(run: dict, k: int) -> dict:
    """{metric: {"mean", "std", ..., "rounds"}} of one run at one K."""
    result = run[f"k{k}"]
    return {key: {**{s: result[key][s] for s in SUMMARY_KEYS if s in result[key]},
                  "rounds": result["rounds"]} for key in METRIC_KEYS}


def model_entry(run: dict, benchmark: ShortTermBenchmark) -> dict:
    """What one run contributes to its benchmark's file: every K scored, or the one its table
    shows (`table_k`)."""
    if "not_run_reason" in run:
        return {"not_run_reason": run["not_run_reason"]}
    if benchmark.table_k is None:
        return {f"k{k}": cell(run, k) for k in run["ks"]}
    return cell(run, benchmark.table_k)


def tables(runs: dict[tuple[str, str], dict]) -> dict[str, dict]:
    """File name -> content, from the runs found, keyed (dataset, model)."""
    out = {}
    for dataset in SHORT_TERM:
        benchmark = short_term(dataset)
        found = {model: runs[dataset, model] for model in SHORT_TERM_MODELS_OURS_FIRST
                 if (dataset, model) in runs}
        scored = [run for run in found.values() if "not_run_reason" not in run]
        out[benchmark.summary_file] = {
            "dataset": dataset,
            "profile": next((run.get("profile") for run in found.values()), None),
            "unit": benchmark.unit,
            "rounds": max((run["rounds"] for run in scored), default=None),
            "models": {model: model_entry(run, benchmark) for model, run in found.items()},
        }
    return out


def read_runs(folder: Path) -> dict[tuple[str, str], dict]:
    runs = {}
    for dataset in SHORT_TERM:
        for model in SHORT_TERM_MODELS_OURS_FIRST:
            path = run_file(folder, dataset, model)
            if path.exists():
                runs[dataset, model] = json.loads(path.read_text())
    return runs


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, required=True, help="folder of <dataset>_<model>.json")
    parser.add_argument("--out", type=Path, required=True, help="folder of the report's files")
    args = parser.parse_args(argv)
    runs = read_runs(args.runs)
    for name, content in tables(runs).items():
        write_json(content, args.out / name)
    expected = len(SHORT_TERM) * len(SHORT_TERM_MODELS_OURS_FIRST)
    print(f"short_term_tables: {len(runs)} of {expected} runs merged")


if __name__ == "__main__":
    main()
