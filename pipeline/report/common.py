"""What the report's parts share: the paper's models (those this pipeline runs, their series
labels and colours, then every registered model's), the long-term tables' horizon and K_e, a
benchmark's columns of the paper's long-term tables, the relative difference, the videos' order,
and the slot a figure is drawn into.

The lowest module of the page: its parts (`tables`, `series`, `figures`, `seed_spread`,
`data_and_segmentation`, `run_provenance`) and their assembler `pipeline.report.page` import it;
it imports none of them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from pipeline.model_list import PAPER_MODEL_NAMES, ours_first
from pipeline.models import ModelEntry, all_models

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.benchmarks.base import Benchmark

METRICS = ("ade", "fde")
# The paper's models this pipeline trains or evaluates with stages of their own; any other model
# of the paper is "paper only". Every model registered in params.yaml `models` (README "Your model
# here"; constant velocity is one) follows them: `horizon_models`, `model_colours`.
PIPELINE_MODELS = frozenset(PAPER_MODEL_NAMES)
LONG_TERM_TF = 30  # the long-term tables' horizon (s)
LONG_TERM_KE = 20  # and their K_e (baselines: K)


def horizon_models(registered: Mapping[str, ModelEntry]) -> tuple[tuple[str, str], ...]:
    """(key, label) of every model with a series per horizon, Y-net first: the paper's, then the
    registered."""
    return tuple((m.name, m.label) for m in ours_first(all_models(registered), key=lambda m: m.name))


def table_models(registered: Mapping[str, ModelEntry]) -> tuple[tuple[str, str], ...]:
    """(key, label) of every model in the paper's tables' order, then the registered."""
    return tuple((m.name, m.label) for m in all_models(registered))


def model_colours(registered: Mapping[str, ModelEntry]) -> dict[str, str]:
    return {m.name: m.colour for m in all_models(registered)}


# The paper's models alone (no registry at hand: a figure's or a table's default).
HORIZON_MODELS = horizon_models({})
MODEL_COLOURS = model_colours({})


def paper_columns(spec: Mapping, benchmark: Benchmark) -> list[Mapping]:
    """The columns of a paper table's `spec` (Tables 3-4) that are `benchmark`'s."""
    return [c for c in spec["columns"] if c["dataset"] == benchmark.paper_key]


def relative_difference(ours: float, paper: float | None) -> float | None:
    """(ours - paper) / paper: signed, so 'lower than the paper' reads as negative."""
    if paper is None or paper == 0:
        return None
    return (ours - paper) / paper


def video_sort_key(name: str) -> tuple[str, int]:
    scene, _, k = name.rpartition("_")
    return (scene, int(k)) if k.isdigit() else (name, -1)


@dataclass(frozen=True)
class FigureSlot:
    """Where a figure is drawn (the staged folder) and how the page will refer to it."""
    path: Path
    src: str
