"""S-GAN and PECNet on a short-term benchmark, trained and scored in the unit the benchmark is
scored in: what the stages `train_short_term_baseline` and `evaluate_short_term_baseline` share
beyond `pipeline.runners.short_term`.

Units. SDD (TrajNet) windows stay in original pixels, its unit. An ETH/UCY fold's windows are read
from the table's metre columns (`x_m`, `y_m`): both upstream codebases train their ETH/UCY models
in metres (S-GAN's released models on raw metres; PECNet's ETH code on metres times 170), and the
images' pixels differ 2x between scenes (0.019-0.042 m each), so a pixel setting tuned on SDD
(PECNet's 100 px neighbour radius, its likelihood width) meant something else in every scene.
The networks see the windows' shape only through their own settings, so the same code trains on
either unit.

Settings: the model's `sgan` / `pecnet` section of the active profile, with this benchmark's epochs
(`short_term_models.<profile>.epochs.<model>.<benchmark>`) and its overrides
(`short_term_baselines.<profile>.<model>.<benchmark>`, fields of the model's config; empty for SDD),
each checked by the model's own config class.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from pipeline.harness.baseline_runs import model_config
from pipeline.io import IntermediateError
from pipeline.runners.short_term import Benchmark, benchmark_of, load_benchmark, table_path, unit_of

SECTION = "short_term_baselines"


def benchmark_in_unit(table: pd.DataFrame, dataset: str, n_past: int, n_future: int) -> Benchmark:
    """The splits of a short-term window table in the unit `dataset` is scored in: SDD pixels as
    they are; ETH/UCY from its metre columns (train, val and test alike, the truth too)."""
    if unit_of(dataset) == "px":
        return load_benchmark(table, dataset, n_past, n_future, None)
    missing = [c for c in ("x_m", "y_m") if c not in table.columns]
    if missing:
        raise ValueError(f"{dataset}: the window table has no metre columns {missing}")
    metres = table.assign(x=table["x_m"], y=table["y_m"])
    return dataclasses.replace(load_benchmark(metres, dataset, n_past, n_future, None), unit="m")


def load_in_unit(windows: Path, dataset: str, n_past: int, n_future: int) -> Benchmark:
    """`benchmark_in_unit` of `dataset`'s table in the `short_term_windows` folder; a table it
    cannot use is named (`IntermediateError`)."""
    path = table_path(windows, dataset)
    try:
        return benchmark_in_unit(pd.read_parquet(path), dataset, n_past, n_future)
    except ValueError as error:
        raise IntermediateError(f"{path}: {error}") from None


def overrides(params: Mapping[str, Any], model: str, dataset: str) -> dict[str, Any]:
    """`short_term_baselines.<profile>.<model>.<benchmark>` of the active profile ({} if empty)."""
    profile = params["profile"]
    try:
        value = params[SECTION][profile][model][benchmark_of(dataset)]
    except (KeyError, TypeError) as error:
        raise ValueError(f"params.yaml: {SECTION}.{profile}.{model}.{benchmark_of(dataset)} is "
                         f"missing ({error})") from None
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ValueError(f"params.yaml: {SECTION}.{profile}.{model}.{benchmark_of(dataset)} must "
                         f"map settings to values, got {value!r}")
    return dict(value)


def baseline_config(model: str, dataset: str, params: Mapping[str, Any], epochs: int):
    """The model's config for `dataset`: its section, this benchmark's epochs and overrides. An
    unknown setting or a bad value fails here, naming the params key."""
    changes = overrides(params, model, dataset)
    base = model_config(model, dict(params))
    unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(base)})
    if unknown:
        raise ValueError(f"params.yaml: {SECTION}.{params['profile']}.{model}."
                         f"{benchmark_of(dataset)}: {model} has no setting(s) {unknown}")
    return dataclasses.replace(base, **changes, epochs=epochs)
