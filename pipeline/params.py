"""Typed access to `params.yaml`.

Each stage owns a dataclass for the section it reads (fields documented, checks in
`__post_init__`). `load_section` builds it from the YAML and fails loudly on unknown or missing
keys, so a typo in `params.yaml` or in `dvc exp run -S ...` is an error, not a silent default.
"""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path
from typing import Any, TypeVar

import yaml

T = TypeVar("T")

PARAMS_FILE = Path("params.yaml")


class ParamsError(ValueError):
    """`params.yaml` does not match what a stage expects."""


def read_params(path: Path | str = PARAMS_FILE) -> dict[str, Any]:
    path = Path(path)
    try:
        with path.open() as f:
            params = yaml.safe_load(f)
    except FileNotFoundError as e:
        raise ParamsError(f"{path}: not found (run stages from the repository root)") from e
    if not isinstance(params, dict):
        raise ParamsError(f"{path}: expected a mapping at the top level")
    return params


def from_dict(cls: type[T], values: Any, where: str) -> T:
    """Build dataclass `cls` from a mapping; nested dataclass fields recurse."""
    if not isinstance(values, dict):
        raise ParamsError(f"{where}: expected a mapping, got {type(values).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise ParamsError(f"{where}: unknown key(s) {unknown}; allowed: {sorted(fields)}")
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for name, value in values.items():
        hint = hints[name]
        if dataclasses.is_dataclass(hint):
            value = from_dict(hint, value, f"{where}.{name}")
        kwargs[name] = value
    missing = [
        n for n, f in fields.items()
        if n not in kwargs and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ParamsError(f"{where}: missing key(s) {missing}")
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as e:
        raise ParamsError(f"{where}: {e}") from e


def load_section(cls: type[T], key: str, params: dict[str, Any] | None = None) -> T:
    """The section `key` of `params.yaml` (or of `params`) as a `cls` instance."""
    params = read_params() if params is None else params
    if key not in params:
        raise ParamsError(f"params.yaml: missing section '{key}'")
    return from_dict(cls, params[key], f"params.yaml:{key}")


def load_profile(cls: type[T], key: str, params: dict[str, Any] | None = None) -> T:
    """Section `key` for the active `profile` (params.yaml `profile: cpu|paper`) as a `cls`.

    Such a section holds one sub-mapping per profile, e.g. `ynet: {cpu: {...}, paper: {...}}`, so
    `dvc exp run -S profile=paper` switches every profiled stage at once.
    """
    params = read_params() if params is None else params
    profile = params.get("profile")
    if key not in params:
        raise ParamsError(f"params.yaml: missing section '{key}'")
    if not isinstance(params[key], dict) or profile not in params[key]:
        raise ParamsError(f"params.yaml:{key}: no settings for profile {profile!r}; "
                          f"profiles here: {sorted(params[key]) if isinstance(params[key], dict) else []}")
    return from_dict(cls, params[key][profile], f"params.yaml:{key}.{profile}")
