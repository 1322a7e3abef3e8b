"""How far an edit of one params section's code reaches, and that splitting `pipeline/config.py`
into `pipeline/config/<section>.py` changed no setting
(docs/experiments/2026-11-28-config-by-section.md). Not a test: prints what it finds.

    python -m docs.experiments.config_sections closures        # stages whose code holds each module
    python -m docs.experiments.config_sections edits SCRATCH   # a docstring edit per module, then
                                                               # stage code_fingerprints, on a copy
    python -m docs.experiments.config_sections identity [--rev bf8c423]  # old module vs new ones

`edits` copies `pipeline/` and `ynet/` into SCRATCH, runs stage `code_fingerprints` there once as
it is and once after each edit (one line of one module's docstring), and lists the stages whose
fingerprint file changed; the checkout is not touched. `identity` loads every section of
params.yaml, for each profile, with `pipeline/config.py` as it was at `--rev` and with the section
modules, and compares the values (`dataclasses.asdict`), the section helpers' results, the
messages of bad values (an unknown key, a missing key, a value of the wrong type, each scalar out
of its range), and the source of every class and function moved.
"""

from __future__ import annotations

import argparse
import ast
import copy
import dataclasses
import importlib
import json
import shutil
import subprocess
import sys
import types
from pathlib import Path

from pipeline.code_graph import code_closure, entry_points

ROOT = Path(__file__).resolve().parents[2]

CONFIG = ROOT / "pipeline" / "config"
# What the split renamed (short_term_models imports them under their old names)
RENAMED = {"DATASETS": "SHORT_TERM_DATASETS", "MODELS": "SHORT_TERM_MODELS_OURS_FIRST",
           "BENCHMARKS": "SHORT_TERM_SETTINGS_KEYS"}
CLASSES = {"runtime": "RuntimeParams", "fetch": "FetchParams", "compat": "CompatParams",
           "split": "SplitParams", "windows": "WindowParams", "data": "DataParams",
           "labels": "LabelsParams", "segmentation": "SegmentationParams",
           "semantic": "SemanticParams", "ynet": "YnetSettings", "ttst": "TtstParams",
           "cws": "CwsParams", "eval": "EvalParams", "ynet_horizons": "HorizonParams",
           "ynet_seeds": "YnetSeedsParams", "sgan": "SganConfig", "pecnet": "PecnetConfig",
           "train_baseline": "TrainBaselineParams", "baseline_seeds": "BaselineSeedsParams",
           "epoch_selection_study": "EpochSelectionStudyParams",
           "pecnet_test_selection": "PecnetTestSelectionParams",
           "short_term_pecnet_test_selection": "ShortTermPecnetTestSelectionParams",
           "evaluate_baseline": "EvaluateBaselineParams",
           "rpecnet_rollouts": "RpecnetRolloutsParams",
           "score_predictions": "ScorePredictionsParams", "short_term": "ShortTermParams",
           "short_term_models": "ShortTermModelsParams", "ind_benchmark": "IndBenchmarkParams",
           "report": "ReportParams"}


def section_modules() -> list[str]:
    return sorted(p.stem for p in CONFIG.glob("*.py") if p.stem != "__init__")


def closures() -> None:
    points = entry_points(ROOT)
    print(f"{len(points)} entry points (stage modules and registered models)")
    for section in section_modules():
        path = f"pipeline/config/{section}.py"
        inside = sorted(name.split("/")[1] for name, module in points.items()
                        if path in code_closure(module, ROOT))
        print(f"{section:34s} {len(inside):2d}  {' '.join(inside)}")


def fingerprints(tree: Path, out: Path) -> dict[str, str]:
    subprocess.run([sys.executable, "-m", "pipeline.stages.code_fingerprints", "--out", str(out)],
                   cwd=tree, check=True, capture_output=True, env={"PYTHONPATH": str(tree)})
    return {p.relative_to(out).with_suffix("").as_posix(): p.read_text()
            for p in sorted(out.rglob("*.json"))}


def edits(scratch: Path) -> None:
    tree = scratch / "tree"
    if tree.exists():
        shutil.rmtree(tree)
    for package in ("pipeline", "ynet"):
        shutil.copytree(ROOT / package, tree / package, ignore=shutil.ignore_patterns("__pycache__"))
    before = fingerprints(tree, scratch / "fp_before")
    for section in section_modules():
        path = tree / "pipeline" / "config" / f"{section}.py"
        original = path.read_text()
        first = original.index("\n")  # the docstring's first line, a line of code
        path.write_text(original[:first] + " (edited)" + original[first:])
        after = fingerprints(tree, scratch / f"fp_{section}")
        path.write_text(original)
        changed = sorted(name.split("/")[1] for name in before if before[name] != after[name])
        print(f"{section:34s} {len(changed):2d}  {' '.join(changed)}")
    assert fingerprints(tree, scratch / "fp_reverted") == before


def old_config(rev: str) -> types.ModuleType:
    source = subprocess.run(["git", "show", f"{rev}:pipeline/config.py"], cwd=ROOT, check=True,
                            capture_output=True, text=True).stdout
    module = types.ModuleType("old_config")
    module.__file__ = f"{rev}:pipeline/config.py"
    sys.modules["old_config"] = module
    exec(compile(source, module.__file__, "exec"), module.__dict__)
    return module


def new_object(name: str):
    """A name of the old module, where the split put it."""
    for section in section_modules():
        module = importlib.import_module(f"pipeline.config.{section}")
        if hasattr(module, name) and getattr(module, name).__module__ == module.__name__:
            return getattr(module, name)
    raise KeyError(name)


def outcome(load, cls, params: dict, key: str) -> str:
    try:
        value = load(cls, key, params)
    except Exception as e:  # noqa: BLE001 (the messages are what is compared)
        return f"{type(e).__name__}: {e}"
    return json.dumps(dataclasses.asdict(value), sort_keys=True, default=repr)


def bad_inputs(raw: dict) -> list[tuple[str, dict]]:
    """Section entries that must fail (or load) alike: an unknown key, each key missing, each
    scalar of the wrong type and made negative or zero."""
    cases = [("unknown key", {**raw, "no_such_key": 1})]
    for key, value in raw.items():
        cases.append((f"{key} missing", {k: v for k, v in raw.items() if k != key}))
        if isinstance(value, (bool, int, float, str)) or value is None:
            for label, bad in (("a string", "x"), ("a bool", True), ("-1", -1), ("0", 0)):
                if bad != value:
                    cases.append((f"{key} = {label}", {**raw, key: bad}))
        if isinstance(value, list):
            cases.append((f"{key} = []", {**raw, key: []}))
    return cases


def identity(rev: str) -> int:
    from pipeline.config.loading import load_profile, load_section, read_params

    old = old_config(rev)
    params = read_params(ROOT / "params.yaml")
    compared = differ = 0
    for profile in ("cpu", "paper"):
        for section, name in CLASSES.items():
            entry = params[section]
            profiled = isinstance(entry, dict) and {"cpu", "paper"} <= set(entry)
            raw = entry[profile] if profiled else entry
            for case, value in [("as in params.yaml", raw), *bad_inputs(raw)]:
                trial = copy.deepcopy(params)
                trial["profile"] = profile
                if profiled:
                    trial[section][profile] = value
                else:
                    trial[section] = value
                a = outcome(old.load_profile if profiled else old.load_section,
                            getattr(old, name), trial, section)
                b = outcome(load_profile if profiled else load_section, new_object(name), trial,
                            section)
                compared += 1
                if a != b:
                    differ += 1
                    print(f"DIFFERENT {profile} {section} ({case}):\n  old {a}\n  new {b}")
        trial = {**params, "profile": profile}
        for helper in ("ynet_main_seed", "ynet_seed_slots"):
            compared += 1
            if getattr(old, helper)(trial) != new_object(helper)(trial):
                differ += 1
                print(f"DIFFERENT {profile} {helper}")
        locations = [[repr(x) for x in load(cls, "fetch", trial).parsed_locations()]
                     for load, cls in ((old.load_section, old.FetchParams),
                                       (load_section, new_object("FetchParams")))]
        evals = [repr(dataclasses.asdict(load(cls, "short_term_models", trial).eval_params()))
                 for load, cls in ((old.load_profile, old.ShortTermModelsParams),
                                   (load_profile, new_object("ShortTermModelsParams")))]
        compared += 2
        differ += (locations[0] != locations[1]) + (evals[0] != evals[1])
    sources = moved_sources(old, rev)
    print(f"sections loaded and bad values tried: {compared} compared, different: {differ}")
    print(f"classes, functions and constants moved: {sources[0]} compared, different: {sources[1]}")
    return int(differ + sources[1] > 0)


def moved_sources(old: types.ModuleType, rev: str) -> tuple[int, int]:
    """Each top-level definition of the old module against its namesake in the new ones, as code
    (`ast.dump`), the split's renames undone."""
    source = subprocess.run(["git", "show", f"{rev}:pipeline/config.py"], cwd=ROOT, check=True,
                            capture_output=True, text=True).stdout
    new = {}
    for path in sorted(CONFIG.glob("*.py")):
        text = path.read_text()
        for old_name, new_name in RENAMED.items():
            text = text.replace(f"{new_name} as {old_name}", old_name)
        text = text.replace("SETTINGS_KEYS", "BENCHMARKS")
        for node in ast.parse(text).body:
            for name in names_of(node):
                new[name] = ast.dump(node)
    compared = different = 0
    for node in ast.parse(source).body:
        for name in names_of(node):
            if name in RENAMED:
                continue
            compared += 1
            if new.get(name) != ast.dump(node):
                different += 1
                print(f"DIFFERENT source: {name}")
    return compared, different


def names_of(node: ast.AST) -> list[str]:
    if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
        return [node.name]
    if isinstance(node, ast.Assign):
        return [t.id for t in node.targets if isinstance(t, ast.Name)]
    return []


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    verbs = parser.add_subparsers(dest="verb", required=True)
    verbs.add_parser("closures")
    edit = verbs.add_parser("edits")
    edit.add_argument("scratch", type=Path)
    same = verbs.add_parser("identity")
    same.add_argument("--rev", default="bf8c423", help="a commit with pipeline/config.py")
    args = parser.parse_args()
    if args.verb == "closures":
        closures()
    elif args.verb == "edits":
        edits(args.scratch)
    else:
        return identity(args.rev)
    return 0


if __name__ == "__main__":
    sys.exit(main())
