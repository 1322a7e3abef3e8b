"""Every stage declares what it runs and reads, so `dvc repro` re-runs it when any of that changes.

Code: a stage's code is every project file its `python -m pipeline.stages.<stage>` reaches through
its imports inside `pipeline` and `ynet` (`pipeline.code_graph.code_closure`). Stage
`code_fingerprints` hashes that closure into `data/code_fingerprints/stages/<stage>.json` (and a
registered model's, which `fit_model` / `predict_model` load by name, into `models/<name>.json`);
each stage declares its fingerprint as its code dep and lists no code file itself. Files: every
path on the command line must be a declared dep or output (or lie inside one, or be the folder of
declared outputs), except `dvc.lock`, which the report reads for its provenance and which cannot be
a dep of a stage it records.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
import yaml
from dvc.repo import Repo

from pipeline.code_graph import (PACKAGES, REPO, code_closure, code_text, entry_points, fingerprint,
                                 imported_modules)
from pipeline.stages import code_fingerprints

NOT_A_DEP = {"dvc.lock"}  # read by `report` for provenance; a dep on it could never be up to date
# A study's scratch folder (checkpoints kept for resuming): never an output, since a frozen stage's
# outputs must be on every clone (docs/studies.md)
STUDY_SCRATCH = "checkpoints/studies/"


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


FINGERPRINTS = "data/code_fingerprints"


def wanted_fingerprints(cmd: str) -> list[str]:
    """The fingerprint files a stage running `cmd` must declare: its module's, and the registered
    model's it loads by name (`--model <name>` of a file `pipeline/models/<name>.py`)."""
    tokens = shlex.split(cmd)
    wanted = [f"{FINGERPRINTS}/stages/{stage_module(cmd).rpartition('.')[2]}.json"]
    if "--model" in tokens:
        name = tokens[tokens.index("--model") + 1]
        if (REPO / "pipeline" / "models" / f"{name}.py").is_file():
            wanted.append(f"{FINGERPRINTS}/models/{name}.json")
    return wanted


@pytest.mark.parametrize("stage", STAGES, ids=lambda s: s.addressing)
def test_stage_declares_the_fingerprint_of_the_code_it_runs(stage):
    module = stage_module(stage.cmd)
    assert module, f"{stage.addressing}: command is not `python -m <module>`: {stage.cmd}"
    deps = [d.def_path for d in stage.deps]
    if stage.addressing == "code_fingerprints":
        assert sorted(deps) == sorted(PACKAGES), "code_fingerprints must hash every project package"
        return
    missing = [f for f in wanted_fingerprints(stage.cmd) if f not in deps]
    assert not missing, f"{stage.addressing} runs code it does not declare: add {missing}"
    listed = [d for d in deps if is_code(d)]
    assert not listed, f"{stage.addressing} lists code files {listed}: its fingerprint covers them"


def test_every_module_a_stage_runs_is_fingerprinted():
    """What the stages declare is what code_fingerprints writes, and nothing it writes is unused."""
    declared = {d.def_path for s in STAGES for d in s.deps if d.def_path.startswith(FINGERPRINTS + "/")}
    written = {f"{FINGERPRINTS}/{name}.json" for name in entry_points(REPO)}
    assert declared == written


def test_a_fingerprint_changes_exactly_when_code_the_module_reaches_changes(tmp_path):
    """On a small tree: editing an imported file changes the importer's fingerprint, editing a file
    it does not reach leaves it byte-identical, and the stage writes one file per entry point."""
    root = tmp_path / "repo"
    for path, text in {
        "pipeline/__init__.py": "",
        "pipeline/helper.py": "X = 1\n",
        "pipeline/other.py": "Y = 2\n",
        "pipeline/stages/__init__.py": "",
        "pipeline/stages/alpha.py": "from pipeline.helper import X\n",
        "pipeline/stages/beta.py": "from pipeline import other\n",
        "pipeline/models/__init__.py": "",
        "pipeline/models/mine.py": "import pipeline.helper\n",
    }.items():
        (root / path).parent.mkdir(parents=True, exist_ok=True)
        (root / path).write_text(text)
    assert entry_points(root) == {"stages/alpha": "pipeline.stages.alpha",
                                  "stages/beta": "pipeline.stages.beta",
                                  "models/mine": "pipeline.models.mine"}
    before = fingerprint("pipeline.stages.alpha", root)
    assert set(before) == {"pipeline/helper.py", "pipeline/stages/alpha.py"}
    beta = fingerprint("pipeline.stages.beta", root)
    (root / "pipeline/other.py").write_text("Y = 3\n")
    assert fingerprint("pipeline.stages.alpha", root) == before
    assert fingerprint("pipeline.stages.beta", root) != beta
    (root / "pipeline/helper.py").write_text("X = 2\n")
    assert fingerprint("pipeline.stages.alpha", root)["pipeline/helper.py"] != before["pipeline/helper.py"]


def test_an_import_only_for_type_checking_is_no_code_of_the_closure(tmp_path):
    """An import under `if TYPE_CHECKING:` never runs: editing its file leaves the fingerprint as
    it was, while the import graph (the floors) still sees it; a run-time import of the same file
    elsewhere in the closure brings it back."""
    root = tmp_path / "repo"
    for path, text in {
        "pipeline/__init__.py": "",
        "pipeline/section.py": "X = 1\n",
        "pipeline/lib.py": ("from typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n"
                            "    from pipeline.section import X\n\n\ndef f(x: X):\n    return x\n"),
        "pipeline/stages/__init__.py": "",
        "pipeline/stages/alpha.py": "from pipeline.lib import f\n",
        "pipeline/stages/beta.py": "from pipeline.lib import f\nfrom pipeline.section import X\n",
    }.items():
        (root / path).parent.mkdir(parents=True, exist_ok=True)
        (root / path).write_text(text)
    assert "pipeline.section" in imported_modules(root / "pipeline/lib.py", root)
    assert "pipeline.section" not in imported_modules(root / "pipeline/lib.py", root, when_run=True)
    alpha = fingerprint("pipeline.stages.alpha", root)
    assert set(alpha) == {"pipeline/lib.py", "pipeline/stages/alpha.py"}
    assert "pipeline/section.py" in fingerprint("pipeline.stages.beta", root)
    (root / "pipeline/section.py").write_text("X = 2\n")
    assert fingerprint("pipeline.stages.alpha", root) == alpha


def test_comments_blank_lines_and_trailing_spaces_are_not_code(tmp_path):
    """Editing them leaves a fingerprint as it was; editing code, a string or a line inside a
    docstring (the code can read it) changes it."""
    root = tmp_path / "repo"
    source = ('"""Doc.\n\nSecond paragraph."""\n\nimport os  # why\n\n\n'
              'def f(x):\n    # say why\n    return x + 1\n')
    for path, text in {"pipeline/__init__.py": "", "pipeline/stages/__init__.py": "",
                       "pipeline/stages/alpha.py": source}.items():
        (root / path).parent.mkdir(parents=True, exist_ok=True)
        (root / path).write_text(text)

    def after(text: str) -> dict[str, str]:
        (root / "pipeline/stages/alpha.py").write_text(text)
        return fingerprint("pipeline.stages.alpha", root)

    before = fingerprint("pipeline.stages.alpha", root)
    assert after(source.replace("# why", "# why not").replace("\n\n\ndef", "\n\ndef")) == before
    assert after(source.replace("x + 1\n", "x + 1   \n").replace("    # say why\n", "")) == before
    assert after(source.replace("x + 1", "x + 2")) != before
    assert after(source.replace("import os  # why", "import os, sys  # why")) != before
    assert after(source.replace("Doc.\n\nSecond", "Doc.\nSecond")) != before
    assert code_text('s = "# kept"  # dropped\n') == 's = "# kept"\n'
    with pytest.raises(ValueError, match="broken.py"):
        code_text('s = """never closed\n', "pipeline/broken.py")


def test_the_stage_writes_every_fingerprint(tmp_path):
    out = tmp_path / "code_fingerprints"
    code_fingerprints.main(["--out", str(out)])
    written = sorted(p.relative_to(out).with_suffix("").as_posix() for p in out.rglob("*.json"))
    assert written == sorted(entry_points(REPO))
    record = yaml.safe_load((out / "stages" / "evaluate_ynet.json").read_text())
    assert record["module"] == "pipeline.stages.evaluate_ynet"
    assert record["files"] == fingerprint("pipeline.stages.evaluate_ynet")
    assert "ynet/model.py" in record["files"]


@pytest.mark.parametrize("stage", STAGES, ids=lambda s: s.addressing)
def test_every_path_on_the_command_line_is_a_dep_or_an_output(stage):
    outs = [o.def_path for o in stage.outs]
    declared = [d.def_path for d in stage.deps] + outs
    paths = [t for t in shlex.split(stage.cmd)
             if "/" in t or Path(t).suffix in (".yaml", ".lock", ".json", ".parquet")]
    paths = [p for p in paths if "=" not in p and p not in NOT_A_DEP
             and not (stage.frozen and p.startswith(STUDY_SCRATCH))]
    undeclared = [p for p in paths if not covered(p, declared, outs)]
    assert not undeclared, f"{stage.addressing} reads or writes {undeclared}, not declared in dvc.yaml"


def test_the_closure_follows_imports_through_packages():
    """A check of the checker: train_baseline reaches every model through the registry."""
    closure = code_closure("pipeline.stages.train_baseline")
    assert {"pipeline/runners/baselines/__init__.py", "pipeline/runners/baselines/sgan.py",
            "pipeline/runners/baselines/pecnet.py", "pipeline/device.py"} <= closure
    assert "pipeline/__init__.py" not in closure  # a docstring only
    assert "pipeline/stages/__init__.py" not in closure
    assert "ynet/model.py" in code_closure("pipeline.stages.evaluate_ynet")


def test_every_locked_stage_is_a_stage_of_dvc_yaml():
    """dvc.lock keeps an entry until someone removes it: a stage renamed or dropped from dvc.yaml
    leaves a stale record (and stale provenance in the report) behind."""
    locked = set(yaml.safe_load((REPO / "dvc.lock").read_text())["stages"])
    assert locked - {s.addressing for s in STAGES} == set()


def test_relock_takes_only_stages_whose_one_change_is_their_code_fingerprint():
    from tools.relock_fingerprints import fingerprint_only

    fingerprint = "data/code_fingerprints/stages/report.json"
    assert fingerprint_only([{"changed deps": {fingerprint: "modified"}}])
    assert not fingerprint_only([{"changed deps": {fingerprint: "deleted"}}])
    assert not fingerprint_only([{"changed deps": {fingerprint: "modified",
                                                   "data/windows/release_tf30.parquet": "modified"}}])
    assert not fingerprint_only([{"changed deps": {"params.yaml": {"ttst.temperature": "modified"}}}])
    assert not fingerprint_only([{"changed outs": {"metrics/ynet_eval.json": "modified"}}])
    assert not fingerprint_only(["always changed"])
    # A checkout without the outputs (a new machine): absent files are no change, with the flag.
    absent = [{"changed deps": {fingerprint: "modified", "data/windows/release_tf30.parquet": "deleted"}},
              {"changed outs": {"reports/index.html": "deleted", "checkpoints/ynet": "not in cache"}}]
    assert not fingerprint_only(absent)
    assert fingerprint_only(absent, absent_ok=True)
    assert not fingerprint_only([{"changed deps": {fingerprint: "deleted"}}], absent_ok=True)
    assert not fingerprint_only([{"changed outs": {"reports/index.html": "modified"}}], absent_ok=True)
    assert not fingerprint_only([{"changed deps": {"params.yaml": {"ttst.temperature": "modified"}}}],
                                absent_ok=True)
    # --params: a params change is taken too (a removed switch, a newly read key), nothing else
    params = [{"changed deps": {fingerprint: "modified", "params.yaml": {"models": "new"}}}]
    assert not fingerprint_only(params) and fingerprint_only(params, params_ok=True)
    assert not fingerprint_only([{"changed outs": {"metrics/ynet_eval.json": "modified"}}],
                                params_ok=True)


def test_relock_narrows_to_the_named_stages_and_foreach_groups():
    from tools.relock_fingerprints import selected, unknown

    status = {"segmentation": [], "train_ynet_horizon@5": [], "train_ynet_horizon@10": [],
              "train_ynet": [], "evaluate_ynet": []}
    assert selected(status, []) == status
    assert set(selected(status, ["train_ynet_horizon"])) == {"train_ynet_horizon@5",
                                                             "train_ynet_horizon@10"}
    # a stage's name is not a prefix of another's: train_ynet leaves the horizons out
    assert set(selected(status, ["train_ynet", "train_ynet_horizon@10"])) == {
        "train_ynet", "train_ynet_horizon@10"}
    names = [s.addressing for s in STAGES]
    assert unknown(["train_ynet_horizon", "segmentation", "train_ynet_horizon@5"], names) == []
    assert unknown(["train_ynet_horizn", "train_ynet_horizon@7"], names) == [
        "train_ynet_horizn", "train_ynet_horizon@7"]
