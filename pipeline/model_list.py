"""The paper's models, written out once: their names, how the report shows them, what each runs.

Every other list of models derives from this one: the trained baselines of `pipeline.config` (and so
the short-term stages' choices), the names a registered model may not take (`pipeline.models`),
the report's labels, colours and series (`pipeline.models.all_models` adds the models registered in
params.yaml `models` after these), the seed-spread study's models, inD's baselines; and
`tests/test_model_list.py` holds `dvc.yaml`'s matrices and plots to it.

The order is the paper's tables' (Table 3: S-GAN, PECNet, R-PECNet, then Y-net); a view that puts
Y-net first (the figures, the short-term tables) uses `ours_first`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TypeVar


@dataclass(frozen=True)
class PaperModel:
    """One of the paper's models as this pipeline runs it."""

    name: str  # its stages' and files' key: metrics/baselines/<name>_tf<H>.json, ...
    label: str  # how the report names it
    colour: str  # "#rrggbb", the same in every figure
    short_term: bool  # trained and scored on the short-term benchmarks (Tables 1 and 2)
    trains: bool  # a baseline with weights of its own (stages train_baseline@<name>-<t_f>, ...)
    trained_as: str | None = None  # whose trained weights it runs (R-PECNet: the t_f = 5 PECNet)
    ours: bool = False  # the paper's own model (Y-net), not a baseline


# Each model's name, for code about that one model (R-PECNet's roll-out, Y-net's own files); code
# about several goes through the lists below.
SGAN = "sgan"
PECNET = "pecnet"
RPECNET = "rpecnet"
YNET = "ynet"

PAPER_MODELS = (
    PaperModel(SGAN, "S-GAN", "#2ca02c", short_term=True, trains=True),
    PaperModel(PECNET, "PECNet", "#1f77b4", short_term=True, trains=True),
    PaperModel(RPECNET, "R-PECNet", "#9467bd", short_term=False, trains=False,
               trained_as=PECNET),
    PaperModel(YNET, "Y-net", "#d62728", short_term=True, trains=False, ours=True),
)
BY_NAME = {model.name: model for model in PAPER_MODELS}
PAPER_MODEL_NAMES = tuple(BY_NAME)
OURS = next(model.name for model in PAPER_MODELS if model.ours)

# The baselines with weights to learn (S-GAN, PECNet): `train_baseline@<model>-<t_f>` and their
# short-term stages.
TRAINED_BASELINES = tuple(model.name for model in PAPER_MODELS if model.trains)
# The long-term baselines a training seed changes (R-PECNet through its PECNet).
SEEDED_BASELINES = tuple(model.name for model in PAPER_MODELS
                         if model.trains or model.trained_as is not None)
# Every baseline, in the paper's order (inD scores these and constant velocity).
BASELINES = tuple(model.name for model in PAPER_MODELS if not model.ours)
SHORT_TERM_MODELS = tuple(model.name for model in PAPER_MODELS if model.short_term)

Named = TypeVar("Named")


def ours_first(names: Iterable[Named], key=lambda item: item) -> list[Named]:
    """`names` (or items named by `key`) with Y-net moved to the front, the others in order."""
    items = list(names)
    return [item for item in items if key(item) == OURS] + [item for item in items
                                                             if key(item) != OURS]


# The short-term models, Y-net first: the order of the short-term tables (Tables 1 and 2) and the
# keys of params.yaml `short_term_models.<profile>.epochs`.
SHORT_TERM_MODELS_OURS_FIRST = tuple(ours_first(SHORT_TERM_MODELS))


def label(name: str) -> str:
    """The report's name for paper model `name` (the name itself for any other)."""
    return BY_NAME[name].label if name in BY_NAME else name
