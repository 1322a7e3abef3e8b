"""What the report's parts share: the paper's models (those this pipeline runs, their series
labels and colours, then every registered model's), the long-term tables' horizon and K_e, the
relative difference, the videos' order, and the slot a figure is drawn into.

The lowest module of the page: its parts (`tables`, `series`, `figures`, `seed_spread`,
`data_and_segmentation`, `run_provenance`) and their assembler `pipeline.report.page` import it;
it imports none of them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from pipeline.models import ModelEntry

METRICS = ("ade", "fde")
# The paper's models this pipeline trains or evaluates with stages of their own; any other model
# of the paper is "paper only". Every model registered in params.yaml `models` (README "Your model
# here"; constant velocity is one) follows them: `horizon_models`, `model_colours`.
PIPELINE_MODELS = frozenset({"ynet", "sgan", "pecnet", "rpecnet"})
HORIZON_MODELS = (("ynet", "Y-net"), ("pecnet", "PECNet"), ("rpecnet", "R-PECNet"),
                  ("sgan", "S-GAN"))
MODEL_COLOURS = {"ynet": "#d62728", "pecnet": "#1f77b4", "rpecnet": "#9467bd", "sgan": "#2ca02c"}
DATASETS = {"sdd": "SDD", "ind": "inD"}
LONG_TERM_TF = 30  # the long-term tables' horizon (s)
LONG_TERM_KE = 20  # and their K_e (baselines: K)


def horizon_models(registered: Mapping[str, ModelEntry]) -> tuple[tuple[str, str], ...]:
    """(key, label) of every model with a series per horizon: the paper's, then the registered."""
    return (*HORIZON_MODELS, *((name, entry.label) for name, entry in registered.items()))


def model_colours(registered: Mapping[str, ModelEntry]) -> dict[str, str]:
    return {**MODEL_COLOURS, **{name: entry.colour for name, entry in registered.items()}}


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
