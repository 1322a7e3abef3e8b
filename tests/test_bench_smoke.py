"""Every speed benchmark `bench/bench_*.py` runs with `--smoke` (tiny sizes, synthetic inputs, one
thread, seconds) and prints numbers, so a changed signature breaks a test, not the next person who
runs the benchmark; a new benchmark without a smoke mode fails here. The experiments of
`docs/experiments/` need trained models to run at all: they are only imported. A missing pipeline
output makes a benchmark exit `NEEDS_PIPELINE`, naming the file and the stage (`make bench`)."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from bench import common
from bench.bench_ynet import KEEP_FREED_MEMORY

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = sorted(ROOT.glob("bench/bench_*.py"))
EXPERIMENTS = sorted((ROOT / "docs" / "experiments").glob("*.py"))
MIRROR = ROOT.parent / "shared" / "data"
NEEDS_MIRROR = {"bench_data.py"}  # times the data stages on the raw mirror (cheap: one repeat)
NUMBER = re.compile(r"\d+\.\d+")


@pytest.mark.parametrize("script", BENCHMARKS, ids=lambda path: path.stem)
def test_the_benchmark_runs_with_smoke_and_prints_numbers(script):
    if script.name in NEEDS_MIRROR and not MIRROR.exists():
        pytest.skip(f"{MIRROR} not on this machine")
    env = {**os.environ, "OMP_NUM_THREADS": "1",
           "GLIBC_TUNABLES": KEEP_FREED_MEMORY}  # as the stages run: no re-execution to set it
    done = subprocess.run([sys.executable, "-m", f"bench.{script.stem}", "--smoke"], cwd=ROOT,
                          env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"exit {done.returncode}\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
    assert NUMBER.search(done.stdout), done.stdout[-2000:]


def test_the_benchmarks_are_found():
    assert len(BENCHMARKS) >= 10 and ROOT / "bench" / "bench_ynet.py" in BENCHMARKS


@pytest.mark.parametrize("script", EXPERIMENTS, ids=lambda path: path.stem)
def test_the_experiment_imports(script):
    """What an experiment imports still exists (run as `python -m docs.experiments.<name>`)."""
    importlib.import_module(f"docs.experiments.{script.stem}")


def test_a_missing_output_names_its_stage_and_exits_needs_pipeline(tmp_path, capsys):
    there = tmp_path / "there.pt"
    there.touch()
    common.require("bench_x", {there: common.repro("train_ynet")})  # all there: returns
    with pytest.raises(SystemExit) as stopped:
        common.require("bench_x", {there: common.repro("train_ynet"),
                                   tmp_path / "model.pt": common.repro("train_ynet"),
                                   tmp_path / "maps": common.repro("semantic_maps")})
    assert stopped.value.code == common.NEEDS_PIPELINE
    assert f"-eq {common.NEEDS_PIPELINE}" in (ROOT / "Makefile").read_text()  # make bench goes on
    assert capsys.readouterr().out.splitlines() == [
        f"bench_x: needs {tmp_path / 'model.pt'}: run `dvc repro train_ynet`",
        f"bench_x: needs {tmp_path / 'maps'}: run `dvc repro semantic_maps`"]


def test_a_benchmark_without_its_inputs_exits_needs_pipeline(tmp_path):
    """Not in smoke mode, in a folder without data/: the distinct exit `make bench` goes on after."""
    done = subprocess.run([sys.executable, "-m", "bench.bench_score_predictions",
                           "--root", str(tmp_path)], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == common.NEEDS_PIPELINE, done.stderr[-3000:]
    assert (f"needs {tmp_path / 'data/predictions/long_term'}: run `dvc repro score_predictions`"
            in done.stdout)
