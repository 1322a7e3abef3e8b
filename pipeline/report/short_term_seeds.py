"""Tables 1-2's training-seed spread: each short-term baseline's headline run (training seed
`train_baseline.seed`, metrics/short_term/runs/) beside its study runs with other training seeds
(studies/short_term_seeds/, made by `tools/run_study.py`, never by `make repro`), all scored the
same way. From them, per benchmark, model, K and metric: every seed's value and machine, the range
a paper number must lie in for the cause "seed spread", and for ETH/UCY the range of the
five-fold average over the seeds run on every fold.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from pipeline.benchmarks.ethucy import FOLDS
from pipeline.benchmarks.registry import SHORT_TERM
from pipeline.model_list import SHORT_TERM_MODELS
from pipeline.report.lookups import MetricsStore, dig, is_number

HEADLINE_RUN = "short_term/runs/{dataset}_{model}.json"  # in the metrics store
HEADLINE_CPU = "not recorded in its metrics"
STUDY_RUN = "{dataset}_{model}_seed{seed}.json"  # in the studies store
ETHUCY_FOLDS = tuple(FOLDS)  # their average is Table 2's AVG row
SEEDED_MODELS = SHORT_TERM_MODELS  # the study trains each of them with several seeds


@dataclass(frozen=True)
class SeedRun:
    """One training of one model on one benchmark: its seed, where it ran, its test numbers."""
    seed: int
    cpu: str
    headline: bool  # the run the tables show
    values: Mapping[str, float]  # "k20.ade", "k20.fde", "k5.ade", ...
    source: str


def run_values(record: Any) -> dict[str, float]:
    """{"k<K>.<metric>": mean over evaluation rounds} of a short-term run record."""
    values = {}
    for k in record.get("ks", []) if isinstance(record, Mapping) else []:
        for metric in ("ade", "fde"):
            mean = dig(record, f"k{k}", metric, "mean")
            if is_number(mean):
                values[f"k{k}.{metric}"] = float(mean)
    return values


def seed_runs(metrics: MetricsStore, studies: MetricsStore, dataset: str, model: str,
              headline_seed: int) -> list[SeedRun]:
    """The headline run, then the study's runs in seed order (a study run of the headline's own
    seed is left out: it would count one seed twice)."""
    runs = []
    rel = HEADLINE_RUN.format(dataset=dataset, model=model)
    headline = metrics.files.get(rel)
    if isinstance(headline, Mapping) and run_values(headline):
        runs.append(SeedRun(headline_seed, HEADLINE_CPU, True, run_values(headline),
                            metrics.where(rel)))
    for rel, record in sorted(studies.files.items()):
        seed = record.get("training_seed") if isinstance(record, Mapping) else None
        if (rel == STUDY_RUN.format(dataset=dataset, model=model, seed=seed)
                and seed != headline_seed and run_values(record)):
            runs.append(SeedRun(int(seed), str(dig(record, "machine", "cpu") or "unknown"), False,
                                run_values(record), studies.where(rel)))
    return sorted(runs, key=lambda run: (not run.headline, run.seed))


def value_range(values: list[float]) -> tuple[float, float, int] | None:
    """(min, max, count) over two or more seeds; None with fewer (one seed has no spread)."""
    return (min(values), max(values), len(values)) if len(values) >= 2 else None


def seed_range(runs: list[SeedRun], key: str) -> tuple[float, float, int] | None:
    return value_range([run.values[key] for run in runs if key in run.values])


def average_range(per_fold: Mapping[str, list[SeedRun]], key: str) -> tuple[float, float, int] | None:
    """The range over seeds of the five folds' average, over the seeds run on every fold."""
    by_seed = [{run.seed: run.values[key] for run in runs if key in run.values}
               for runs in per_fold.values()]
    common = set.intersection(*(set(seeds) for seeds in by_seed)) if by_seed else set()
    return value_range([sum(seeds[s] for seeds in by_seed) / len(by_seed) for s in sorted(common)])


@dataclass(frozen=True)
class ShortTermSeeds:
    """Every short-term baseline's seed runs, by (dataset, model)."""
    runs: Mapping[tuple[str, str], list[SeedRun]]

    def range(self, dataset: str, model: str, k: int, metric: str) -> tuple[float, float, int] | None:
        return seed_range(self.runs.get((dataset, model), []), f"k{k}.{metric}")

    def per_seed(self, dataset: str, model: str, k: int, metric: str) -> tuple[tuple[int, float], ...]:
        """(training seed, value) of every run that has the number, in seed order."""
        key = f"k{k}.{metric}"
        return tuple(sorted((run.seed, run.values[key]) for run in self.runs.get((dataset, model), [])
                            if key in run.values))

    def average(self, model: str, metric: str, k: int = 20) -> tuple[float, float, int] | None:
        return average_range({fold: self.runs.get((fold, model), []) for fold in ETHUCY_FOLDS},
                             f"k{k}.{metric}")


def short_term_seeds(metrics: MetricsStore, studies: MetricsStore,
                     headline_seed: int) -> ShortTermSeeds:
    return ShortTermSeeds({(dataset, model): seed_runs(metrics, studies, dataset, model,
                                                       headline_seed)
                           for dataset in SHORT_TERM for model in SEEDED_MODELS})


def seed_rows(seeds: ShortTermSeeds, k: int = 20) -> list[dict[str, Any]]:
    """The page's table: per benchmark and model, each seed's K = `k` ADE / FDE and machine, and
    the range over seeds (None with one seed)."""
    rows = []
    for (dataset, model), runs in seeds.runs.items():
        if not runs:
            continue
        rows.append({"dataset": dataset, "model": model,
                     "runs": [{"seed": run.seed, "headline": run.headline, "cpu": run.cpu,
                               "ade": run.values.get(f"k{k}.ade"), "fde": run.values.get(f"k{k}.fde"),
                               "source": run.source} for run in runs],
                     "ade": seed_range(runs, f"k{k}.ade"), "fde": seed_range(runs, f"k{k}.fde")})
    return rows
