"""The project's import graph, read from the source (no imports run): which modules a file imports,
every project file a module needs, and the fingerprint of that code.

A stage's code is the closure of its module (`code_closure`): every file whose code can run when
the module runs. Stage `code_fingerprints` writes each stage module's `fingerprint` to a file the
stage declares as its one code dep, so DVC re-runs a stage exactly when the code of a file its
module reaches changes (`code_text`: comments, blank lines and trailing spaces are not code), while
dvc.lock records one entry per stage instead of one per imported file (each stage that finishes
rewrites the whole lock file). An import under `if TYPE_CHECKING:` never runs, so it is no part of
a closure (a parameter's type named for the reader: whoever builds such an object imports its
class at run time, and that importer is in the closure); the import graph still counts it.
`tests/test_dvc_deps.py` and `tests/test_import_graph.py` check the house with it.
"""

from __future__ import annotations

import ast
import hashlib
import io
import tokenize
from functools import cache
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("pipeline", "ynet")


def module_name(path: Path, root: Path = REPO) -> str:
    """pipeline/stages/report.py -> pipeline.stages.report; a package's __init__.py -> the package."""
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path, root: Path = REPO, when_run: bool = False) -> set[str]:
    """Absolute names `path` imports: `import a.b` -> a.b; `from a import b` -> a and a.b
    (relative imports resolved); imports inside functions count too. `when_run`: only the imports
    that can run, not those under `if TYPE_CHECKING:`. Each version of a file (its mtime and size)
    is parsed once: every stage's closure passes through the same libraries."""
    stat = path.stat()
    return set(_imported_modules(path, root, (stat.st_mtime_ns, stat.st_size), when_run))


def type_checking_only(tree: ast.AST) -> set[ast.AST]:
    """The nodes inside the body of an `if TYPE_CHECKING:` (or `typing.TYPE_CHECKING`), which
    Python never runs."""
    skipped = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and ast.unparse(node.test) in ("TYPE_CHECKING",
                                                                     "typing.TYPE_CHECKING"):
            for statement in node.body:
                skipped.update(ast.walk(statement))
    return skipped


@cache
def _imported_modules(path: Path, root: Path, version: tuple[int, int],
                      when_run: bool) -> frozenset[str]:
    name = module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    tree = ast.parse(path.read_text())
    skipped = type_checking_only(tree) if when_run else set()
    for node in ast.walk(tree):
        if node in skipped:
            continue
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
    """Root-relative files of `module`, its parent packages and everything they import at run
    time."""
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
            todo.extend(imported_modules(path, root, when_run=True))
    return frozenset(p.relative_to(root).as_posix() for p in seen
                     if p.name != "__init__.py" or has_code(p))


def code_text(source: str, path: Path | str = "<source>") -> str:
    """`source` without what the interpreter never runs: comments, trailing spaces and blank lines,
    so that editing them re-runs no stage. Lines inside a multi-line string (a docstring, a
    template) stay exactly as written: the code can read them. A file Python cannot tokenize is a
    ValueError naming `path`."""
    lines = source.splitlines()
    verbatim: set[int] = set()  # 0-based rows inside multi-line strings
    try:
        for token in tokenize.generate_tokens(io.StringIO(source).readline):
            if token.type == tokenize.COMMENT:
                row, column = token.start
                lines[row - 1] = lines[row - 1][:column]
            elif token.type == tokenize.STRING and token.end[0] > token.start[0]:
                verbatim.update(range(token.start[0] - 1, token.end[0] - 1))
    except (tokenize.TokenError, IndentationError, SyntaxError) as error:
        raise ValueError(f"{path}: not Python that tokenizes: {error}") from error
    kept = [line if row in verbatim else line.rstrip() for row, line in enumerate(lines)]
    return "\n".join(line for row, line in enumerate(kept) if row in verbatim or line) + "\n"


def fingerprint(module: str, root: Path = REPO) -> dict[str, str]:
    """{root-relative path: SHA-256 of its `code_text`} over `code_closure(module)`, sorted by
    path: the same mapping exactly when the code of every file the module reaches is the same."""
    return {path: code_hash(root / path) for path in sorted(code_closure(module, root))}


def code_hash(path: Path) -> str:
    """SHA-256 of `path`'s `code_text`, tokenized once per content of the file: most closures
    share the same libraries."""
    return _code_hash(path.read_bytes(), str(path))


@cache
def _code_hash(data: bytes, path: str) -> str:
    return hashlib.sha256(code_text(data.decode(), path).encode()).hexdigest()


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
