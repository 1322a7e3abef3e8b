"""The environment a clone installs: exact pins in pyproject.toml, every transitive version in
requirements.lock agreeing with them, and the Pythons the Makefile looks for being the ones
pyproject.toml admits."""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet

REPO = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]


def canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def lock_pins(text: str) -> dict[str, str]:
    """requirements.lock's `name==version` lines (comments and blank lines skipped)."""
    pins = {}
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            name, _, version = line.partition("==")
            assert version, f"requirements.lock: {line!r} is not name==version"
            pins[canonical(name)] = version
    return pins


def exact_pins(requirements: list[str]) -> dict[str, str]:
    pins = {}
    for text in requirements:
        requirement = Requirement(text)
        (spec,) = requirement.specifier  # exactly one specifier: ==
        assert spec.operator == "==", f"pyproject.toml: {text} is not pinned exactly"
        pins[canonical(requirement.name)] = spec.version
    return pins


def makefile_pythons() -> list[str]:
    makefile = (REPO / "Makefile").read_text()
    return re.findall(r"python(3\.\d+)", makefile.split("VENV ?=")[0])


def test_every_dependency_is_pinned_and_the_lock_agrees():
    declared = exact_pins(PYPROJECT["dependencies"] + PYPROJECT["optional-dependencies"]["test"])
    locked = lock_pins((REPO / "requirements.lock").read_text())
    assert {name: locked.get(name) for name in declared} == declared


def test_the_makefile_looks_for_exactly_the_pythons_pyproject_admits():
    admitted = SpecifierSet(PYPROJECT["requires-python"])
    found = makefile_pythons()
    assert found == ["3.11", "3.12", "3.13"]
    assert all(f"{v}.0" in admitted for v in found)
    assert "3.10.0" not in admitted and "3.14.0" not in admitted
    assert f"{sys.version_info.major}.{sys.version_info.minor}" in found  # the one running this


def test_the_checks_catch_a_loose_pin_and_a_lock_that_disagrees():
    import pytest
    with pytest.raises(AssertionError, match="not pinned exactly"):
        exact_pins(["numpy>=2"])
    assert lock_pins("# c\nnumpy==2.4.5\n") != exact_pins(["numpy==2.4.6"])
