"""The project's import graph, read from the source (no imports run): which modules a file imports,
every project file a module needs, and the fingerprint of that code.

A stage's code is the closure of its module (`code_closure`). Stage `code_fingerprints` writes each
stage module's `fingerprint` to a file the stage declares as its one code dep, so DVC re-runs a
stage exactly when a file its module reaches changes, while dvc.lock records one entry per stage
instead of one per imported file (each stage that finishes rewrites the whole lock file).
`tests/test_dvc_deps.py` and `tests/test_import_graph.py` check the house with it.
"""

from __future__ import annotations

import ast
import hashlib
from functools import cache
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("pipeline", "ynet")


def module_name(path: Path, root: Path = REPO) -> str:
    """pipeline/stages/report.py -> pipeline.stages.report; a package's __init__.py -> the package."""
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path, root: Path = REPO) -> set[str]:
    """Absolute names `path` imports: `import a.b` -> a.b; `from a import b` -> a and a.b
    (relative imports resolved); imports inside functions count too. Each version of a file (its
    mtime and size) is parsed once: every stage's closure passes through the same libraries."""
    stat = path.stat()
    return set(_imported_modules(path, root, (stat.st_mtime_ns, stat.st_size)))


@cache
def _imported_modules(path: Path, root: Path, version: tuple[int, int]) -> frozenset[str]:
    name = module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return frozenset(found)


def module_path(name: str, root: Path = REPO) -> Path | None:
    """The file of project module `name` (a package's __init__.py), or None if not ours."""
    if name.split(".")[0] not in PACKAGES:
        return None
    base = root.joinpath(*name.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def has_code(path: Path) -> bool:
    """False for a module that is only a docstring (an empty package marker)."""
    body = ast.parse(path.read_text()).body
    return any(not (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant))
               for node in body)


@cache
def code_closure(module: str, root: Path = REPO) -> frozenset[str]:
    """Root-relative files of `module`, its parent packages and everything they import."""
    seen: set[Path] = set()
    todo = [module]
    while todo:
        name = todo.pop()
        parts = name.split(".")
        for i in range(1, len(parts) + 1):  # importing a.b.c runs a/__init__ and a/b/__init__
            path = module_path(".".join(parts[:i]), root)
            if path is None or path in seen:
                continue
            seen.add(path)
            todo.extend(imported_modules(path, root))
    return frozenset(p.relative_to(root).as_posix() for p in seen
                     if p.name != "__init__.py" or has_code(p))


def fingerprint(module: str, root: Path = REPO) -> dict[str, str]:
    """{root-relative path: SHA-256 of its bytes} over `code_closure(module)`, sorted by path:
    the same mapping exactly when every file the module reaches is the same."""
    return {path: hashlib.sha256((root / path).read_bytes()).hexdigest()
            for path in sorted(code_closure(module, root))}


def entry_points(root: Path = REPO) -> dict[str, str]:
    """{fingerprint name: module} of every module a stage runs: `stages/<stage>` for each stage
    module, and `models/<name>` for each registered-model file (`pipeline/models/<name>.py`), which
    stages `fit_model` and `predict_model` load by name rather than import."""
    points = {}
    for folder in ("stages", "models"):
        for path in sorted((root / "pipeline" / folder).glob("*.py")):
            if path.name != "__init__.py" and path.stem != "code_fingerprints":
                points[f"{folder}/{path.stem}"] = module_name(path, root)
    return points
