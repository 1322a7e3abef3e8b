"""The long-term SDD benchmark (paper Table 3 and the horizon study): windows of 5 s observed and
t_f seconds predicted at 1 FPS, cut by stages `windows` (the raw and the authors' release tables,
`data/windows/{raw_tf*, release_tf30}.parquet`) and `horizon_windows` (one table per horizon,
`data/horizon_windows/tf<t_f>.parquet`; `pipeline.data.windows`, `pipeline.data.horizon_windows`).
Errors in original image pixels; metres per pixel from SDD's `estimated_scales.yaml` per video
(`read_scales`); scene masks from the hand labels of `data/labels` (`sdd_label_masks`).

Each window table is a benchmark of its own in a predictions file's metadata
(`SddLongTerm.prediction_benchmark`): window ids belong to their table.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from pipeline.benchmarks.base import SceneMasks, ScoredTable, class_values
from pipeline.benchmarks.long_term import LongTermBenchmark
from pipeline.data.labels import read_index, read_label_map
from pipeline.io import IntermediateError


@dataclass(frozen=True)
class SddLongTerm(LongTermBenchmark):
    """The long-term SDD benchmark: one window table per horizon (and the release's), every window
    of a table scored in original pixels; a record per horizon of each baseline."""

    def baseline_metrics(self, model: str, t_f: int) -> tuple[str, tuple[str, ...]]:
        """A baseline's own file per horizon (stage `evaluate_baseline`)."""
        return f"baselines/{model}_tf{t_f}.json", ()

    def stored_scores(self, model: str, table: str) -> tuple[str, tuple[str, ...]]:
        """The long-term record of `score_predictions`, a table per window table."""
        return "beyond/long_term.json", ("tables", table, "models", model)

    def prediction_benchmark(self, table: Path) -> str:
        """The benchmark a long-term SDD window table defines, named after the table's file:
        `sdd_long_term_tf<H>` for the horizon tables (`data/horizon_windows/tf<H>.parquet`),
        `sdd_long_term_release_tf30` for the release's (`data/windows/release_tf30.parquet`).
        Window ids belong to their table, so two tables are two benchmarks even where their
        windows agree (the release's t_f = 30 test windows equal the horizon table's, under other
        ids)."""
        return f"{self.name}_{Path(table).stem}"

    def prediction_metadata(self, model: str, table: Path) -> dict[str, Any]:
        """What a stored long-term SDD test predictions file records first: the model, the
        benchmark of the window table scored (`prediction_benchmark`), the unit and split, and the
        table."""
        return {"model": model, "benchmark": self.prediction_benchmark(table), "unit": self.unit,
                "split": self.split, "window_table": str(table)}

    def scored_table(self, table: Path, n_past: int, masks: SceneMasks,
                     scales: Mapping[str, float], scales_path: Path) -> ScoredTable:
        """A long-term SDD window table as scoring sees it: original pixels, every window (the
        files of a table hold its test windows, ids checked against the whole table), the hand
        labels and SDD's estimated scales."""
        return ScoredTable(self.prediction_benchmark(table), Path(table), self.unit, n_past,
                           metres_per_unit=scales, scales_source=f"per video, {Path(scales_path)}",
                           masks=masks)


SDD_LONG_TERM = SddLongTerm("sdd_long_term", "SDD long-term", "px", label="SDD",
                            paper_table="sdd_long", paper_key="sdd",
                            in_paper="Table 3, SDD long term (t_f = 30 s)", study_key="sdd_long",
                            metrics_file="ynet_eval.json")


def read_scales(path: Path) -> dict[str, float]:
    """{'<scene>_<k>': metres per original image pixel} from SDD's `estimated_scales.yaml`
    ({scene: {video<k>: {scale, certainty}}}); an IntermediateError naming the file and entry."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as e:
        raise IntermediateError(f"{path}: unreadable: {e}") from e
    scales = {}
    for scene, videos in (raw or {}).items():
        for video, entry in (videos or {}).items():
            scale = entry.get("scale") if isinstance(entry, dict) else None
            if not (str(video).startswith("video") and isinstance(scale, int | float)
                    and scale > 0):
                raise IntermediateError(f"{path}: {scene}.{video}: expected video<k> with a "
                                        f"positive scale, got {entry!r}")
            scales[f"{scene}_{str(video)[len('video'):]}"] = float(scale)
    return scales


def sdd_label_masks(labels_dir: Path, forbidden_classes: Sequence[str]) -> SceneMasks:
    """SDD's hand-labelled class masks (`data/labels`, at the original image resolution, every
    video the index lists), each checked against the index's size when read."""
    labels_dir = Path(labels_dir)
    sizes = read_index(labels_dir)["videos"]  # name -> {height, width, ...}

    def read(name: str) -> np.ndarray:
        mask = read_label_map(labels_dir, name)
        size = (sizes[name]["height"], sizes[name]["width"])
        if mask.shape != size:
            raise IntermediateError(f"{labels_dir}/maps/{name}.png is {mask.shape}, "
                                    f"index.json says {size}")
        return mask

    return SceneMasks(f"hand labels {labels_dir.as_posix()}",
                      class_values(forbidden_classes), tuple(forbidden_classes),
                      frozenset(sizes), read)

