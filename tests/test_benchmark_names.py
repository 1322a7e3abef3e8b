"""No stage, runner, study, harness or report module tests a benchmark's name: each asks the
benchmark (`pipeline.benchmarks`: its unit, files, scene sources, labels, paper and study keys),
so that a new benchmark needs only its module and a line in `pipeline.benchmarks.registry`.

Read from the AST of every module of `CHECKED`, with the names every registered benchmark answers
to (`benchmark_names`: registry names, short-term `--dataset`s, settings keys, paper and study
keys), a module must not hold
(a) a comparison (==, !=, in, not in, is, is not) with such a name on either side, alone or
    inside a tuple, list or set;
(b) `.startswith` / `.endswith` / `.removeprefix` / `.removesuffix` of such a name;
(c) a table keyed by such names: a dict literal with two or more of them as keys, or a subscript
    by one;
(d) a list of benchmarks written out: a tuple, list or set literal holding two or more names.
In (c) and (d) the paper's table keys (`TABLE_KEYS`) are tables, not benchmarks (`sdd_long` names
Table 3 as well as the long-term SDD budget study).
Each check also runs on a module with a name test put back, to show that it fails.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from pipeline.benchmarks.registry import BENCHMARKS, SHORT_TERM
from pipeline.dataset_list import SHORT_TERM_DATASETS, SHORT_TERM_SETTINGS_KEYS
from pipeline.report.provenance import TABLE_KEYS

REPO = Path(__file__).resolve().parents[1]
CHECKED = ("pipeline/stages", "pipeline/runners", "pipeline/studies", "pipeline/harness",
           "pipeline/report")
STRING_METHODS = ("startswith", "endswith", "removeprefix", "removesuffix")
COMPARISONS = (ast.Eq, ast.NotEq, ast.In, ast.NotIn, ast.Is, ast.IsNot)


def benchmark_names() -> frozenset[str]:
    """Every name a registered benchmark answers to."""
    names = {*SHORT_TERM_DATASETS, *SHORT_TERM_SETTINGS_KEYS, *SHORT_TERM}
    for benchmark in BENCHMARKS.values():
        names |= {benchmark.name, benchmark.paper_key, benchmark.study_key}
    for benchmark in SHORT_TERM.values():
        names |= {benchmark.dataset, benchmark.settings_key}
    return frozenset(names - {""})


def strings(node: ast.AST) -> list[str]:
    """The string constants `node` is or holds as a tuple, list or set literal."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, ast.Tuple | ast.List | ast.Set):
        return [s for element in node.elts for s in strings(element)]
    return []


def name_tests(source: str, names: frozenset[str]) -> list[tuple[int, str]]:
    """(line, what) of every test of a benchmark name in `source` (checks (a) to (d))."""
    keys = names - set(TABLE_KEYS)
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare) and any(isinstance(op, COMPARISONS) for op in node.ops):
            hits = [s for side in (node.left, *node.comparators) for s in strings(side)
                    if s in names]
            found += [(node.lineno, f"compares with {s!r}") for s in hits]
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr in STRING_METHODS):
            hits = [s for arg in node.args for s in strings(arg) if s in names]
            found += [(node.lineno, f".{node.func.attr}({s!r})") for s in hits]
        elif isinstance(node, ast.Dict):
            hits = [s for key in node.keys if key is not None for s in strings(key) if s in keys]
            if len(hits) >= 2:
                found.append((node.lineno, f"a table keyed by {hits}"))
        elif isinstance(node, ast.Subscript):
            found += [(node.lineno, f"looks up {s!r}") for s in strings(node.slice) if s in keys]
        if isinstance(node, ast.Tuple | ast.List | ast.Set):
            hits = [s for s in strings(node) if s in keys]
            if len(hits) >= 2:
                found.append((node.lineno, f"lists {hits}"))
    return sorted(found)


def test_no_stage_runner_or_report_module_tests_a_benchmark_name():
    names = benchmark_names()
    found = [f"{path.relative_to(REPO)}:{line}: {what}"
             for package in CHECKED for path in sorted((REPO / package).rglob("*.py"))
             for line, what in name_tests(path.read_text(), names)]
    assert not found, ("ask the benchmark (pipeline.benchmarks) instead of testing its name:\n"
                       + "\n".join(found))


def test_the_names_are_every_benchmarks():
    names = benchmark_names()
    assert {"sdd", "eth", "zara2", "ethucy", "ind", "sdd_long_term", "trajnet_sdd", "ethucy_eth",
            "sdd_long"} <= names
    assert not names & set(TABLE_KEYS) - {"sdd_long"}  # only the long-term SDD study shares one


@pytest.mark.parametrize("source, what", [
    ('name = "sdd.json" if dataset == "sdd" else "other.json"', "compares with 'sdd'"),
    ('if args.dataset != "sdd":\n    pass', "compares with 'sdd'"),
    ('ok = dataset in ("eth", "hotel")', "compares with 'eth'"),
    ('ok = (c["dataset"], c["k_a"]) == ("sdd", 1)', "compares with 'sdd'"),
    ('ok = benchmark.name == "ind"', "compares with 'ind'"),
    ('ok = benchmark == "sdd_long"', "compares with 'sdd_long'"),
    ('ok = name.startswith("ethucy")', ".startswith('ethucy')"),
    ('LABELS = {"sdd": "SDD", "ind": "inD"}', "a table keyed by ['sdd', 'ind']"),
    ('label = LABELS["zara1"]', "looks up 'zara1'"),
    ('FOLDS = ("eth", "hotel", "univ")', "lists ['eth', 'hotel', 'univ']"),
])
def test_a_name_test_is_found(source, what):
    assert [w for _, w in name_tests(source, benchmark_names())][:1] == [what]


@pytest.mark.parametrize("source", [
    'ok = dataset == benchmark.dataset',  # asking the benchmark
    'paper["sdd_long"]["columns"]',  # a paper table, not a benchmark
    'options = {"maps": True, "sdd": True}',  # one option named after a raw source
    'run(store, "sdd", model)',  # an argument, not a test
    'ok = kind.startswith("long_term_")',
])
def test_what_is_not_a_name_test(source):
    assert name_tests(source, benchmark_names()) == []
