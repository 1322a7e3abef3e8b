"""A toy short-term benchmark, written as a new benchmark's module would be
(`pipeline/benchmarks/<name>.py`): tests/test_toy_benchmark.py registers it and runs the
short-term stages on it.

Its windows (8 observed + 12 future steps) lie in pixels of blank 240 x 320 scenes, in one table
`toy.parquet` of the `short_term_windows` folder; its errors are in pixels; its settings are the
ETH/UCY ones (`settings_key`); its scenes' sizes and images need no fetched raw source; scoring
its stored predictions needs no scale (pixels are its unit) and has no scene mask.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.benchmarks.base import ScoredTable
from pipeline.benchmarks.short_term import ScoringSources, ShortTermBenchmark

SCENE_HW = (240, 320)  # every toy scene's (height, width), original pixels


@dataclass(frozen=True)
class Toy(ShortTermBenchmark):
    """Pixels throughout (`ShortTermBenchmark.load`, `splits_in_unit`), on scenes of one size."""

    def scene_sizes(self, windows: Path, sdd: Path | None, scene_ids: set[str]
                    ) -> dict[str, tuple[int, int]]:
        return dict.fromkeys(scene_ids, SCENE_HW)

    def scene_images(self, windows: Path, sdd: Path | None, cameras: Path | None
                     ) -> Callable[[str], np.ndarray]:
        return lambda scene_id: np.zeros((*SCENE_HW, 3), np.uint8)

    def scored_table(self, sources: ScoringSources) -> ScoredTable:
        return ScoredTable(self.prediction_benchmark(), self.table(sources.windows), self.unit,
                           sources.n_past, self.truth_columns, self.split,
                           scales_source="a toy: no scale", masks_absent="a toy: no scene mask")


TOY = Toy("toy", "Toy benchmark", "px", label="Toy", study_key="toy", dataset="toy",
          table_file="toy.parquet", settings_key="ethucy", summary_file="toy.json", table_k=20)
