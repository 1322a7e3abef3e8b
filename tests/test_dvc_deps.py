"""Every stage declares what it runs and reads, so `dvc repro` re-runs it when any of that changes.

Code: the project modules a stage's `python -m pipeline.stages.<stage>` imports, followed through every
import inside `pipeline` and `ynet` (a package's `__init__.py` counts when it holds code), must all
be in the stage's `deps`; so must whatever a code file listed as a dep imports (a registered
model's file, which its stages load by name: `pipeline/models/<name>.py`). Files: every path on the command line must be a declared dep or output
(or lie inside one, or be the folder of declared outputs), except `dvc.lock`, which the report reads for its provenance and which
cannot be a dep of a stage it records.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
import yaml
from dvc.repo import Repo

from tools.code_graph import REPO, code_closure, module_name

NOT_A_DEP = {"dvc.lock"}  # read by `report` for provenance; a dep on it could never be up to date


def stages():
    return sorted(Repo(str(REPO)).index.stages, key=lambda s: s.addressing)


def stage_module(cmd: str) -> str | None:
    tokens = shlex.split(cmd)
    return tokens[tokens.index("-m") + 1] if "-m" in tokens else None


def covered(path: str, declared: list[str], outs: list[str]) -> bool:
    """A declared path, a file inside one, or the folder an option names for declared outputs."""
    return (any(path == d or path.startswith(d.rstrip("/") + "/") for d in declared)
            or any(o.startswith(path.rstrip("/") + "/") for o in outs))


STAGES = stages()


def is_code(path: str) -> bool:
    return path.endswith(".py") and path.split("/")[0] in ("pipeline", "ynet")


@pytest.mark.parametrize("stage", STAGES, ids=lambda s: s.addressing)
def test_stage_declares_the_code_it_imports(stage):
    module = stage_module(stage.cmd)
    assert module, f"{stage.addressing}: command is not `python -m <module>`: {stage.cmd}"
    deps = [d.def_path for d in stage.deps]
    needed = set(code_closure(module))
    for dep in filter(is_code, deps):  # a code dep brings what it imports
        assert (REPO / dep).is_file(), f"{stage.addressing}: code dep {dep} does not exist"
        needed |= code_closure(module_name(REPO / dep))
    missing = sorted(f for f in needed if f not in deps)
    assert not missing, f"{stage.addressing} imports {missing} but dvc.yaml does not list them"


@pytest.mark.parametrize("stage", STAGES, ids=lambda s: s.addressing)
def test_every_path_on_the_command_line_is_a_dep_or_an_output(stage):
    outs = [o.def_path for o in stage.outs]
    declared = [d.def_path for d in stage.deps] + outs
    paths = [t for t in shlex.split(stage.cmd)
             if "/" in t or Path(t).suffix in (".yaml", ".lock", ".json", ".parquet")]
    paths = [p for p in paths if "=" not in p and p not in NOT_A_DEP]
    undeclared = [p for p in paths if not covered(p, declared, outs)]
    assert not undeclared, f"{stage.addressing} reads or writes {undeclared}, not declared in dvc.yaml"


def test_the_closure_follows_imports_through_packages():
    """A check of the checker: train_baseline reaches every model through the registry."""
    closure = code_closure("pipeline.stages.train_baseline")
    assert {"pipeline/harness/baselines/__init__.py", "pipeline/harness/baselines/sgan.py",
            "pipeline/harness/baselines/pecnet.py", "pipeline/device.py"} <= closure
    assert "pipeline/__init__.py" not in closure  # a docstring only
    assert "pipeline/stages/__init__.py" not in closure
    assert "ynet/model.py" in code_closure("pipeline.stages.evaluate_ynet")


def test_a_registered_models_imports_become_its_stages_deps(tmp_path):
    """tools/sync_dvc_deps.py adds what a registered model's file imports to the code deps of the
    stages that load it by name, beside the templated `pipeline/models/${item.model}.py`."""
    from tools.sync_dvc_deps import MODEL_DEP, registered_model_code, synced_deps

    params = tmp_path / "params.yaml"
    params.write_text("models:\n  constant_velocity: {class: ConstantVelocity, label: CV, "
                      "colour: '#7f7f7f', settings: {}}\n")
    imported = registered_model_code(params)
    assert "pipeline/harness/baselines/constant_velocity.py" in imported  # extrapolate
    assert "pipeline/models/__init__.py" in imported  # the contract
    assert "pipeline/models/constant_velocity.py" not in imported  # the templated dep names it
    body = {"cmd": "python -m pipeline.stages.predict_model --model ${item.model}",
            "deps": ["pipeline/io.py", MODEL_DEP, "data/x.parquet"]}
    deps = synced_deps(body, params)
    assert deps[-2:] == [MODEL_DEP, "data/x.parquet"]  # kept as written, after the code
    assert set(deps[:-2]) == set(code_closure("pipeline.stages.predict_model")) | imported
    params.write_text("models: {}\n")  # nothing registered: the stage's own imports only
    assert set(synced_deps(body, params)[:-2]) == set(code_closure("pipeline.stages.predict_model"))


def test_every_locked_stage_is_a_stage_of_dvc_yaml():
    """dvc.lock keeps an entry until someone removes it: a stage renamed or dropped from dvc.yaml
    leaves a stale record (and stale provenance in the report) behind."""
    locked = set(yaml.safe_load((REPO / "dvc.lock").read_text())["stages"])
    assert locked - {s.addressing for s in STAGES} == set()
