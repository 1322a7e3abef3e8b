"""TTST without waiting for a GPU: `ynet.sampling.kmeans`' sync-light mode (`check_every`), which
scoring takes on CUDA (`ynet_scoring.kmeans_check_every`), and its default mode, which the CPU
takes, bit for bit as it was: the references below are the functions as they were before the
mode existed.

The audit (`tests/sync_audit.py`) runs on the CPU: what it counts would each block the host on
CUDA, so both modes are checked here without a GPU.
"""

from collections import Counter

import numpy as np
import pytest
import torch

from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.ynet import YnetSettings
from pipeline.runners import ynet_scoring
from pipeline.runners.ynet_scoring import (CUDA_KMEANS_CHECK_EVERY, Sampling, kmeans_check_every,
                                           predict_samplings, sampling_options, ttst_windows)
from tests.sync_audit import SyncAudit
from tests.test_no_fixed_device import N_FUTURE, N_PAST, SETTINGS, scenes
from tests.test_train_ynet import TTST
from tests.test_ynet_sampling import gen, tiny_model_and_windows, two_mode_logits
from ynet import sampling
from ynet.model import YNet
from ynet.sampling import (SamplingOptions, distinct_points, goal_masses, kmeans, nearest_centre,
                           predict, sample_positions, softargmax, ttst)

torch.set_num_threads(1)

HOST_CHECK = ("scalar read", "torch.bool")  # the sync-light mode's one kind of wait
CUDA = torch.device("cuda")


# The default mode as it was.

def reference_distinct_points(points):
    n, p, _ = points.shape
    order = points[..., 1].argsort(dim=-1, stable=True)
    order = order.gather(1, points[..., 0].gather(1, order).argsort(dim=-1, stable=True))
    ordered = points.gather(1, order[..., None].expand(n, p, 2))
    first = torch.ones(n, p, dtype=torch.bool, device=points.device)
    first[:, 1:] = (ordered[:, 1:] != ordered[:, :-1]).any(-1)
    slot = first.cumsum(1) - 1
    unique = points[:, :1].repeat(1, int(slot[:, -1].max()) + 1, 1)
    unique.scatter_(1, slot[..., None].expand(n, p, 2), ordered)
    weights = points.new_zeros(unique.shape[:2]).scatter_add_(1, slot, points.new_ones(n, p))
    return unique, weights


def reference_kmeans(points, k, generator, max_iter=1000, tol=1e-3, distinct=None):
    n, p, _ = points.shape
    first = torch.rand(n, p, generator=generator, device=points.device).argsort(dim=-1)[:, :k]
    centres = torch.gather(points, 1, first[..., None].expand(n, k, 2))
    unique, weights = reference_distinct_points(points) if distinct is None else distinct
    weighted = unique * weights[..., None]
    active = torch.ones(n, dtype=torch.bool, device=points.device)
    for _ in range(max_iter):
        nearest = nearest_centre(unique, centres)
        counts = points.new_zeros(n, k).scatter_add_(1, nearest, weights)
        sums = points.new_zeros(n, k, 2).scatter_add_(1, nearest[..., None].expand(n, -1, 2), weighted)
        new = sums / counts.clamp_min(1)[..., None]
        empty = counts == 0
        if empty.any():
            restart = torch.randint(p, (n, k), generator=generator, device=points.device)
            restart = torch.gather(points, 1, restart[..., None].expand(n, k, 2))
            new = torch.where(empty[..., None], restart, new)
        shift = (new - centres).square().sum(-1).sqrt().sum(-1)
        centres = torch.where(active[:, None, None], new, centres)
        active &= shift.square() >= tol
        if not active.any():
            break
    return centres


def reference_ttst(goal_logits, options, generator, check_every=None):
    assert check_every is None  # the default mode is what the CPU runs
    best = softargmax(goal_logits)[:, None]
    if options.K_e == 1:
        return best, torch.ones_like(best[..., 0])
    prob = torch.sigmoid(goal_logits / options.temperature)
    draws = sample_positions(prob, options.ttst_samples, generator, options.rel_threshold)
    distinct = reference_distinct_points(draws)
    centres = reference_kmeans(draws, options.K_e - 1, generator, options.kmeans_max_iter,
                               options.kmeans_tol, distinct)
    goals = torch.cat([best, centres], dim=1)
    return goals, goal_masses(draws, goals, distinct)


def peaky_points(n_points=2000):
    """(3, n_points, 2) pixels drawn from peaky maps, many repeated; set 2 from 100 pixels only."""
    prob = torch.rand(3, 24, 20, generator=gen(4)) ** 8
    prob[2, 5:] = 0.0
    return sample_positions(prob, n_points, gen(3), rel_threshold=0.01)


def restarted(points, k, seed, run) -> bool:
    """Whether `run(generator)` drew more than k-means' initial centres (a restart) from a
    generator seeded `seed`."""
    once = gen(seed)
    torch.rand(points.shape[:2], generator=once)  # the initial centres' draw alone
    used = gen(seed)
    run(used)
    return not torch.equal(used.get_state(), once.get_state())


def same_generator(a: torch.Generator, b: torch.Generator) -> bool:
    return torch.equal(a.get_state(), b.get_state())


# (a) The default mode: bit for bit the previous code, the generator left in the same state.

def test_default_mode_is_the_previous_kmeans_bit_for_bit_restarts_included():
    points = peaky_points()
    assert torch.equal(distinct_points(points)[0], reference_distinct_points(points)[0])
    assert torch.equal(distinct_points(points)[1], reference_distinct_points(points)[1])
    any_restart = False
    for k in (4, 19, 40):
        ours, theirs = gen(k), gen(k)
        assert torch.equal(kmeans(points, k, ours), reference_kmeans(points, k, theirs)), k
        assert same_generator(ours, theirs), k
        any_restart |= restarted(points, k, k, lambda g, k=k: kmeans(points, k, g))
    assert any_restart  # the restart branch was taken, and matched


def test_default_mode_is_the_previous_ttst_and_predict_bit_for_bit(monkeypatch):
    logits = torch.stack([two_mode_logits(), two_mode_logits().flip(-1),
                          torch.randn(48, 64, generator=gen(9)) * 3])
    for k_e in (1, 5, 20):
        options = SamplingOptions(K_e=k_e, temperature=1.0, rel_threshold=0.01)
        ours, theirs = gen(k_e), gen(k_e)
        goals, masses = ttst(logits, options, ours)
        expected_goals, expected_masses = reference_ttst(logits, options, theirs)
        assert torch.equal(goals, expected_goals) and torch.equal(masses, expected_masses), k_e
        assert same_generator(ours, theirs)
    model, past, x = tiny_model_and_windows(3)
    options = SamplingOptions(K_e=6, K_a=2, temperature=1.0, rel_threshold=0.01)
    ours = predict(model, x, past[:, -1], options, gen(2), 60.0, chunk_size=4)
    monkeypatch.setattr(sampling, "ttst", reference_ttst)
    theirs = predict(model, x, past[:, -1], options, gen(2), 60.0, chunk_size=4)
    for name in ("trajectory", "goals", "waypoints", "weights"):
        assert torch.equal(getattr(ours, name), getattr(theirs, name)), name


# (b) The sync-light mode waits for the host once per `check_every` iterations, nothing else.

@pytest.mark.parametrize("max_iter, check_every", [(64, 16), (64, 32), (40, 16)])
def test_sync_light_kmeans_reads_the_host_once_per_block_and_no_size(max_iter, check_every):
    points = peaky_points()
    with SyncAudit() as audit:  # tol 0: no set ever stops, all iterations run
        kmeans(points, 19, gen(0), max_iter=max_iter, tol=0.0, check_every=check_every)
    blocks = -(-max_iter // check_every)
    assert audit.events == [HOST_CHECK] * (blocks - 1)  # none after the last: the loop ends anyway
    assert audit.ops["aten.randint.generator"] == blocks  # a block's restart points in one draw
    assert audit.ops["aten.bmm.default"] == max_iter  # one one-hot product an iteration


def test_sync_light_ttst_and_predict_wait_once_per_16_iterations_for_a_batch():
    logits = torch.stack([two_mode_logits(), two_mode_logits().flip(-1)])
    options = SamplingOptions(K_e=5, temperature=1.0, rel_threshold=0.01)
    with SyncAudit() as audit:
        ttst(logits, options, gen(0), check_every=16)
    blocks = audit.ops["aten.randint.generator"]
    assert blocks > 0 and audit.events == [HOST_CHECK] * blocks  # it stopped at a check
    assert audit.ops["aten.bmm.default"] == 16 * blocks + 1  # the iterations and the goal masses
    model, past, x = tiny_model_and_windows(3)
    encoded = sampling.encode(model, x)
    for k_a, use_cws in ((1, True), (3, True), (1, False)):
        options = SamplingOptions(K_e=6, K_a=k_a, temperature=1.0, rel_threshold=0.01,
                                  use_cws=use_cws)
        with SyncAudit() as audit:  # under inference_mode, as scoring runs
            sampling.predict_encoded(model, encoded, past[:, -1], options, gen(1), 60.0,
                                     check_every=16)
        blocks = audit.ops["aten.randint.generator"]
        assert blocks > 0 and audit.events == [HOST_CHECK] * blocks
        assert audit.slow == []  # nothing slow on CUDA in deterministic mode


def test_the_default_mode_waits_twice_per_iteration_and_reads_a_size():
    """What the sync-light mode saves, and that the audit sees a per-iteration `.any()`."""
    points = peaky_points()
    with SyncAudit() as audit:
        kmeans(points, 19, gen(0), max_iter=64, tol=0.0)
    assert audit.events.count(HOST_CHECK) == 2 * 64  # empty.any() and active.any()
    assert audit.events.count(("scalar read", "torch.int64")) == 1  # distinct_points' size


def test_encode_selects_the_waypoint_maps_without_a_host_made_index():
    model, _, x = tiny_model_and_windows(2)
    with SyncAudit() as audit:
        encoded = sampling.encode(model, x)
    assert audit.events == []
    goal_logits = model.predict_goals(model.encode(x.contiguous(memory_format=torch.channels_last)))
    assert torch.equal(encoded.waypoint_logits, goal_logits[:, list(model.config.waypoints)])


# (c) Where no cluster empties, the same centres as the default mode; repeatable with the seed.

@pytest.mark.parametrize("check_every", [1, 16, 32])
def test_sync_light_centres_equal_the_default_modes_without_restarts(check_every):
    logits = torch.stack([two_mode_logits(), two_mode_logits().flip(-1),
                          torch.randn(48, 64, generator=gen(9)) * 3])
    draws = sample_positions(torch.sigmoid(logits), 10_000, gen(5), rel_threshold=0.01)
    wide = draws[2:]  # the random map's draws: 19 clusters without a restart
    for points, k, seed in ((draws, 4, 1), (draws, 4, 2), (draws, 9, 3), (wide, 19, 0),
                            (wide, 19, 1)):
        assert not restarted(points, k, seed, lambda g, points=points, k=k: kmeans(points, k, g))
        light, default = gen(seed), gen(seed)
        centres = kmeans(points, k, light, check_every=check_every)
        assert torch.equal(centres, kmeans(points, k, default)), (k, seed)
        assert not same_generator(light, default)  # its own stream of (unused) restart draws
        again = gen(seed)
        assert torch.equal(kmeans(points, k, again, check_every=check_every), centres)
        assert same_generator(again, light)
    options = SamplingOptions(K_e=5, temperature=1.0, rel_threshold=0.01)  # TTST: no restart
    goals, masses = ttst(logits, options, gen(0), check_every)
    expected_goals, expected_masses = ttst(logits, options, gen(0))
    assert torch.equal(goals, expected_goals) and torch.equal(masses, expected_masses)


def test_sync_light_restarts_empty_clusters_and_repeats_with_the_seed():
    points = torch.tensor([[[0.0, 0.0]] * 50 + [[10.0, 10.0]] * 50])  # two distinct points only
    centres = kmeans(points, 4, gen(0), check_every=16)
    assert {tuple(c) for c in centres[0].tolist()} == {(0.0, 0.0), (10.0, 10.0)}
    points = peaky_points()
    assert restarted(points, 40, 40, lambda g: kmeans(points, 40, g))  # set 2: < 40 pixels
    first, second = gen(40), gen(40)
    centres = kmeans(points, 40, first, check_every=16)
    assert torch.equal(kmeans(points, 40, second, check_every=16), centres)
    assert same_generator(first, second)
    model, past, x = tiny_model_and_windows(2)
    options = SamplingOptions(K_e=20, K_a=2, temperature=1.0, rel_threshold=0.01)
    runs = [predict(model, x, past[:, -1], options, gen(3), 60.0, check_every=16) for _ in range(2)]
    assert torch.equal(runs[0].waypoints, runs[1].waypoints)
    assert torch.equal(runs[0].trajectory, runs[1].trajectory)


def test_point_counts_are_distinct_points_without_scatter_at_a_fixed_size():
    points = torch.cat([peaky_points(), torch.tensor([[[-1.5, 2.0], [0.25, -3.0]] * 1000] * 3)], 1)
    with SyncAudit() as audit:
        ordered, counts = sampling.point_counts(points)  # (N, P, 2), (N, P)
    assert audit.events == [] and audit.slow == []
    assert ordered.shape == points.shape and counts.shape == points.shape[:2]
    unique, weights = distinct_points(points)  # (N, U, 2), (N, U)
    for n in range(points.shape[0]):
        kept = counts[n] > 0
        assert torch.equal(ordered[n][kept], unique[n][weights[n] > 0])  # the same points, in order
        assert torch.equal(counts[n][kept], weights[n][weights[n] > 0])  # counted alike
        assert sorted(map(tuple, ordered[n].tolist())) == sorted(map(tuple, points[n].tolist()))


def test_sync_light_goal_masses_equal_the_default_ones_without_scatter():
    logits = torch.stack([two_mode_logits(), two_mode_logits().flip(-1),
                          torch.randn(48, 64, generator=gen(9)) * 3])
    draws = sample_positions(torch.sigmoid(logits), 10_000, gen(5), rel_threshold=0.01)
    goals = torch.rand(3, 7, 2, generator=gen(6)) * 60
    goals[:, 3] = goals[:, 2]  # a tie: the first goal takes the points
    with SyncAudit() as audit:
        light = goal_masses(draws, goals, sync_light=True)
    assert audit.events == [] and audit.slow == []
    assert torch.equal(light, goal_masses(draws, goals)) and not light[:, 3].any()


# (d) Weight-0 points change no centre.

@pytest.mark.parametrize("check_every", [None, 16])
def test_weight_0_padding_changes_no_centre(check_every):
    points = peaky_points()
    n, p, _ = points.shape
    unique, weights = distinct_points(points)  # (N, U, 2), (N, U)
    fixed_unique, fixed_weights = distinct_points(points, size=p)  # (N, P, 2), (N, P)
    u = unique.shape[1]
    assert u < p and torch.equal(fixed_unique[:, :u], unique)
    assert torch.equal(fixed_weights[:, :u], weights) and not fixed_weights[:, u:].any()
    stray = torch.rand(n, 300, 2, generator=gen(8)) * 200 - 50  # weight-0 points anywhere
    padded = (torch.cat([unique, stray], 1), torch.cat([weights, weights.new_zeros(n, 300)], 1))
    for k, seed in ((4, 0), (19, 1), (40, 40)):  # k = 40 restarts empty clusters
        plain = kmeans(points, k, gen(seed), distinct=(unique, weights), check_every=check_every)
        for distinct in ((fixed_unique, fixed_weights), padded, sampling.point_counts(points)):
            assert torch.equal(kmeans(points, k, gen(seed), distinct=distinct,
                                      check_every=check_every), plain), (k, seed)


def test_check_every_must_be_positive():
    with pytest.raises(ValueError, match="check_every"):
        kmeans(peaky_points(), 4, gen(0), check_every=0)


# The scoring runner: the mode follows the device.

def test_the_runner_takes_the_exact_mode_on_the_cpu_and_the_sync_light_one_on_cuda():
    assert kmeans_check_every(torch.device("cpu")) is None
    assert kmeans_check_every(torch.device("cuda", 0)) == CUDA_KMEANS_CHECK_EVERY == 16
    assert [ttst_windows(torch.device("cpu"), b) for b in (1, 4, 100)] == [1, 4, 100]
    assert [ttst_windows(torch.device("cuda"), b) for b in (1, 4, 24, 100)] == [64, 64, 48, 100]


@pytest.fixture(params=[0, 32], ids=["whole scene", "crops"])
def runner(request):
    """A tiny model, 5 windows in batches of 2 and 4 samplings of them (K_a 1 and 2, 2 seeds):
    `predict_samplings`' arguments."""
    torch.manual_seed(0)
    settings = YnetSettings(**SETTINGS, crop=request.param, crop_lead_steps=1.0)
    model = YNet(settings.model_config(N_PAST, N_FUTURE)).eval()
    test_scenes, arrays = scenes(5, settings.resize)
    samplings = [Sampling(sampling_options(3, k_a, TTST, CwsParams(), True, True), seed)
                 for k_a in (1, 2) for seed in (0, 1)]
    return model, test_scenes, settings, samplings, EvalParams(k_e=3, batch_size=2), len(arrays)


def run(model, test_scenes, settings, samplings, params, n):
    sampled, _ = predict_samplings(model, test_scenes, settings, samplings, params, n, "test",
                                   settings.crop, settings.crop_lead_steps)
    return sampled


def test_the_runner_on_the_cpu_scores_as_the_previous_ttst(runner, monkeypatch):
    ours = run(*runner)
    monkeypatch.setattr(sampling, "ttst", reference_ttst)
    for mine, theirs in zip(ours, run(*runner)):
        for name in ("paths", "goals", "weights"):
            np.testing.assert_array_equal(getattr(mine, name), getattr(theirs, name))


def test_the_runner_in_the_cuda_mode_waits_only_at_checks_and_once_a_scene(runner, monkeypatch):
    """The runner's CUDA mode, run on the CPU: the k-means checks of each sampling (the goals of
    the scene's windows drawn at once), and one copy of the scene's results to the host; repeatable
    with the seeds."""
    check_every, group = kmeans_check_every, ttst_windows
    monkeypatch.setattr(ynet_scoring, "kmeans_check_every", lambda device: check_every(CUDA))
    monkeypatch.setattr(ynet_scoring, "ttst_windows", lambda device, batch: group(CUDA, batch))
    with SyncAudit() as audit:
        light = run(*runner)
    blocks = audit.ops["aten.randint.generator"]
    kinds = Counter(what for what, _ in audit.events)
    # the copy is `.cpu().numpy()`: on CUDA the `.numpy()` of a host tensor is free
    assert kinds == {"cpu": len(runner[1]), "numpy": len(runner[1]), "scalar read": blocks}
    assert audit.events.count(HOST_CHECK) == blocks >= len(runner[3])  # each sampling's k-means
    assert audit.slow == []
    for mine, again in zip(light, run(*runner)):
        np.testing.assert_array_equal(mine.paths, again.paths)
        np.testing.assert_array_equal(mine.goals, again.goals)
        np.testing.assert_array_equal(mine.weights, again.weights)
