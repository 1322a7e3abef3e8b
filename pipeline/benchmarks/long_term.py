"""What the long-term benchmarks (paper Tables 3 and 4: SDD, `pipeline.benchmarks.sdd_long_term`,
and inD, `pipeline.benchmarks.ind`) share as the report reads them: where their models' records
lie in metrics/, so that the report asks the benchmark instead of testing its name.
"""

from __future__ import annotations

from dataclasses import dataclass

from pipeline.benchmarks.base import Benchmark


@dataclass(frozen=True)
class LongTermBenchmark(Benchmark):
    """A long-term benchmark: the record of its Y-net scoring and where its baselines' and its
    stored predictions' scores are."""

    metrics_file: str = ""  # in metrics/: Y-net's main setting, ablation and K_a grid

    def baseline_metrics(self, model: str, t_f: int) -> tuple[str, tuple[str, ...]]:
        """(file in metrics/, keys to the record) of a baseline's scores at horizon `t_f`."""
        raise NotImplementedError

    def stored_scores(self, model: str, table: str) -> tuple[str, tuple[str, ...]]:
        """(file in metrics/, keys to the record) of a model's stored-predictions scores (stage
        `score_predictions`); `table`: the window table scored, where the benchmark has several."""
        raise NotImplementedError
