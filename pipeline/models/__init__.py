"""The contract a long-term model is written to, so that adding one is one file and one line.

README "Your model here" walks through it with constant velocity (`pipeline/models/
constant_velocity.py`) as the worked example.

**The file.** `pipeline/models/<name>.py` holds a class (any name) with

- `__init__(self, settings)`: `settings` is the registry line's `settings` mapping (`{}` for none);
  check it here and raise `ValueError` for a key the model does not know;
- `fit(self, train, val, workdir, seed) -> None`: learn from the `train` windows, select on
  `val` (never the test windows, which the model is not shown), and keep in `workdir` (a fresh
  empty folder, DVC output `checkpoints/models/<name>_tf<H>/`) whatever `predict` needs, as files
  named relative to it. A model with nothing to learn writes nothing. `seed` is
  `train_baseline.seed`: draw every random number from it;
- `predict(self, test, k, workdir, seed) -> (N, k, n_f, 2)`: `k` sampled futures for each of the
  `test` windows, in their order, in original image pixels; `workdir` is what `fit` left (in
  another process: read it back from the files), `seed` the round's seed (rounds r = 0 .. R-1 of
  `evaluate_baseline` are seeded `evaluate_baseline.seed + r`, as for every baseline). A
  deterministic model returns its one path k times.

Windows come as `WindowSet`s (below): the observed past `(N, n_past, 2)` of every window, the
future `(N, n_f, 2)` of train and val windows only (None for the windows predicted), the horizon
`n_future` and the ids that say where and when a window is (`scene_id`, `track_id`,
`first_frame`: windows of one scene with equal first frames are observed at the same time).
Positions are float64 pixels of the original SDD images, 1 FPS, t_f = n_f seconds.

**The line.** In `params.yaml`, section `models`:
`<name>: {class: <Class>, label: <shown in the report>, colour: "#rrggbb", settings: {...}}`
(`load_models` below checks it). DVC then has the stages `fit_model@<name>-<t_f>` and
`predict_model@<name>-<t_f>` for every horizon of `windows.horizons`, and the report a column in
Table 3, a line in Figure 4 and rows in "Beyond the paper's tables".

What the harness does around the model (`pipeline.harness.model_runs`): it reads the window
table, hands over the splits, times `fit`, calls `predict` once per seeded round, checks what it
returns (`check_predictions`: shape, finite, numeric; an error names the model), scores it with
the shared best-of-K metric and stores every round in the predictions format. A model's own
imports of project code are in its stages' code dep (`data/code_fingerprints/models/<name>.json`).
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from pipeline.config.loading import ParamsError
from pipeline.data.window_table import WindowArrays
from pipeline.model_list import PAPER_MODEL_NAMES, PAPER_MODELS

PACKAGE = __name__  # pipeline.models
FOLDER = Path(__file__).parent


# ---------------------------------------------------------------------------------------------
# The registry: section `models` of params.yaml, one line per model

MODELS_SECTION = "models"
# Names the paper's models' own stages already write under (metrics/baselines/<name>_tf<H>.json,
# data/predictions/long_term/tf<H>/<name>.parquet): a registered model may not take one.
RESERVED_MODEL_NAMES = PAPER_MODEL_NAMES
MODEL_NAME = re.compile(r"[a-z][a-z0-9_]*")
HEX_COLOUR = re.compile(r"#[0-9a-fA-F]{6}")
MODEL_KEYS = ("class", "label", "colour", "settings")


@dataclass(frozen=True)
class ModelEntry:
    """One line of section `models`: `<name>: {class, label, colour, settings}`.

    The model's code is `pipeline/models/<name>.py` (the name is also its stages' and files'
    name), `class` the class there written to the contract of `pipeline.models`, `label` and
    `colour` (#rrggbb) how the report shows it, `settings` the mapping its constructor takes
    (`{}` for none). Kept here, not in `pipeline.config` with the other sections: it is this
    contract's."""

    name: str
    class_name: str
    label: str
    colour: str
    settings: dict[str, Any]


def load_models(params: Mapping[str, Any]) -> dict[str, ModelEntry]:
    """Section `models` of `params` (params.yaml as its stage read it), in its order, each line
    checked."""
    if MODELS_SECTION not in params:
        raise ParamsError(f"params.yaml: missing section '{MODELS_SECTION}' (README \"Your model "
                          "here\"; `models: {}` registers none)")
    section = params[MODELS_SECTION]
    if section is None:
        return {}
    if not isinstance(section, dict):
        raise ParamsError(f"params.yaml:{MODELS_SECTION}: expected a mapping of model name to "
                          f"{{{', '.join(MODEL_KEYS)}}}, got {type(section).__name__}")
    return {name: model_entry(name, line) for name, line in section.items()}


def model_entry(name: Any, line: Any) -> ModelEntry:
    where = f"params.yaml:{MODELS_SECTION}.{name}"
    if not isinstance(name, str) or not MODEL_NAME.fullmatch(name):
        raise ParamsError(f"{where}: a model name is lower-case letters, digits and underscores, "
                          "starting with a letter (it names pipeline/models/<name>.py and the files)")
    if name in RESERVED_MODEL_NAMES:
        raise ParamsError(f"{where}: {name!r} is one of the paper's models, which have stages of "
                          f"their own; taken names: {list(RESERVED_MODEL_NAMES)}")
    if not isinstance(line, dict):
        raise ParamsError(f"{where}: expected a mapping {{{', '.join(MODEL_KEYS)}}}, "
                          f"got {type(line).__name__}")
    unknown, missing = sorted(set(map(str, line)) - set(MODEL_KEYS)), [k for k in MODEL_KEYS if k not in line]
    if unknown or missing:
        raise ParamsError(f"{where}: " + "; ".join(
            ([f"unknown key(s) {unknown}"] if unknown else [])
            + ([f"missing key(s) {missing}"] if missing else [])) + f"; keys: {list(MODEL_KEYS)}")
    if not isinstance(line["class"], str) or not line["class"].isidentifier():
        raise ParamsError(f"{where}.class: expected the name of a class in pipeline/models/{name}.py, "
                          f"got {line['class']!r}")
    if not isinstance(line["label"], str) or not line["label"].strip():
        raise ParamsError(f"{where}.label: expected a non-empty string, got {line['label']!r}")
    if not isinstance(line["colour"], str) or not HEX_COLOUR.fullmatch(line["colour"]):
        raise ParamsError(f"{where}.colour: expected \"#rrggbb\" (quoted: YAML reads # as a "
                          f"comment), got {line['colour']!r}")
    if not isinstance(line["settings"], dict):
        raise ParamsError(f"{where}.settings: expected a mapping ({{}} for none), "
                          f"got {type(line['settings']).__name__}")
    return ModelEntry(name, line["class"], line["label"], line["colour"], dict(line["settings"]))


@dataclass(frozen=True)
class ShownModel:
    """A model as the report shows it: the paper's (`pipeline.model_list`) or a registered one."""

    name: str
    label: str
    colour: str


def all_models(registered: Mapping[str, ModelEntry]) -> tuple[ShownModel, ...]:
    """Every model the pipeline scores, as shown: the paper's in their tables' order, then the
    `registered` ones (`load_models`) in theirs."""
    return (*(ShownModel(m.name, m.label, m.colour) for m in PAPER_MODELS),
            *(ShownModel(name, entry.label, entry.colour) for name, entry in registered.items()))


# ---------------------------------------------------------------------------------------------
# The contract


@dataclass(frozen=True)
class WindowSet:
    """The windows of one split as a model sees them: N windows, n_past observed steps and a
    horizon of n_future steps (1 FPS, original pixels)."""

    past: np.ndarray  # (N, n_past, 2) float64: the observed positions, last one at "now"
    future: np.ndarray | None  # (N, n_future, 2) float64 for train / val; None for predicted windows
    n_future: int  # steps to predict (t_f in seconds)
    window_id: np.ndarray  # (N,) int64: the window table's ids
    scene_id: np.ndarray  # (N,) str: `<scene>_<video>`, e.g. `gates_2`
    track_id: np.ndarray  # (N,) int64: the SDD annotation's track
    first_frame: np.ndarray  # (N,) int64: raw 30 FPS frame of the first observed step

    def __len__(self) -> int:
        return len(self.window_id)


def window_set(arrays: WindowArrays, split: str, with_future: bool) -> WindowSet:
    """The windows of `split` as a model sees them; the future only `with_future`."""
    keep = arrays.split == split
    return WindowSet(past=arrays.past[keep], future=arrays.future[keep] if with_future else None,
                     n_future=arrays.future.shape[1], window_id=arrays.window_id[keep],
                     scene_id=arrays.scene_id[keep], track_id=arrays.track_id[keep],
                     first_frame=arrays.first_frame[keep])


def window_arrays(windows: WindowSet, split: str) -> WindowArrays:
    """`windows` back as the `WindowArrays` of one split, for code written against the window
    table (the paper's baselines); a future the model is not shown comes as zeros."""
    future = (np.zeros((len(windows), windows.n_future, 2)) if windows.future is None
              else windows.future)  # (N, n_future, 2)
    return WindowArrays(past=windows.past, future=future, window_id=windows.window_id,
                        scene_id=windows.scene_id, track_id=windows.track_id,
                        first_frame=windows.first_frame,
                        split=np.full(len(windows), split))


class Model(Protocol):
    """What a registered model's class provides (see the module's docstring)."""

    def __init__(self, settings: Mapping[str, Any]) -> None: ...

    def fit(self, train: WindowSet, val: WindowSet, workdir: Path, seed: int) -> None: ...

    def predict(self, test: WindowSet, k: int, workdir: Path, seed: int) -> np.ndarray: ...


def model_file(name: str) -> str:
    """The repository path of model `name`'s code: `pipeline/models/<name>.py`."""
    return f"pipeline/models/{name}.py"


def load_model(entry: ModelEntry) -> Model:
    """The class `entry.class_name` of `pipeline/models/<entry.name>.py`, built with the entry's
    settings; a ValueError naming the model, its file and the problem otherwise."""
    where = f"model {entry.name!r} ({model_file(entry.name)})"
    if not (FOLDER / f"{entry.name}.py").is_file():
        raise ValueError(f"{where}: no such file; a registered model's code is "
                         f"pipeline/models/<name>.py")
    module = importlib.import_module(f"{PACKAGE}.{entry.name}")
    cls = getattr(module, entry.class_name, None)
    if not isinstance(cls, type):
        raise ValueError(f"{where}: defines no class {entry.class_name!r} (params.yaml "
                         f"models.{entry.name}.class)")
    lacking = [m for m in ("fit", "predict") if not callable(getattr(cls, m, None))]
    if lacking:
        raise ValueError(f"{where}: class {entry.class_name} has no {' or '.join(lacking)} method")
    try:
        return cls(dict(entry.settings))
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: {entry.class_name}(settings={entry.settings!r}) failed: {e}") from e


def check_predictions(name: str, predictions: Any, n: int, k: int, n_future: int) -> np.ndarray:
    """`predictions` as float64 (n, k, n_future, 2), or a ValueError naming model `name` and what
    is wrong (not an array of numbers, another shape, a NaN or infinite value)."""
    where = f"model {name!r}: predict returned"
    try:
        array = np.asarray(predictions)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where} something that is no array ({e})") from e
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{where} an array of {array.dtype}, expected float pixels")
    if array.shape != (n, k, n_future, 2):
        raise ValueError(f"{where} shape {array.shape}, expected (N, k, n_f, 2) = "
                         f"{(n, k, n_future, 2)}")
    array = array.astype(np.float64)
    bad = ~np.isfinite(array)
    if bad.any():
        window, sample, step, _ = np.argwhere(bad)[0]
        raise ValueError(f"{where} {int(bad.sum())} non-finite value(s), first at window index "
                         f"{window}, sample {sample}, step {step}")
    return array
