"""Every speed benchmark `bench/bench_*.py` runs with `--smoke` (tiny sizes, synthetic inputs, one
thread, seconds) and prints its own result lines, so a changed signature breaks a test, not the next
person who runs the benchmark; a new benchmark without a smoke mode, or without its result lines
in `RESULT_LINES`, fails here. They run in this process as `python -m` runs them (`runpy`): a
subprocess each spent more CPU importing torch again than the benchmark's smoke run
(tests/test_gpu_check.py runs `python -m bench.gpu_check` in a process of its own, re-execution
included). The experiments of
`docs/experiments/` need trained models to run at all: they are only imported. A missing pipeline
output makes a benchmark exit `NEEDS_PIPELINE`, naming the file and the stage (`make bench`)."""

from __future__ import annotations

import importlib
import os
import re
import runpy
import sys
from pathlib import Path

import pytest
import torch

from bench import common
from bench.bench_ynet import KEEP_FREED_MEMORY

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = sorted(ROOT.glob("bench/bench_*.py"))
EXPERIMENTS = sorted((ROOT / "docs" / "experiments").glob("*.py"))
MIRROR = ROOT.parent / "shared" / "data"
NEEDS_MIRROR = {"bench_data.py"}  # times the data stages on the raw mirror (cheap: one repeat)
# Lines only a benchmark's body prints, each with a measured number: a header (the torch version,
# the load average) has numbers too, so one whose body stopped running would still print some.
RESULT_LINES = {
    "bench_baselines": [r"^sgan +\d+\.\d+ +\d+", r"^constant_velocity +\d+\.\d+$"],
    "bench_data": [r"^parse \d+ videos, .* \d+\.\d+ s$",
                   r"^verify \+ import release .* \d+\.\d+ s$"],
    "bench_evaluation_pass": [r"^one pass, each batch encoded once +\d+\.\d+",
                              r"^identical predictions: (True|False)$"],
    "bench_profiles": [r"^cpu +\d+\.\d+ +\d+x\d+ .* GiB$",
                       r"^paper +\d+\.\d+ +\d+x\d+ .* GiB$",
                       r"^  segmentation +\d+\.\d+ crops/s"],
    "bench_score_predictions": [r"^long_term: wall time, median of \d+: \d+\.\d+ s",
                                r"^short_term: wall time, median of \d+: \d+\.\d+ s"],
    "bench_scoring": [r"^  min_ade_fde +\d+\.\d+$", r"^  total +\d+\.\d+$"],
    "bench_segmentation": [r"^  augmented crops: +\d+\.\d+ crops/s",
                           r"^  training step: +\d+\.\d+ crops/s"],
    "bench_short_term_scoring": [r"^ +\d+ +\d+\.\d+$",
                                 r"^  trajectory decoder +\d+\.\d+ ms per window"],
    "bench_training_precision": [r"^  long-term, batch \d+, float32 +\d+\.\d+ samples/s",
                                 r"^  short-term ETH/UCY crops, .*bf16 +\d+\.\d+ samples/s"],
    "bench_ynet": [r"^  batch 1 NCHW +: \d+\.\d+ ", r"^  K_a 1 fp32 +: \d+\.\d+ ",
                   r"^  trajectory decoder \(batched, shared skips\) +\d+\.\d+ s"],
}


def missing_results(name: str, stdout: str) -> list[str]:
    """The result-line patterns of benchmark `name` that no line of `stdout` matches."""
    return [pattern for pattern in RESULT_LINES[name] if not re.search(pattern, stdout, re.M)]


def flushes_denormals() -> bool:
    """Whether torch flushes denormals to zero now (`torch.set_flush_denormal` has no getter)."""
    return torch.tensor([1e-39]).mul(1.0).item() == 0.0


@pytest.fixture
def as_a_fresh_process(monkeypatch):
    """What `python -m bench.<name>` had in a process of its own: the repository as working folder
    and the malloc setting as the stages run (so `keep_freed_memory` does not re-execute, which here
    would replace pytest: refused). Torch's threads, denormal mode and random state the benchmark
    sets are put back for the tests after it."""
    monkeypatch.chdir(ROOT)
    monkeypatch.setenv("GLIBC_TUNABLES", KEEP_FREED_MEMORY)
    monkeypatch.setattr(os, "execve", lambda *args: pytest.fail(f"re-executes: {args[1]}"))
    threads, flushing = torch.get_num_threads(), flushes_denormals()
    with torch.random.fork_rng(devices=[]):
        yield
    torch.set_num_threads(threads)
    torch.set_flush_denormal(flushing)


def run_module(name: str, argv: list[str]) -> int:
    """`python -m name *argv`, in this process: the exit status it would have had."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sys, "argv", [name, *argv])
        try:
            runpy.run_module(name, run_name="__main__", alter_sys=True)
        except SystemExit as stop:
            return stop.code if isinstance(stop.code, int) else int(stop.code is not None)
    return 0


@pytest.mark.parametrize("script", BENCHMARKS, ids=lambda path: path.stem)
@pytest.mark.filterwarnings("ignore:'bench[.]bench_[a-z_]+' found in sys.modules:RuntimeWarning")
def test_the_benchmark_runs_with_smoke_and_prints_its_results(script, as_a_fresh_process, capsys):
    if script.name in NEEDS_MIRROR and not MIRROR.exists():
        pytest.skip(f"{MIRROR} not on this machine")
    status = run_module(f"bench.{script.stem}", ["--smoke"])
    stdout = capsys.readouterr().out
    assert status == 0, f"exit {status}\n{stdout[-2000:]}"
    assert missing_results(script.stem, stdout) == [], stdout[-2000:]


def test_the_benchmarks_are_found_each_with_its_result_lines():
    assert len(BENCHMARKS) >= 10 and ROOT / "bench" / "bench_ynet.py" in BENCHMARKS
    assert sorted(RESULT_LINES) == [script.stem for script in BENCHMARKS]


def test_a_header_alone_is_no_result():
    """What a benchmark whose body was removed prints: its header, numbers and all."""
    header = "torch 2.13.0+cpu, 1 threads, load average 5.06 4.65 3.17\nload average 5.16; 2 cores"
    assert all(missing_results(name, header) == RESULT_LINES[name] for name in RESULT_LINES)


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


def test_a_benchmark_without_its_inputs_exits_needs_pipeline(tmp_path, as_a_fresh_process,
                                                             capsys):
    """Not in smoke mode, in a folder without data/: the distinct exit `make bench` goes on after."""
    status = run_module("bench.bench_score_predictions", ["--root", str(tmp_path)])
    stdout = capsys.readouterr().out
    assert status == common.NEEDS_PIPELINE, stdout[-3000:]
    assert (f"needs {tmp_path / 'data/predictions/long_term'}: run `dvc repro score_predictions`"
            in stdout)
