"""Rewrite the code part of every stage's `deps` in dvc.yaml from the stage module's imports.

    python tools/sync_dvc_deps.py           # rewrite dvc.yaml in place (comments kept)
    python tools/sync_dvc_deps.py --check   # exit 1 and list the stages whose code deps differ

A stage's code deps are the project files its `python -m pipeline.stages.<name>` imports, followed
through every import inside `pipeline` and `ynet` (`tools.code_graph`: the closure that
tests/test_dvc_deps.py checks). Other deps (data, manifests, templates) are kept as written, after the code.

A registered model's stages (`fit_model`, `predict_model`) run code no import names: the model's
file, the templated dep `pipeline/models/${item.model}.py` (kept as written). What that file
imports is added for every model registered in params.yaml `models` (`registered_model_code`).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from ruamel.yaml import YAML

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tools.code_graph import REPO, code_closure  # noqa: E402

CODE_SUFFIX = ".py"
CODE_ROOTS = ("pipeline/", "ynet/")
MODEL_DEP = "pipeline/models/${item.model}.py"  # a registered model's code, one file per model


def is_code(dep: str) -> bool:
    """A project code file named outright (a templated path is kept as written)."""
    return dep.endswith(CODE_SUFFIX) and dep.startswith(CODE_ROOTS) and "${" not in dep


def registered_model_code(params_file: Path) -> set[str]:
    """The project files the registered models' files import (not those files themselves)."""
    models = YAML(typ="safe").load(params_file).get("models") or {}
    needed: set[str] = set()
    for name in models:
        needed |= code_closure(f"pipeline.models.{name}") - {MODEL_DEP.replace("${item.model}", name)}
    return needed


def stage_bodies(stages: dict) -> list[tuple[str, dict]]:
    """(name, the mapping holding cmd and deps) of every stage, foreach/matrix ones included."""
    return [(name, stage.get("do", stage)) for name, stage in stages.items()]


def synced_deps(body: dict, params_file: Path) -> list[str]:
    tokens = shlex.split(" ".join(str(body["cmd"]).split()))
    module = tokens[tokens.index("-m") + 1]
    other = [d for d in body.get("deps", []) if not is_code(str(d))]
    code = set(code_closure(module))
    if MODEL_DEP in other:
        code |= registered_model_code(params_file)
    return sorted(code) + other


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true")
    parser.add_argument("--dvc-yaml", type=Path, default=REPO / "dvc.yaml")
    parser.add_argument("--params", type=Path, default=REPO / "params.yaml",
                        help="for the registered models (section `models`)")
    args = parser.parse_args(argv)
    yaml = YAML()
    yaml.width = 4096
    yaml.indent(mapping=2, sequence=4, offset=2)
    document = yaml.load(args.dvc_yaml)
    stale = []
    for name, body in stage_bodies(document["stages"]):
        wanted = synced_deps(body, args.params)
        if [str(d) for d in body.get("deps", [])] != wanted:
            stale.append(name)
            body["deps"] = wanted
    if args.check:
        print("\n".join(stale) or "dvc.yaml code deps are in sync")
        return 1 if stale else 0
    if stale:
        yaml.dump(document, args.dvc_yaml)
        print(f"rewrote the deps of {len(stale)} stages: {', '.join(stale)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
