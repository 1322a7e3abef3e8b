"""The shape of `pipeline/`, from its import graph: stages are thin entry points, libraries never
reach into them.

(a) no module of `pipeline/stages` imports another module of `pipeline/stages`;
(b) no module outside `pipeline/stages` imports `pipeline.stages` (or anything in it);
(c) every module of `pipeline/stages` has a `main` function (and runs it under `__main__`);
(d) every stage module is named as a stage of dvc.yaml, and every stage runs the module of its name.
Each check runs on the real tree and, to show it can fail, on a deliberately bad one.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
import yaml

from pipeline.code_graph import REPO, imported_modules, module_name

STAGES = "pipeline.stages"


def graph(root: Path) -> dict[str, set[str]]:
    """Module name -> the `pipeline` modules (and names) it imports, for every pipeline/**.py."""
    return {module_name(path, root): {n for n in imported_modules(path, root)
                                       if n.split(".")[0] == "pipeline"}
            for path in sorted((root / "pipeline").rglob("*.py"))}


def is_stage(name: str) -> bool:
    return name.startswith(STAGES + ".")


def stage_to_stage(modules: dict[str, set[str]]) -> list[str]:
    return sorted(f"{m} imports {n}" for m, names in modules.items() if is_stage(m)
                  for n in names if n == STAGES or is_stage(n))


def library_to_stage(modules: dict[str, set[str]]) -> list[str]:
    return sorted(f"{m} imports {n}" for m, names in modules.items()
                  if not is_stage(m) and m != STAGES for n in names if n == STAGES or is_stage(n))


def stage_files(root: Path) -> list[Path]:
    return sorted(p for p in (root / "pipeline" / "stages").glob("*.py") if p.name != "__init__.py")


def without_main(root: Path) -> list[str]:
    missing = []
    for path in stage_files(root):
        tree = ast.parse(path.read_text())
        has_main = any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body)
        runs_main = any(isinstance(n, ast.If) and "__main__" in ast.unparse(n.test)
                        and "main()" in ast.unparse(n) for n in tree.body)
        if not (has_main and runs_main):
            missing.append(path.name)
    return missing


def dvc_stage_names(dvc_yaml: Path) -> set[str]:
    """Top-level keys of `stages:` (foreach / matrix stages by their base name)."""
    return set(yaml.safe_load(dvc_yaml.read_text())["stages"])


def unnamed_stages(root: Path, dvc_yaml: Path) -> list[str]:
    names = dvc_stage_names(dvc_yaml)
    return sorted(p.stem for p in stage_files(root) if p.stem not in names)


def misnamed_commands(dvc_yaml: Path) -> list[str]:
    """Stages whose command does not run `python -m pipeline.stages.<the stage's name>`."""
    stages = yaml.safe_load(dvc_yaml.read_text())["stages"]
    return sorted(name for name, s in stages.items()
                  if f"-m {STAGES}.{name} " not in " ".join(str(s.get("do", s)["cmd"]).split()) + " ")


# ---------------------------------------------------------------------------------------------
# The real tree


def test_no_stage_imports_another_stage():
    assert stage_to_stage(graph(REPO)) == []


def test_no_library_imports_a_stage():
    assert library_to_stage(graph(REPO)) == []


def test_every_stage_module_has_a_main():
    assert stage_files(REPO), "no stage modules found"
    assert without_main(REPO) == []


def test_every_stage_module_is_a_dvc_stage_and_every_stage_runs_its_namesake():
    assert unnamed_stages(REPO, REPO / "dvc.yaml") == []
    assert misnamed_commands(REPO / "dvc.yaml") == []


# ---------------------------------------------------------------------------------------------
# The checks catch what they are for


def write(root: Path, rel: str, text: str) -> None:
    path = root / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


@pytest.fixture
def bad_tree(tmp_path) -> Path:
    """A tiny pipeline/ with one of each mistake."""
    write(tmp_path, "pipeline/__init__.py", '"""doc"""\n')
    write(tmp_path, "pipeline/stages/__init__.py", '"""doc"""\n')
    write(tmp_path, "pipeline/lib.py", "from pipeline.stages.a import helper\n")
    write(tmp_path, "pipeline/other.py", "def f():\n    from pipeline import stages\n")
    write(tmp_path, "pipeline/stages/a.py",
          "def helper():\n    pass\n\n\ndef main():\n    pass\n\n\nif __name__ == '__main__':\n    main()\n")
    write(tmp_path, "pipeline/stages/b.py", "from . import a\n\n\ndef run():\n    a.helper()\n")
    write(tmp_path, "pipeline/stages/c.py", "from pipeline.stages.a import helper\n\n\ndef main():\n    helper()\n")
    write(tmp_path, "dvc.yaml", "stages:\n  a:\n    cmd: python -m pipeline.stages.a\n"
                                "  b:\n    foreach: [1]\n    do:\n      cmd: python -m pipeline.stages.b\n"
                                "  d:\n    cmd: python -m pipeline.stages.a --x 1\n")
    return tmp_path


def test_the_checks_catch_bad_imports_and_missing_mains(bad_tree):
    modules = graph(bad_tree)
    offenders = lambda found: sorted({line.split(" imports ")[0] for line in found})  # noqa: E731
    assert offenders(stage_to_stage(modules)) == ["pipeline.stages.b", "pipeline.stages.c"]
    assert "pipeline.stages.b imports pipeline.stages.a" in stage_to_stage(modules)  # relative import
    assert offenders(library_to_stage(modules)) == ["pipeline.lib", "pipeline.other"]  # other: in a function
    assert without_main(bad_tree) == ["b.py", "c.py"]  # b: no main; c: main never run
    assert unnamed_stages(bad_tree, bad_tree / "dvc.yaml") == ["c"]
    assert misnamed_commands(bad_tree / "dvc.yaml") == ["d"]  # stage d runs module a
