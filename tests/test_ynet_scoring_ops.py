"""Y-net scoring's CUDA path, run and counted on the CPU: how many aten ops it dispatches per window
(each one or more kernel launches on a GPU, where launches were most of scoring's time: issue 62)
and that none of them is slow on CUDA in the deterministic mode scoring runs in.

The path is `ynet_scoring.predict_samplings` as CUDA takes it: TTST's k-means in its sync-light
mode (`kmeans_check_every`) over the goals of a whole scene's windows at once (`ttst_windows`),
here with those two choices made as on CUDA. Counted with `tests/sync_audit.py` (a dispatch mode:
every operator, views included). The scene is the size `bench/gpu_check.py` scores (32 windows,
about an SDD test scene's mean of 35), with the `paper` profile's scoring (K_e 20, K_a 1, TTST +
CWS, batch 4, chunk 8) and its model's levels and waypoints; the channels are few, which changes no
count. Before issue 62 this path dispatched 1,181.5 ops a window on this very scene, 1,296 of them
`scatter_add_` (docs/experiments/2026-11-28-gpu-scoring-cpu-path.md).
"""

import dataclasses
from collections import Counter
from pathlib import Path

import pytest
import torch

from bench.bench_profiles import ScoringBench, main_options, profile_settings
from bench.common import tiny_ynet
from pipeline.config.loading import read_params
from pipeline.device import CPU
from pipeline.runners import ynet_scoring
from tests.sync_audit import SyncAudit
from tests.test_ynet_scoring_sync import HOST_CHECK, peaky_points
from tests.test_ynet_sampling import gen
from ynet.sampling import kmeans

ROOT = Path(__file__).resolve().parents[1]
WINDOWS = 32
MAX_OPS_PER_WINDOW = 300


@pytest.fixture(scope="module")
def cuda_path():
    """The audit of scoring one scene of 32 windows as on CUDA, and the bench that scored it."""
    torch.set_num_threads(1)
    params = read_params(ROOT / "params.yaml")
    settings, evaluation = profile_settings(params, "paper", 1)
    settings = tiny_ynet(settings)
    evaluation = dataclasses.replace(evaluation, k_e=20, k_a=1)
    torch.manual_seed(0)
    bench = ScoringBench(settings, evaluation, CPU, WINDOWS, main_options(evaluation, params),
                         (512, 416))
    cuda = torch.device("cuda")
    check_every, ttst_windows = ynet_scoring.kmeans_check_every, ynet_scoring.ttst_windows
    with pytest.MonkeyPatch.context() as patch:  # the choices CUDA makes, on the CPU
        patch.setattr(ynet_scoring, "kmeans_check_every", lambda device: check_every(cuda))
        patch.setattr(ynet_scoring, "ttst_windows", lambda device, batch: ttst_windows(cuda, batch))
        with SyncAudit() as audit:
            bench.run(WINDOWS)
    return audit, bench


def test_the_cuda_path_dispatches_at_most_300_ops_a_window(cuda_path):
    audit, bench = cuda_path
    assert (bench.evaluation.batch_size, bench.evaluation.chunk_size, bench.options.K) == (4, 8, 20)
    total = sum(audit.ops.values())
    top = ", ".join(f"{op} {n}" for op, n in audit.ops.most_common(10))
    print(f"\n{total} ops for {WINDOWS} windows: {total / WINDOWS:.1f} a window; top: {top}")
    assert audit.ops["aten.bmm.default"] > 16  # the k-means ran (one product per iteration)
    assert total / WINDOWS <= MAX_OPS_PER_WINDOW


def test_the_cuda_path_has_no_op_slow_on_cuda_when_deterministic(cuda_path):
    audit, _ = cuda_path
    assert audit.slow == []


def test_the_cuda_path_waits_at_the_checks_and_copies_the_scene_once(cuda_path):
    audit, _ = cuda_path
    blocks = audit.ops["aten.randint.generator"]  # a block's restart points in one draw
    kinds = Counter(what for what, _ in audit.events)
    assert kinds == {"scalar read": blocks, "cpu": 1, "numpy": 1}
    assert audit.events.count(HOST_CHECK) == blocks


def test_the_default_mode_is_seen_to_scatter():
    """The check of slow ops sees them: the CPU's exact k-means sums with `scatter_add_`."""
    with SyncAudit() as audit:
        kmeans(peaky_points(), 4, gen(0), max_iter=3)
    assert Counter(audit.slow)["aten.scatter_add_.default"] >= 3
