"""Every benchmark of the pipeline, by name, and the short-term ones by the stages' `--dataset`:
what the rest of the pipeline asks instead of testing names.

- `sdd_long_term`: SDD at 1 FPS, 5 s observed, t_f up to 60 s (Table 3, the horizon study);
  pixels. `pipeline.benchmarks.sdd_long_term`.
- `trajnet_sdd`: TrajNet's SDD split at 2.5 FPS, 3.2 + 4.8 s (Table 1); pixels. `--dataset sdd`,
  `pipeline.benchmarks.trajnet_sdd`.
- `ethucy_<fold>`: ETH/UCY leave-one-scene-out folds (Table 2); metres. `--dataset <fold>`,
  `pipeline.benchmarks.ethucy`.
- `ind`: inD at 1 FPS, 5 + 30 s (from the user's own copy); pixels. `pipeline.benchmarks.ind`.

The long-term ones are also found by their key in the paper's Tables 3-4 (`long_term`), any one
by its name in the studies' records (`studied`) or in a scoring record (`scored`).
"""

from __future__ import annotations

from pipeline.benchmarks.base import Benchmark
from pipeline.benchmarks.ethucy import FOLDS
from pipeline.benchmarks.ind import IND
from pipeline.benchmarks.long_term import LongTermBenchmark
from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.benchmarks.short_term import ShortTermBenchmark
from pipeline.benchmarks.trajnet_sdd import TRAJNET_SDD

SHORT_TERM: dict[str, ShortTermBenchmark] = {TRAJNET_SDD.dataset: TRAJNET_SDD, **FOLDS}
LONG_TERM: dict[str, LongTermBenchmark] = {b.paper_key: b for b in (SDD_LONG_TERM, IND)}
BENCHMARKS: dict[str, Benchmark] = {benchmark.name: benchmark for benchmark in (
    SDD_LONG_TERM, *SHORT_TERM.values(), IND)}


def get(name: str) -> Benchmark:
    """The benchmark called `name` (a key of `BENCHMARKS`)."""
    if name not in BENCHMARKS:
        raise KeyError(f"no benchmark {name!r}; known: {sorted(BENCHMARKS)}")
    return BENCHMARKS[name]


def short_term(dataset: str) -> ShortTermBenchmark:
    """The short-term benchmark of a stage's `--dataset` (sdd or an ETH/UCY fold)."""
    if dataset not in SHORT_TERM:
        raise KeyError(f"no short-term dataset {dataset!r}; known: {list(SHORT_TERM)}")
    return SHORT_TERM[dataset]


def long_term(paper_key: str) -> LongTermBenchmark:
    """The long-term benchmark of a column of the paper's Tables 3-4 (its `dataset`: sdd, ind)."""
    if paper_key not in LONG_TERM:
        raise KeyError(f"no long-term benchmark {paper_key!r}; known: {list(LONG_TERM)}")
    return LONG_TERM[paper_key]


def studied(study_key: str) -> Benchmark | None:
    """The benchmark a study's record names (`Benchmark.study_key`), None for an unknown name."""
    return next((b for b in BENCHMARKS.values() if b.study_key and b.study_key == study_key), None)


def scored(key: str) -> Benchmark | None:
    """The benchmark a record of scored predictions names (`score_benchmarks`: a short-term
    `--dataset`, or a registry name: ind), None for an unknown name."""
    return SHORT_TERM.get(key) or BENCHMARKS.get(key)
