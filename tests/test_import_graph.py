"""The shape of `pipeline/` and `ynet/`, and of `tools/` and `bench/` that use them, from their
import graph: floors that import only from the floors below them, and stages, tools and benchmarks
as entry points on top.

(a) no module of `pipeline/stages` imports another module of `pipeline/stages`;
(b) no module outside `pipeline/stages` imports `pipeline.stages` (or anything in it);
(c) every module of `pipeline/stages` has a `main` function (and runs it under `__main__`);
(d) every stage module is named as a stage of dvc.yaml, and every stage runs the module of its name;
(e) every module is on exactly one floor of `FLOORS`, and imports only its own floor and the floors
    that floor may import, all of them lower (ARCHITECTURE.md's "The packages" shows the same table);
(f) no import cycle: within a floor too, two modules never need each other;
(g) tools/ and bench/ import no private name (`_name`) of the library: they call its public API.
(h) only `pipeline/stages` and `pipeline/config` read params.yaml (call `read_params`,
    `load_section` or `load_profile`): a stage reads it once and hands the settings down.
Each check runs on the real tree and, to show it can fail, on a deliberately bad one.
"""

from __future__ import annotations

import ast
from fnmatch import fnmatchcase
from pathlib import Path

import pytest
import yaml

from pipeline.code_graph import PACKAGES, REPO, imported_modules, module_name

STAGES = "pipeline.stages"
# Entry points beside the stages: they use the library and no floor may import them. Not in
# `pipeline.code_graph.PACKAGES`, whose files make the stages' code fingerprints.
ENTRY_PACKAGES = ("tools", "bench")
CHECKED = (*PACKAGES, *ENTRY_PACKAGES)
PARAMS_READERS = ("read_params", "load_section", "load_profile")  # of pipeline.config.loading
READ_PARAMS_IN = (STAGES, "pipeline.config")  # the stages, and the loading itself

# The floors, lowest first: (floor, its modules, the floors it may import besides its own). A name
# ending in ".*" stands for everything inside that package; `pipeline` is the package's own
# __init__.py (no code), which Python runs before any module of it.
BELOW_MODELS = ("ynet", "facts", "config", "foundation", "data", "benchmarks")
LIBRARY = (*BELOW_MODELS, "models", "harness", "runners", "studies", "report", "code")
FLOORS = (
    ("ynet", ("ynet", "ynet.*"), ()),
    ("facts", ("pipeline", "pipeline.splits", "pipeline.model_list", "pipeline.dataset_list"), ()),
    ("config", ("pipeline.config", "pipeline.config.*"), ("ynet", "facts")),
    ("foundation", ("pipeline.io", "pipeline.device", "pipeline.preemption", "pipeline.checkpoints"),
     ("facts", "config")),
    ("data", ("pipeline.data", "pipeline.data.*"), ("ynet", "facts", "config", "foundation")),
    ("benchmarks", ("pipeline.benchmarks", "pipeline.benchmarks.*"),
     ("ynet", "facts", "config", "foundation", "data")),
    ("models", ("pipeline.models", "pipeline.models.*"), BELOW_MODELS),
    ("harness", ("pipeline.harness", "pipeline.harness.*"), (*BELOW_MODELS, "models")),
    ("runners", ("pipeline.runners", "pipeline.runners.*"), (*BELOW_MODELS, "models", "harness")),
    ("studies", ("pipeline.studies", "pipeline.studies.*"),
     (*BELOW_MODELS, "models", "harness", "runners")),
    ("report", ("pipeline.report", "pipeline.report.*"), (*BELOW_MODELS, "models")),
    # the project's own import graph and code fingerprints: imports no project module, and only a
    # stage (code_fingerprints), the tools and the tests import it
    ("code", ("pipeline.code_graph",), ()),
    # a stage never imports another stage: test_no_stage_imports_another_stage
    ("stages", ("pipeline.stages", "pipeline.stages.*"), LIBRARY),
    ("tools", ("tools", "tools.*"), LIBRARY),
    ("bench", ("bench", "bench.*"), LIBRARY),
)


def graph(root: Path) -> dict[str, set[str]]:
    """Module name -> the project modules (and names) it imports, for every .py of `CHECKED`."""
    return {module_name(path, root): {n for n in imported_modules(path, root)
                                       if n.split(".")[0] in CHECKED}
            for package in CHECKED if (root / package).is_dir()
            for path in sorted((root / package).rglob("*.py"))}


def is_stage(name: str) -> bool:
    return name.startswith(STAGES + ".")


def stage_to_stage(modules: dict[str, set[str]]) -> list[str]:
    return sorted(f"{m} imports {n}" for m, names in modules.items() if is_stage(m)
                  for n in names if n == STAGES or is_stage(n))


def library_to_stage(modules: dict[str, set[str]]) -> list[str]:
    return sorted(f"{m} imports {n}" for m, names in modules.items()
                  if not is_stage(m) and m != STAGES for n in names if n == STAGES or is_stage(n))


def floors_of(module: str) -> list[str]:
    return [floor for floor, members, _ in FLOORS
            if any(fnmatchcase(module, member) for member in members)]


def not_on_one_floor(modules: dict[str, set[str]]) -> list[str]:
    return sorted(f"{m} is on {len(floors_of(m))} floors" for m in modules if len(floors_of(m)) != 1)


def module_of(name: str, modules: dict[str, set[str]]) -> str:
    """The module an imported name is, or lies in (`pipeline.splits.TRAIN_VIDEOS` -> pipeline.splits)."""
    parts = name.split(".")
    return next((".".join(parts[:i]) for i in range(len(parts), 0, -1)
                 if ".".join(parts[:i]) in modules), name)


def floor_breaches(modules: dict[str, set[str]]) -> list[str]:
    """Every import of a floor the importer's floor may not import, as `module imports module`."""
    allowed = {floor: {floor, *below} for floor, _, below in FLOORS}
    found = set()
    for module, names in modules.items():
        if len(floors_of(module)) != 1:
            continue  # not_on_one_floor names it
        for target in {module_of(n, modules) for n in names}:
            floors = floors_of(target)
            if len(floors) != 1 or floors[0] not in allowed[floors_of(module)[0]]:
                found.add(f"{module} imports {target}")
    return sorted(found)


def private_imports(modules: dict[str, set[str]]) -> list[str]:
    """Every library name starting with `_` that a module of `ENTRY_PACKAGES` imports."""
    found = set()
    for module, names in modules.items():
        if module.split(".")[0] not in ENTRY_PACKAGES:
            continue
        for name in names:
            target = module_of(name, modules)
            inside = name[len(target) + 1:].split(".") if name != target else []
            if target.split(".")[0] in PACKAGES and any(part.startswith("_") for part in inside):
                found.add(f"{module} imports {name}")
    return sorted(found)


def on_cycles(modules: dict[str, set[str]]) -> list[str]:
    """Modules that reach themselves through imports. A module naming its own package (`from
    pipeline.runners.baselines import common` in `baselines.sgan`) only reaches a sibling."""
    edges = {m: {t for t in (module_of(n, modules) for n in names)
                 if t in modules and t != m and not m.startswith(t + ".")}
             for m, names in modules.items()}

    def reached(start: str) -> set[str]:
        seen, todo = set(), list(edges[start])
        while todo:
            m = todo.pop()
            if m not in seen:
                seen.add(m)
                todo.extend(edges[m])
        return seen

    return sorted(m for m in modules if m in reached(m))


def architecture_floors(path: Path) -> list[tuple[str, tuple[str, ...]]]:
    """(floor, may import) of each row of the table under "## The packages", in its order; the last
    column lists floors separated by commas, or "-" for none."""
    section = path.read_text().split("\n## The packages\n", 1)[1].split("\n## ", 1)[0]
    rows = [line.strip().strip("|").split("|") for line in section.splitlines()
            if line.startswith("| ")][1:]  # below the header
    return [(cells[0].strip(), tuple(f.strip() for f in cells[-1].split(",") if f.strip() != "-"))
            for cells in rows]


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


def unnamed_stages(root: Path, *dvc_yamls: Path) -> list[str]:
    names = set().union(*(dvc_stage_names(dvc_yaml) for dvc_yaml in dvc_yamls))
    return sorted(p.stem for p in stage_files(root) if p.stem not in names)


def misnamed_commands(dvc_yaml: Path) -> list[str]:
    """Stages whose command does not run `python -m pipeline.stages.<the stage's name>`."""
    stages = yaml.safe_load(dvc_yaml.read_text())["stages"]
    return sorted(name for name, s in stages.items()
                  if f"-m {STAGES}.{name} " not in " ".join(str(s.get("do", s)["cmd"]).split()) + " ")


def reads_params_here(module: str) -> bool:
    return any(module == package or module.startswith(package + ".") for package in READ_PARAMS_IN)


def params_reads(path: Path) -> list[int]:
    """The lines of `path` that call a params reader, by name or as an attribute
    (`loading.load_section(...)`)."""
    return sorted(node.lineno for node in ast.walk(ast.parse(path.read_text()))
                  if isinstance(node, ast.Call)
                  and getattr(node.func, "id", getattr(node.func, "attr", None)) in PARAMS_READERS)


def libraries_reading_params(root: Path) -> list[str]:
    """`<file>:<line>` of every params read outside the stages and `pipeline/config`."""
    return [f"{path.relative_to(root)}:{line}"
            for package in PACKAGES if (root / package).is_dir()
            for path in sorted((root / package).rglob("*.py"))
            if not reads_params_here(module_name(path, root))
            for line in params_reads(path)]


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
    assert unnamed_stages(REPO, REPO / "dvc.yaml", REPO / "studies/dvc.yaml") == []
    assert misnamed_commands(REPO / "dvc.yaml") == []
    assert misnamed_commands(REPO / "studies/dvc.yaml") == []


def test_every_module_is_on_one_floor():
    modules = graph(REPO)
    assert "pipeline.config.loading" in modules and "ynet.model" in modules
    assert not_on_one_floor(modules) == []


def test_every_module_imports_only_its_floor_and_the_floors_below_it_may_import():
    assert floor_breaches(graph(REPO)) == []


def test_the_floor_table_looks_only_down_and_is_architectures():
    below = []
    for floor, _, may_import in FLOORS:
        assert set(may_import) <= set(below), f"{floor} may import a floor above it"
        below.append(floor)
    assert architecture_floors(REPO / "ARCHITECTURE.md") == [(f, m) for f, _, m in FLOORS]


def test_no_import_cycle():
    assert on_cycles(graph(REPO)) == []


def test_tools_and_benchmarks_import_no_private_name():
    modules = graph(REPO)
    assert "tools.timed_repro" in modules and "bench.bench_segmentation" in modules
    assert private_imports(modules) == []


def test_only_stages_and_config_read_params():
    assert libraries_reading_params(REPO) == []


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


def test_the_params_check_catches_a_library_reading_params(tmp_path):
    write(tmp_path, "pipeline/stages/a.py", "from pipeline.config.loading import read_params\n"
                                            "params = read_params()\n")
    write(tmp_path, "pipeline/config/x.py", "from pipeline.config.loading import load_profile\n"
                                            "def f(p):\n    return load_profile(X, 'x', p)\n")
    write(tmp_path, "pipeline/runners/r.py", "from pipeline.config.loading import load_section\n"
                                             "def f(p):\n    return load_section(X, 'x', p)\n")
    write(tmp_path, "pipeline/stages_like.py", "from pipeline.config import loading\n\n"
                                               "def f():\n    return loading.read_params()\n")
    assert libraries_reading_params(tmp_path) == ["pipeline/runners/r.py:3",
                                                  "pipeline/stages_like.py:4"]


@pytest.fixture
def upward_tree(tmp_path) -> Path:
    """A tiny project whose floors import upwards, a module on no floor, two import cycles, a
    library module importing a benchmark and a benchmark importing a tool and a private name."""
    for rel in ("pipeline/__init__.py", "pipeline/data/__init__.py", "pipeline/harness/__init__.py",
                "pipeline/runners/__init__.py", "pipeline/report/__init__.py",
                "pipeline/stages/__init__.py", "ynet/__init__.py"):
        write(tmp_path, rel, '"""doc"""\n')
    write(tmp_path, "pipeline/splits.py", "TRAIN = 1\n")
    write(tmp_path, "pipeline/config.py", "from pipeline.data.windows import cut\n")
    write(tmp_path, "pipeline/io.py", "from pipeline.config import cut\n")
    write(tmp_path, "pipeline/data/windows.py", "from pipeline.data import tracks\n"
                                                "from pipeline.splits import TRAIN\n\n\n"
                                                "def cut():\n    from pipeline.runners.train import fit\n")
    write(tmp_path, "pipeline/data/tracks.py", "from pipeline.data.windows import cut\n")
    write(tmp_path, "pipeline/models/__init__.py", "from pipeline.harness.metrics import ade\n")
    write(tmp_path, "pipeline/harness/metrics.py", "from pipeline.splits import TRAIN\n")
    write(tmp_path, "pipeline/runners/train.py", "from pipeline.harness import metrics\n"
                                                 "from pipeline.report.page import draw\n")
    write(tmp_path, "pipeline/report/page.py", "from pipeline.runners.train import fit\n")
    write(tmp_path, "pipeline/stages/a.py", "from pipeline.report.page import draw\n"
                                            "from pipeline.runners.train import fit\n")
    write(tmp_path, "pipeline/helpers.py", "import os\n")
    write(tmp_path, "ynet/model.py", "import pipeline.config\n")
    write(tmp_path, "ynet/loss.py", "from ynet.model import Net\n")
    write(tmp_path, "pipeline/harness/runs.py", "from bench.speed import time_it\n")
    write(tmp_path, "tools/plan.py", "import pipeline.report.page\n")
    write(tmp_path, "bench/speed.py", "from pipeline.runners.train import _step, fit\n"
                                      "from tools.plan import run\n")
    return tmp_path


def test_the_floor_checks_catch_upward_imports_strays_and_cycles(upward_tree):
    modules = graph(upward_tree)
    assert floor_breaches(modules) == [
        "bench.speed imports tools.plan",  # a benchmark imports a tool
        "pipeline.config imports pipeline.data.windows",  # config imports data
        "pipeline.data.windows imports pipeline.runners.train",  # in a function
        "pipeline.harness.runs imports bench.speed",  # the library imports a benchmark
        "pipeline.models imports pipeline.harness.metrics",
        "pipeline.report.page imports pipeline.runners.train",  # report may not import runners
        "pipeline.runners.train imports pipeline.report.page",  # nor runners report
        "ynet.model imports pipeline.config",  # ynet imports pipeline
    ]
    assert not_on_one_floor(modules) == ["pipeline.helpers is on 0 floors"]
    assert on_cycles(modules) == ["pipeline.data.tracks", "pipeline.data.windows",
                                  "pipeline.report.page", "pipeline.runners.train"]
    assert private_imports(modules) == ["bench.speed imports pipeline.runners.train._step"]
