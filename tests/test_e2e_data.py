"""`dvc repro audit` on a fixture mirror, in a temporary copy of the repository."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.fixtures import write_mirror

REPO = Path(__file__).resolve().parents[1]


def copy_repo(target: Path) -> None:
    for name in ("dvc.yaml", "params.yaml", "pyproject.toml"):
        shutil.copy(REPO / name, target / name)
    for package in ("pipeline", "ynet"):
        shutil.copytree(REPO / package, target / package,
                        ignore=shutil.ignore_patterns("__pycache__"))


def run(args, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "DVC_NO_ANALYTICS": "1"}
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_dvc_repro_audit_on_fixture_mirror(tmp_path):
    repo = tmp_path / "repo"
    repo.mkdir()
    copy_repo(repo)
    expected = write_mirror(tmp_path / "mirror", repo / "manifests")
    params = yaml.safe_load((repo / "params.yaml").read_text())
    params["fetch"].update(locations=[str(tmp_path / "elsewhere"), str(tmp_path / "mirror")],
                           sources=["sdd", "ynet-release"])
    (repo / "params.yaml").write_text(yaml.safe_dump(params))

    assert run(["dvc", "init", "--no-scm", "-q"], repo).returncode == 0
    result = run(["dvc", "repro", "audit"], repo)
    assert result.returncode == 0, result.stdout + result.stderr

    stats = json.loads((repo / "metrics/windows.json").read_text())
    assert stats["release"]["tf30"] == expected["release"]
    assert {k: v for k, v in stats["raw"]["tf30"].items() if k != "outside_split"} == expected["raw_tf30"]
    assert {k: v for k, v in stats["raw"]["tf5"].items() if k != "outside_split"} == expected["raw_tf5"]
    audit = json.loads((repo / "metrics/data_audit.json").read_text())
    assert audit["totals"]["exact_matches"] == 3 and audit["totals"]["unexplained_mismatches"] == 0
    assert audit["videos"]["gates_2"] == {"ours": 2, "release": 2, "exact_matches": 2}

    # The detailed JSON is a plain output; `dvc metrics show` prints only the report's headline.
    shown = run(["dvc", "metrics", "show", "--json"], repo)
    assert shown.returncode == 0 and "reports/headline" in shown.stdout
    assert "exact_matches" not in shown.stdout and "data_audit" not in shown.stdout

    # A tampered release pickle must stop the pipeline before anything unpickles it.
    pickle = tmp_path / "mirror/ynet-release/data/SDD/test_longterm.pkl"
    pickle.write_bytes(pickle.read_bytes()[:-1] + b"\x00")
    failed = run(["dvc", "repro", "--force", "--single-item", "fetch@ynet-release"], repo)
    assert failed.returncode != 0
    assert "checksum mismatch data/SDD/test_longterm.pkl" in failed.stdout + failed.stderr
    assert not (repo / "data/raw/ynet-release").exists()
