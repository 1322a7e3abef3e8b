"""S-GAN and PECNet on a short-term benchmark, trained and scored in the unit the benchmark is
scored in: what the stages `train_short_term_baseline` and `evaluate_short_term_baseline` share
beyond `pipeline.runners.short_term`.

Units (`ShortTermBenchmark.load_in_unit`). SDD (TrajNet) windows stay in original pixels, its
unit. An ETH/UCY fold's windows are read from the table's metre columns (`x_m`, `y_m`): both upstream codebases train their ETH/UCY models
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
from dataclasses import dataclass
from typing import Any

from pipeline.benchmarks.registry import short_term

SECTION = "short_term_baselines"


@dataclass(frozen=True)
class BaselineOverrides:
    """Section `short_term_baselines` for the active profile, as written (it has no class: its
    settings are the models' own config fields), with the profile's name for the messages."""

    profile: str
    models: Any  # {<model>: {<benchmark>: {setting: value} | None}}: short_term_baselines.<profile>


def overrides(section: BaselineOverrides, model: str, dataset: str) -> dict[str, Any]:
    """`short_term_baselines.<profile>.<model>.<benchmark>` of the active profile ({} if empty);
    <benchmark>: the `settings_key` of `dataset`'s benchmark (sdd, ethucy)."""
    profile = section.profile
    key = short_term(dataset).settings_key
    try:
        value = section.models[model][key]
    except (KeyError, TypeError) as error:
        raise ValueError(f"params.yaml: {SECTION}.{profile}.{model}.{key} is "
                         f"missing ({error})") from None
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ValueError(f"params.yaml: {SECTION}.{profile}.{model}.{key} must "
                         f"map settings to values, got {value!r}")
    return dict(value)


def baseline_config(model: str, dataset: str, base: Any, section: BaselineOverrides, epochs: int):
    """The model's config for `dataset`: `base` (its section, `<model>.<profile>`), this
    benchmark's epochs and overrides. An unknown setting or a bad value fails here, naming the
    params key."""
    changes = overrides(section, model, dataset)
    unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(base)})
    if unknown:
        raise ValueError(f"params.yaml: {SECTION}.{section.profile}.{model}."
                         f"{short_term(dataset).settings_key}: {model} has no setting(s) {unknown}")
    return dataclasses.replace(base, **changes, epochs=epochs)
