"""tools/run_study.py on a tiny DVC repository: a frozen study runs only through it, and
`--relock-code` re-records a study's code fingerprint, and nothing else, in the study's own lock."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
STUDY = """\
stages:
  tiny:
    frozen: true
    wdir: ..
    cmd: cat data/in.txt > studies/out.txt
    deps:
      - data/code_fingerprints/stages/tiny.json
      - data/in.txt
    outs:
      - studies/out.txt:
          cache: false
"""


def run_study(root: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "tools.run_study", *args], cwd=root,
                          env=env, capture_output=True, text=True)


@pytest.fixture
def study(tmp_path: Path) -> Path:
    subprocess.run(["git", "init", "-q"], cwd=tmp_path, check=True)
    subprocess.run([sys.executable, "-m", "dvc", "init", "-q"], cwd=tmp_path, check=True)
    (tmp_path / "data/code_fingerprints/stages").mkdir(parents=True)
    (tmp_path / "data/code_fingerprints/stages/tiny.json").write_text('{"code": "a"}\n')
    (tmp_path / "data/in.txt").write_text("1\n")
    (tmp_path / "studies").mkdir()
    (tmp_path / "studies/dvc.yaml").write_text(STUDY)
    made = run_study(tmp_path, "studies/dvc.yaml")
    assert made.returncode == 0, made.stderr
    assert (tmp_path / "studies/out.txt").read_text() == "1\n"
    return tmp_path


def fingerprint_md5(root: Path) -> str:
    lock = yaml.safe_load((root / "studies/dvc.lock").read_text())
    return next(dep["md5"] for dep in lock["stages"]["tiny"]["deps"]
                if dep["path"].startswith("data/code_fingerprints/"))


def test_relock_code_rerecords_a_changed_fingerprint_and_runs_nothing(study):
    before = fingerprint_md5(study)
    (study / "data/code_fingerprints/stages/tiny.json").write_text('{"code": "b"}\n')
    assert "tiny: runs" in run_study(study, "studies/dvc.yaml", "--dry").stdout
    relocked = run_study(study, "studies/dvc.yaml", "--relock-code")
    assert relocked.returncode == 0, relocked.stderr
    assert "re-recorded the code fingerprints of 1 studies" in relocked.stdout
    assert fingerprint_md5(study) != before
    assert "tiny: up to date" in run_study(study, "studies/dvc.yaml", "--dry").stdout
    again = run_study(study, "studies/dvc.yaml", "--relock-code")
    assert "nothing to re-record" in again.stdout


def test_relock_code_refuses_a_study_whose_inputs_changed(study):
    before = (study / "studies/dvc.lock").read_text()
    (study / "data/code_fingerprints/stages/tiny.json").write_text('{"code": "b"}\n')
    (study / "data/in.txt").write_text("2\n")
    refused = run_study(study, "studies/dvc.yaml", "--relock-code")
    assert refused.returncode == 1 and "must run" in refused.stdout and "tiny" in refused.stdout
    assert (study / "studies/dvc.lock").read_text() == before
    assert (study / "studies/out.txt").read_text() == "1\n"  # nothing ran
