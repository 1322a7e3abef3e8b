"""How a `params.yaml` section becomes its dataclass: the loading every section module shares.

`load_section` builds a section's dataclass from the YAML and fails loudly on unknown or missing
keys, so a typo in `params.yaml` or in `dvc exp run -S ...` is an error, not a silent default;
`load_profile` picks a profiled section's entry for the active `profile`, the one place the
profile is resolved (`active_profile`, `profile_entry`). Scalars are type-checked
(`scalar_type_error`) and floats read as YAML 1.2 writes them (`yaml12_floats`), as DVC reads them.
Each section's dataclass is in its own module of `pipeline.config` (named after the section), so a
stage's code holds only the sections it reads; `tests/test_params.py` checks every class against
`params.yaml`.
"""

from __future__ import annotations

import dataclasses
import re
import types
import typing
from collections.abc import Mapping
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


SCALAR_TYPES = {bool: (bool,), int: (int,), float: (int, float), str: (str,)}


def union_options(hint: Any) -> tuple:
    """The types an annotation allows: (float, NoneType) for `float | None`, (int,) for int."""
    return (typing.get_args(hint) if typing.get_origin(hint) in (typing.Union, types.UnionType)
            else (hint,))


def scalar_type_error(hint: Any, value: Any) -> str | None:
    """Why `value` does not fit a plain scalar annotation (bool, int, float, str, or one of them
    `| None`), or None; any other annotation is left to the dataclass's own checks. A bool is no
    number here (YAML's `yes` for an epoch count is a typo, not 1)."""
    options = union_options(hint)
    kinds = [o for o in options if o is not type(None)]
    if not kinds or any(o not in SCALAR_TYPES for o in kinds):
        return None
    if value is None and type(None) in options:
        return None
    for kind in kinds:
        if isinstance(value, SCALAR_TYPES[kind]) and (kind is bool or not isinstance(value, bool)):
            return None
    wanted = " or ".join(k.__name__ for k in kinds) + (" or null" if type(None) in options else "")
    return f"expected {wanted}, got {type(value).__name__} {value!r}"


# A float as YAML 1.2 writes it: DVC (ruamel) reads `1e9` and `1e-3` as numbers, PyYAML (YAML 1.1,
# which needs a dot and a signed exponent) as strings
YAML12_FLOAT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")


def wants_float(hint: Any) -> bool:
    """Whether a field annotated `hint` takes a float and no string (float, `float | None`)."""
    options = union_options(hint)
    return float in options and str not in options


def yaml12_floats(hint: Any, value: Any) -> Any:
    """`value` with every string YAML 1.2 reads as a float made one, where `hint` wants a float
    (a field, or the items of a list / the values of a dict of floats): `1e9` in params.yaml (or
    from `dvc exp run -S`) then reaches the field's own checks, as DVC read it, instead of failing
    as a string."""
    if isinstance(value, str) and wants_float(hint) and YAML12_FLOAT.fullmatch(value.strip()):
        return float(value)
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is list and isinstance(value, list) and args:
        return [yaml12_floats(args[0], item) for item in value]
    if origin is dict and isinstance(value, dict) and len(args) == 2:
        return {key: yaml12_floats(args[1], item) for key, item in value.items()}
    return value


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
        value = yaml12_floats(hint, value)
        wrong = scalar_type_error(hint, value)
        if wrong:
            raise ParamsError(f"{where}.{name}: {wrong}")
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


def active_profile(params: Mapping[str, Any]) -> str:
    """The active profile (`cpu` / `paper`): params.yaml's `profile`, read here alone, so every
    profiled section and every record that names the profile names the same one."""
    profile = params.get("profile")
    if not isinstance(profile, str):
        raise ParamsError(f"params.yaml:profile: expected a profile name (cpu, paper), "
                          f"got {profile!r}")
    return profile


def profile_entry(params: Mapping[str, Any], key: str) -> Any:
    """Section `key`'s entry for the active profile, as written (`ynet: {cpu: {...}, paper:
    {...}}` -> `params['ynet'][profile]`), for a caller that reads only some keys of it."""
    profile = active_profile(params)
    if key not in params:
        raise ParamsError(f"params.yaml: missing section '{key}'")
    section = params[key]
    if not isinstance(section, dict) or profile not in section:
        raise ParamsError(f"params.yaml:{key}: no settings for profile {profile!r}; "
                          f"profiles here: {sorted(section) if isinstance(section, dict) else []}")
    return section[profile]


def load_profile(cls: type[T], key: str, params: dict[str, Any] | None = None) -> T:
    """Section `key` for the active `profile` (params.yaml `profile: cpu|paper`) as a `cls`.

    Such a section holds one sub-mapping per profile, e.g. `ynet: {cpu: {...}, paper: {...}}`, so
    `dvc exp run -S profile=paper` switches every profiled stage at once.
    """
    params = read_params() if params is None else params
    entry = profile_entry(params, key)
    return from_dict(cls, entry, f"params.yaml:{key}.{active_profile(params)}")


def seed_list_error(seeds: Any) -> str | None:
    """Why `seeds` is not a list of distinct non-negative integer seeds, or None."""
    if not isinstance(seeds, list) or any(isinstance(s, bool) or not isinstance(s, int) or s < 0
                                          for s in seeds):
        return f"must be non-negative integer seeds, got {seeds}"
    if len(set(seeds)) != len(seeds):
        return f"holds a seed twice: {seeds}"
    return None
