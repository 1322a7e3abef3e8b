"""`python -m bench.gpu_check --smoke` runs end to end on the CPU and writes its JSON and text:
what a GPU session runs as one command must not first fail there. The CUDA-only parts say they
were skipped there; their code (the profile, the sync count) runs here with the CPU standing in
for the GPU."""

import dataclasses
import json
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
import torch
from torch.autograd import DeviceType
from torch.profiler import ProfilerActivity

from bench.bench_profiles import ScoringBench, TrainingBench
from bench.gpu_check import (count_sync_warnings, output_paths, profile_scoring, profile_training,
                              sync_counts, top_events)
from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile, read_params
from pipeline.config.ynet import YnetSettings
from pipeline.device import CPU
from ynet.sampling import SamplingOptions

ROOT = Path(__file__).resolve().parents[1]
KEYS = {"smoke", "environment", "profile", "training_old", "training_new", "training_speedup",
        "ethucy_training", "kernels", "scoring", "scoring_training_settings", "ethucy_scoring",
        "ethucy_scoring_training_settings", "scoring_repeats", "scoring_kernels", "syncs",
        "stage_rates", "rates", "counts", "projection", "projection_total_known_hours", "seconds"}
RATES = {"ynet_sdd", "ynet_ethucy", "segmentation", "sgan", "pecnet"}


def test_the_smoke_run_writes_every_part_with_positive_rates(tmp_path):
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "bench.gpu_check", "--smoke", "--device", "cpu", "--threads", "1",
         "--out", str(out), "--data", str(tmp_path / "no_data"),
         "--rates-file", str(tmp_path / "rates" / "cpu-smoke.json")],
        cwd=ROOT, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads((out / "gpu_check.json").read_text())
    assert KEYS <= set(report)
    assert report["smoke"] is True
    for part in ("training_old", "training_new", "ethucy_training", "scoring",
                 "scoring_training_settings", "ethucy_scoring", "ethucy_scoring_training_settings"):
        assert "error" not in report[part], report[part]
        assert report[part]["rate"] > 0 and report[part]["tflops"] > 0
        assert report[part]["peak_memory"]["bytes"] > 0
    assert report["ethucy_training"]["map"] == [96, 128]  # 144 x 180 at 1 / 1.5, padded
    assert report["scoring_repeats"]["identical"] is True
    assert report["kernels"] == report["syncs"] == report["scoring_kernels"] == "skipped: no CUDA"
    assert set(report["rates"]) == RATES
    assert all(isinstance(rate, float) and rate > 0 for rate in report["rates"].values())
    rates = json.loads((tmp_path / "rates" / "cpu-smoke.json").read_text())
    assert rates["rates"] == report["rates"] and "torch" in rates["device"]
    assert set(rates["sources"]) == RATES | set(rates["scoring_windows_per_s"])
    assert rates["scoring_windows_per_s"]["ethucy_scoring"] == report["ethucy_scoring"]["rate"]
    rows = report["projection"]
    assert rows and all(row["hours"] is None and "needs" in row["unknown"] for row in rows)
    text = (out / "gpu_check.txt").read_text()
    assert "skipped: no CUDA" in text and "total of the known rows" in text


TINY = dict(resize=0.25, batch_size=2, augmentations=2, kernel_size=7, sigma=1.5,
            encoder_channels=[4, 4, 8, 8, 8], decoder_channels=[8, 8, 8, 4, 4], threads=1)


@pytest.fixture(scope="module")
def benches():
    """A tiny Y-net's training and scoring benches on the CPU, measured once (so both are warm)."""
    torch.set_num_threads(1)
    settings = YnetSettings(**TINY)
    evaluation = dataclasses.replace(load_profile(EvalParams, "eval", read_params(ROOT / "params.yaml")),
                                     batch_size=2, chunk_size=4)
    training = TrainingBench(settings, CPU, 3, image_hw=(256, 256))
    scoring = ScoringBench(settings, evaluation, CPU, 3, SamplingOptions(K_e=4, K_a=1, temperature=1.8), (256, 256))
    return training, training.measure(), scoring, scoring.measure()


def test_the_benches_time_warm_steps_and_windows(benches):
    _, trained, _, scored = benches
    assert trained["steps"] == 3 and trained["samples"] == 6 and trained["warmup_steps"] == 1
    assert trained["shapes"] == [[2, 64, 64]] and trained["map"] == [64, 64]
    assert scored["windows"] == 3 and scored["warmup_windows"] == 3  # a batch of 2, then of 1
    assert min(trained["rate"], trained["tflops"], scored["rate"], scored["tflops"]) > 0


def test_the_scoring_profile_counts_launches_per_window(benches):
    result = profile_scoring(benches[2], [ProfilerActivity.CPU], DeviceType.CPU, "self_cpu_time_total")
    assert result["windows"] == 3 and result["kernel_ms"] > 0
    assert result["launches"] == result["launches_per_window"] == 0  # no CUDA launch on a CPU
    assert any("conv" in row["name"] for row in result["kernels"])


def test_the_kernel_profile_runs_with_the_cpu_as_its_device(benches):
    result = profile_training(benches[0], 2, [ProfilerActivity.CPU], DeviceType.CPU,
                              "self_cpu_time_total")
    assert result["steps"] == 2 and result["kernel_ms"] > 0
    assert any("conv" in row["name"] for row in result["kernels"])


def test_the_sync_count_runs_on_the_cpu(benches):
    result = sync_counts(benches[0], benches[2], 2, set_mode=lambda mode: None)
    assert (result["training"]["steps"], result["scoring"]["windows"]) == (2, 2)
    assert result["calibration"] == result["training"]["count"] == result["scoring"]["count"] == 0


def test_output_paths():
    assert output_paths(Path("out")) == (Path("out/gpu_check.json"), Path("out/gpu_check.txt"))
    assert output_paths(Path("x/run.json")) == (Path("x/run.json"), Path("x/run.txt"))


def test_top_events_ranks_by_time_with_shares():
    a = torch.randn(64, 64)
    with torch.profiler.profile(activities=[torch.profiler.ProfilerActivity.CPU]) as prof:
        for _ in range(3):
            a @ a
        a + a
    events = prof.key_averages()
    assert all(hasattr(e, "self_device_time_total") for e in events)  # what the GPU check reads
    top = top_events(events, "self_cpu_time_total", 2, torch.autograd.DeviceType.CPU)
    assert len(top) == 2 and top[0]["ms"] >= top[1]["ms"] > 0
    assert 0 < top[0]["share"] <= 1 and {"name", "calls"} <= set(top[0])
    assert "aten::mm" in {row["name"] for row in top_events(events, "self_cpu_time_total", 10)}
    assert top_events(events, "self_cpu_time_total", 5, torch.autograd.DeviceType.CUDA) == []


def test_count_sync_warnings_counts_only_sync_warnings_and_restores_the_mode():
    modes = []

    def work():
        for _ in range(3):
            warnings.warn("called a synchronizing CUDA operation")
        warnings.warn("something else")

    counted = count_sync_warnings(work, set_mode=modes.append)
    assert counted["count"] == 3 and counted["other_warnings"] == 1
    assert modes == ["warn", 0]
    assert counted["where"][0][1] == 3 and counted["where"][0][0].startswith("tests/test_gpu_check.py:")


def test_the_calibration_counts_one_for_one_sync_though_the_mode_warns_that_it_is_a_prototype():
    """torch's `set_sync_debug_mode` warns, once a process, that the mode "does not yet detect all
    synchronizing operations": only "called a synchronizing CUDA operation" counts as a sync."""
    warned = []

    def set_mode(mode):  # as torch does: a one-time warning when the mode is first turned on
        if mode == "warn" and not warned:
            warned.append(mode)
            warnings.warn("Synchronization debug mode is a prototype feature and does not yet "
                          "detect all synchronizing operations")

    def one_item():
        warnings.warn("called a synchronizing CUDA operation")

    first = count_sync_warnings(one_item, set_mode)
    assert (first["count"], first["other_warnings"]) == (1, 1)
    assert count_sync_warnings(one_item, set_mode) == {**first, "other_warnings": 0}
