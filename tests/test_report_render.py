"""The committed report is the committed code's output.

The `report` stage of dvc.yaml is run, exactly as dvc.yaml writes its command, on copies of its
inputs as committed (every one is in git: metrics, paper values, manifests, dvc.lock, the figure
folders of `report_figures`, `animations` and `horizon_analysis`), and what it writes must equal
the committed `reports/` byte for byte, apart from the run-provenance blocks the template marks
(render time, machine, package versions, git state). So a change to the report's code, its paper
values, its metrics or dvc.lock cannot land without the page it makes.
"""

from __future__ import annotations

import difflib
import html
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
RUN_PROVENANCE = re.compile(r"<!-- run-provenance.*?<!-- /run-provenance -->", re.S)
READ_BUT_NOT_DEPS = ("dvc.lock", "params.yaml", "reports/stage_times.json")  # deps can't say these
RERENDER = ("re-render the page with `dvc repro --single-item report` (or the stage's command from "
            "dvc.yaml) from a clean tree, and commit reports/ with the change")


def report_stage() -> dict:
    return yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]["report"]


def stage_outputs(stage: dict) -> list[str]:
    return [next(iter(out)) if isinstance(out, dict) else out
            for out in [*stage["outs"], *stage.get("metrics", [])]]


def copy_inputs(stage: dict, root: Path) -> None:
    """Every dep of the stage but its code fingerprint (the code runs from this checkout)."""
    for rel in [*stage["deps"], *READ_BUT_NOT_DEPS]:
        if rel.startswith("data/code_fingerprints/"):
            continue
        source = REPO / rel
        assert source.exists(), f"{rel}: read by the report but not in git, so no clone can render it"
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        if source.is_dir():
            shutil.copytree(source, root / rel, dirs_exist_ok=True)
        else:
            shutil.copy2(source, root / rel)


def without_run_provenance(html: str) -> str:
    return RUN_PROVENANCE.sub("<!-- run-provenance -->", html)


def files_under(root: Path, rel: str) -> dict[str, Path]:
    path = root / rel
    if path.is_file():
        return {rel: path}
    return {p.relative_to(root).as_posix(): p for p in sorted(path.rglob("*")) if p.is_file()}


def differences(committed: Path, rendered: Path, outputs: list[str]) -> list[str]:
    """What differs between the committed outputs and the fresh ones, a line each (with the first
    differing lines of the page)."""
    found = []
    for rel in outputs:
        old, new = files_under(committed, rel), files_under(rendered, rel)
        found += [f"{name}: committed, not rendered" for name in sorted(old.keys() - new.keys())]
        found += [f"{name}: rendered, not committed" for name in sorted(new.keys() - old.keys())]
        for name in sorted(old.keys() & new.keys()):
            if name.endswith(".html"):
                before = without_run_provenance(old[name].read_text()).splitlines()
                after = without_run_provenance(new[name].read_text()).splitlines()
                if before != after:
                    diff = list(difflib.unified_diff(before, after, "committed", "rendered", n=0,
                                                     lineterm=""))
                    found.append(f"{name} differs:\n" + "\n".join(line[:300] for line in diff[:24]))
            elif old[name].read_bytes() != new[name].read_bytes():
                found.append(f"{name}: other bytes")
    return found


def render(stage: dict, root: Path) -> None:
    command = shlex.split(stage["cmd"])
    assert command[:2] == ["python", "-m"], command
    subprocess.run([sys.executable, *command[1:]], cwd=root, check=True, capture_output=True,
                   text=True, env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin", "HOME": str(root),
                                   "MPLBACKEND": "Agg"})


@pytest.fixture(scope="module")
def rendered(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("rendered")
    stage = report_stage()
    copy_inputs(stage, root)
    render(stage, root)
    return root


def test_the_committed_report_is_what_the_committed_code_renders(rendered):
    found = differences(REPO, rendered, stage_outputs(report_stage()))
    assert not found, (f"reports/ is not the output of this code ({RERENDER}):\n" + "\n".join(found))


def test_the_check_catches_a_paper_value_changed_without_its_page(tmp_path):
    """The same comparison, after a paper value moved: the page must change with it."""
    stage = report_stage()
    copy_inputs(stage, tmp_path)
    paper = tmp_path / "pipeline/report/paper_values.yaml"
    text = paper.read_text()
    assert "47.94" in text  # Table 3's Y-net ADE at t_f = 30 s
    paper.write_text(text.replace("47.94", "46.94", 1))
    render(stage, tmp_path)
    found = differences(REPO, tmp_path, ["reports/index.html"])
    assert found and "46.94" in (tmp_path / "reports/index.html").read_text()


def test_the_page_names_a_commit_of_this_history():
    """The commit the page was rendered from (its code may have had changes then: the render test
    above is what shows the page is this code's output)."""
    page = (REPO / "reports/index.html").read_text()
    named = re.search(r"Rendered [^<]* from commit <code>([0-9a-f]{12})</code>", page)
    assert named, "the page names no commit"
    git = ["git", "-C", str(REPO)]
    shallow = subprocess.run([*git, "rev-parse", "--is-shallow-repository"], capture_output=True,
                             text=True).stdout.strip() == "true"
    if shallow:
        pytest.skip("a shallow clone cannot tell whether the named commit is in its history")
    known = subprocess.run([*git, "merge-base", "--is-ancestor", named.group(1), "HEAD"])
    assert known.returncode == 0, f"commit {named.group(1)} is not in this branch's history"


def test_no_sentence_of_the_committed_page_runs_into_the_next():
    """A template line ending in `{% endif %}` swallows its newline: "model.Y-net's"."""
    page = re.sub(r"<style.*?</style>", "", (REPO / "reports/index.html").read_text(), flags=re.S)
    text = html.unescape(re.sub(r"<[^>]+>", "", page))
    glued = [text[max(0, m.start() - 30):m.end() + 20]
             for m in re.finditer(r"\w{2,}[)\]]?\.(?=[A-Z][\w-])", text)]
    assert glued == []
