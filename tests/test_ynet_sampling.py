import math

import pytest
import torch
from torch.testing import assert_close

from ynet.heatmaps import scene_and_past
from ynet.model import YNet, YNetConfig
from ynet.sampling import (
    SamplingOptions,
    cws_prior,
    cws_waypoints,
    expected_position,
    distinct_points,
    goal_masses,
    kmeans,
    nearest_centre,
    predict,
    sample_positions,
    sample_waypoints,
    softargmax,
    ttst,
    ttst_goals,
)

torch.set_num_threads(1)

CFG = YNetConfig(
    obs_len=3,
    pred_len=6,
    semantic_classes=2,
    encoder_channels=(4, 8, 8),
    decoder_channels=(8, 8, 4),
    waypoints=(1, 3, 5),
)


def gen(seed=0):
    return torch.Generator().manual_seed(seed)


def two_mode_logits(h=48, w=64):
    """Goal logits with two blobs, at (x=12, y=10) and (x=50, y=36)."""
    ys, xs = torch.meshgrid(torch.arange(h * 1.0), torch.arange(w * 1.0), indexing="ij")
    blob = lambda x, y: torch.exp(-((xs - x) ** 2 + (ys - y) ** 2) / (2 * 3.0**2))  # noqa: E731
    return 8 * (blob(12, 10) + blob(50, 36)) - 6  # (H, W)


def test_softargmax_one_hot():
    logits = torch.full((2, 3, 20, 30), -1e4)
    spots = [[(4, 7), (0, 0), (29, 19)], [(13, 2), (5, 18), (22, 11)]]  # (x, y)
    for b, row in enumerate(spots):
        for t, (x, y) in enumerate(row):
            logits[b, t, y, x] = 0.0
    assert_close(softargmax(logits), torch.tensor(spots, dtype=torch.float32))


def test_softargmax_of_flat_map_is_centre_and_of_two_pixels_is_midpoint():
    assert_close(softargmax(torch.zeros(1, 9, 5)), torch.tensor([[2.0, 4.0]]))
    logits = torch.full((1, 10, 10), -1e4)
    logits[0, 2, 3] = logits[0, 6, 7] = 1.0
    assert_close(softargmax(logits), torch.tensor([[5.0, 4.0]]))
    assert_close(expected_position(torch.softmax(logits.flatten(-2), -1).view_as(logits)), softargmax(logits))


def test_sample_positions_respects_threshold_and_generator():
    prob = torch.zeros(2, 8, 8)
    prob[0, 1, 2], prob[0, 5, 6], prob[0, 7, 7] = 1.0, 1.0, 0.01
    prob[1, 3, 4] = 1.0
    a = sample_positions(prob, 500, gen(1), rel_threshold=0.05)
    assert a.shape == (2, 500, 2)
    assert set(map(tuple, a[0].tolist())) == {(2.0, 1.0), (6.0, 5.0)}  # (x, y); the 0.01 pixel is cut
    assert set(map(tuple, a[1].tolist())) == {(4.0, 3.0)}
    assert torch.equal(a, sample_positions(prob, 500, gen(1), rel_threshold=0.05))


def test_kmeans_converges_to_lloyd_fixed_points_and_finds_separated_clusters():
    g = gen(0)
    true = torch.tensor([[[0.0, 0.0], [20.0, 0.0], [0.0, 30.0]], [[5.0, 5.0], [-40.0, 10.0], [60.0, 60.0]]])
    points = (true[:, :, None] + torch.randn(2, 3, 200, 2, generator=g)).flatten(1, 2)  # (2, 600, 2)
    found = torch.zeros(2, dtype=torch.bool)
    for seed in range(5):  # random init (like the authors' k-means) can end in a local optimum
        centres = kmeans(points, 3, gen(seed), tol=1e-8)
        for b in range(2):
            owner = torch.cdist(points[b], centres[b]).argmin(1)
            for c in range(3):  # every centre is the mean of the points it owns
                assert_close(points[b][owner == c].mean(0), centres[b, c], atol=1e-3, rtol=0)
            found[b] |= torch.cdist(true[b], centres[b]).min(1).values.max() < 0.5
    assert found.all()


def plain_kmeans(points, k, generator, max_iter=1000, tol=1e-3):
    """Lloyd's k-means over every point (duplicates included) on squared distances, as
    kmeans_pytorch: the algorithm `kmeans` must equal."""
    n, p, _ = points.shape
    first = torch.rand(n, p, generator=generator).argsort(dim=-1)[:, :k]
    centres = torch.gather(points, 1, first[..., None].expand(n, k, 2))
    active = torch.ones(n, dtype=torch.bool)
    for _ in range(max_iter):
        owner = (points[:, :, None] - centres[:, None]).square().sum(-1).argmin(-1)  # (N, P)
        new = torch.stack([torch.stack([points[b][owner[b] == c].mean(0) if (owner[b] == c).any()
                                        else torch.full((2,), float("nan")) for c in range(k)])
                           for b in range(n)])
        empty = new.isnan().any(-1)
        if empty.any():
            restart = torch.randint(p, (n, k), generator=generator)
            restart = torch.gather(points, 1, restart[..., None].expand(n, k, 2))
            new = torch.where(empty[..., None], restart, new)
        shift = (new - centres).square().sum(-1).sqrt().sum(-1)
        centres = torch.where(active[:, None, None], new, centres)
        active &= shift.square() >= tol
        if not active.any():
            break
    return centres


def test_kmeans_on_distinct_weighted_points_equals_the_plain_algorithm():
    prob = torch.rand(3, 24, 20) ** 8  # peaky maps: many repeated pixels, as TTST draws them
    prob[2, 5:] = 0.0  # one set with few distinct pixels
    points = sample_positions(prob, 2000, gen(3), rel_threshold=0.01)  # (3, 2000, 2)
    for k in (4, 19):
        assert torch.equal(kmeans(points, k, gen(k)), plain_kmeans(points, k, gen(k)))


def test_distinct_points_counts_each_sets_points_including_fractions_and_negatives():
    points = torch.tensor([[[1.0, 2.0], [1.0, 2.0], [-3.5, 0.25], [1.0, 2.0]],
                           [[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]]])  # (2, 4, 2)
    unique, weights = distinct_points(points)
    assert unique.shape == (2, 2, 2) and weights.shape == (2, 2)
    for b in range(2):  # the same multiset as a per-set torch.unique
        found = {tuple(u): w for u, w in zip(unique[b].tolist(), weights[b].tolist()) if w > 0}
        rows, counts = torch.unique(points[b], dim=0, return_counts=True)
        assert found == {tuple(r): float(c) for r, c in zip(rows.tolist(), counts.tolist())}
    assert weights[1, 1] == 0 and unique[1, 1].tolist() == [0.0, 0.0]  # padding: the first point


def test_kmeans_restarts_empty_clusters():
    points = torch.tensor([[[0.0, 0.0]] * 50 + [[10.0, 10.0]] * 50])  # two distinct points only
    centres = kmeans(points, 4, gen(0))
    assert centres.shape == (1, 4, 2)
    assert {tuple(c) for c in centres[0].tolist()} == {(0.0, 0.0), (10.0, 10.0)}


def test_ttst_distinct_goals_first_is_softargmax():
    logits = torch.stack([two_mode_logits(), two_mode_logits().flip(-1)])  # (2, H, W)
    options = SamplingOptions(K_e=5, temperature=1.0, rel_threshold=0.01)
    goals = ttst_goals(logits, options, gen(0))
    assert goals.shape == (2, 5, 2)
    assert_close(goals[:, 0], softargmax(logits))
    for b in range(2):
        d = torch.cdist(goals[b], goals[b]) + torch.eye(5) * 1e9
        assert d.min() > 0.5  # all K_e goals distinct
    # cluster centres lie on the two modes
    near = torch.cdist(goals[0, 1:], torch.tensor([[12.0, 10.0], [50.0, 36.0]])).min(1).values
    assert near.max() < 8.0
    assert torch.equal(goals, ttst_goals(logits, options, gen(0)))


def covariance(prob):
    h, w = prob.shape[-2:]
    ys, xs = torch.meshgrid(torch.arange(h, dtype=prob.dtype), torch.arange(w, dtype=prob.dtype), indexing="ij")
    mean = expected_position(prob)
    v = torch.stack([xs - mean[0], ys - mean[1]], -1)  # (H, W, 2)
    return mean, torch.einsum("hw,hwi,hwj->ij", prob, v, v)


# Travel direction, and the prior's covariance written out by hand for a variance `along` the
# travel and `across` it (on the diagonal: u = (1, 1) / sqrt 2, so cov = along u u^T + across v v^T).
CWS_CASES = {
    "along x": ((1.0, 0.0), lambda along, across: [[along, 0.0], [0.0, across]]),
    "along y": ((0.0, 1.0), lambda along, across: [[across, 0.0], [0.0, along]]),
    "diagonal": ((1.0, 1.0), lambda along, across: [[(along + across) / 2, (along - across) / 2],
                                                     [(along - across) / 2, (along + across) / 2]]),
}


@pytest.mark.parametrize("case", sorted(CWS_CASES))
@pytest.mark.parametrize("rot", [True, False])
def test_cws_prior_covariance_matches_the_authors_orientation(case, rot):
    """rot=True: narrow along the direction of travel (sigma / ratio), wide across (sigma), as the
    authors' SDD config and the paper's text; rot=False: still aligned, the widths swapped."""
    direction, written_out = CWS_CASES[case]
    h = w = 200
    last = torch.tensor([[100.0, 100.0]])
    unit = torch.tensor(direction) / torch.tensor(direction).norm()
    goal = (last + 60 * unit)[:, None]  # (1, 1, 2): 60 px of travel
    sigma_factor, ratio = 6.0, 2.0
    sigma = (60 + 5) / sigma_factor
    prior = cws_prior(last, goal, 0.5, sigma_factor, ratio, rot, h, w)[0, 0]  # (H, W)
    assert_close(prior.sum(), torch.tensor(1.0))
    mean, cov = covariance(prior.double())
    assert_close(mean.float(), (last[0] + goal[0, 0]) / 2, atol=1e-3, rtol=0)
    narrow, wide = (sigma / ratio) ** 2, sigma**2
    along, across = (narrow, wide) if rot else (wide, narrow)
    expected = torch.tensor(written_out(along, across), dtype=torch.float64)
    # pixel sampling of a continuous Gaussian adds 1/12 px^2 of variance on each axis
    assert_close(cov, expected + torch.eye(2, dtype=torch.float64) / 12, atol=0.05, rtol=1e-2)


def test_cws_flat_waypoint_maps_give_the_prior_means():
    """With uninformative waypoint maps, path 0 puts each waypoint at its prior's centre: 1/3 and then
    1/2 of the way back to the agent for two intermediate waypoints."""
    h = w = 200
    logits = torch.zeros(1, 3, h, w)
    last = torch.tensor([[100.0, 100.0]])
    goals = torch.tensor([[[160.0, 40.0], [40.0, 130.0]]])  # (1, K=2, 2)
    options = SamplingOptions(K_e=2, K_a=1, temperature=1.0)
    wp = cws_waypoints(logits, goals, last, options, gen(0))  # (1, 2, 3, 2)
    assert_close(wp[:, :, 2], goals)
    second = goals + (last[:, None] - goals) / 3
    assert_close(wp[:, :, 1], second, atol=1e-3, rtol=0)
    assert_close(wp[:, :, 0], second + (last[:, None] - second) / 2, atol=1e-3, rtol=0)


def test_goals_without_ttst_are_distinct_pixels_ignoring_the_threshold():
    """Without TTST the authors draw K_e goals without replacement and with no relative threshold:
    on a map with 3 dominant pixels, 8 goals are 8 different pixels, 5 of them below threshold."""
    logits = torch.full((1, 1, 16, 16), -20.0)
    logits[0, 0, [2, 8, 12], [3, 9, 5]] = 20.0
    options = SamplingOptions(K_e=8, K_a=1, use_ttst=False, use_cws=False, temperature=1.0,
                              rel_threshold=0.5)
    goals = sample_waypoints(logits, torch.zeros(1, 2), options, gen(0))[0, :, -1]  # (8, 2)
    assert len(torch.unique(goals, dim=0)) == 8
    dominant = {(3.0, 2.0), (9.0, 8.0), (5.0, 12.0)}
    assert dominant <= {tuple(g.tolist()) for g in goals}


@pytest.mark.parametrize(
    "use_ttst,use_cws,K_a", [(True, True, 1), (True, True, 3), (False, True, 2), (True, False, 2), (False, False, 1)]
)
def test_sample_waypoints_shapes_and_order(use_ttst, use_cws, K_a):
    logits = two_mode_logits()[None, None].repeat(2, 3, 1, 1)  # (B=2, n_w=3, H, W)
    last = torch.tensor([[30.0, 20.0], [10.0, 40.0]])
    options = SamplingOptions(
        K_e=4, K_a=K_a, use_ttst=use_ttst, use_cws=use_cws, temperature=1.0, rel_threshold=0.01
    )
    wp = sample_waypoints(logits, last, options, gen(0))
    assert wp.shape == (2, 4 * K_a, 3, 2)
    # path-major: every path repeats the same K_e goals
    for a in range(K_a):
        assert torch.equal(wp[:, a * 4 : (a + 1) * 4, -1], wp[:, :4, -1])
    assert ((wp >= 0) & (wp[..., 0] <= 63)[..., None] & (wp[..., 1] <= 47)[..., None]).all()
    if use_ttst:
        assert_close(wp[:, 0, -1], softargmax(logits[:, -1]))
    assert torch.equal(wp, sample_waypoints(logits, last, options, gen(0)))


def test_options_checks():
    with pytest.raises(ValueError):
        SamplingOptions(K_e=0, temperature=1.8)
    with pytest.raises(ValueError, match="sigma_factor"):
        SamplingOptions(K_a=7, sigma_factor=6.0, temperature=1.8)
    with pytest.raises(TypeError, match="temperature"):
        SamplingOptions(K_e=20)  # no default: the pipeline's is params.yaml's ttst.temperature
    assert SamplingOptions(K_e=20, K_a=5, temperature=1.8).K == 100


def tiny_model_and_windows(b: int) -> tuple[YNet, torch.Tensor, torch.Tensor]:
    """A randomly initialised tiny Y-net (seed 0), `b` random pasts (b, obs_len, 2) on a 40 x 48 map
    and their inputs (b, C + obs_len, 40, 48)."""
    torch.manual_seed(0)
    model = YNet(CFG)
    h, w = 40, 48
    past = torch.rand(b, CFG.obs_len, 2) * torch.tensor([w - 1.0, h - 1.0])
    x = scene_and_past(torch.softmax(torch.randn(b, CFG.semantic_classes, h, w), 1), past, 60.0)
    return model, past, x


@pytest.mark.parametrize("bf16", [False, True])
def test_predict_shapes_and_determinism(bf16):
    model, past, x = tiny_model_and_windows(2)
    options = SamplingOptions(K_e=5, K_a=2, temperature=1.0, rel_threshold=0.01)
    runs = [predict(model, x, past[:, -1], options, gen(7), 60.0, chunk_size=3, bf16=bf16) for _ in range(2)]
    p = runs[0]
    assert p.trajectory.shape == (2, 10, CFG.pred_len, 2)
    assert p.goals.shape == (2, 10, 2) and p.waypoints.shape == (2, 10, CFG.n_waypoints, 2)
    assert torch.equal(p.goals, p.waypoints[:, :, -1])
    for field in ("trajectory", "goals", "waypoints"):
        assert torch.equal(getattr(runs[0], field), getattr(runs[1], field))  # bit-identical
    other = predict(model, x, past[:, -1], options, gen(8), 60.0, chunk_size=3, bf16=bf16)
    assert not torch.equal(other.waypoints, p.waypoints)
    # chunking does not change the result
    whole = predict(model, x, past[:, -1], options, gen(7), 60.0, chunk_size=10, bf16=bf16)
    assert_close(whole.trajectory, p.trajectory, rtol=1e-4, atol=1e-3 if bf16 else 1e-4)


def test_predict_bf16_changes_only_the_trajectory_decoder():
    model, past, x = tiny_model_and_windows(1)
    options = SamplingOptions(K_e=4, K_a=2, temperature=1.0, rel_threshold=0.01)
    fp32 = predict(model, x, past[:, -1], options, gen(3), 60.0)
    bf16 = predict(model, x, past[:, -1], options, gen(3), 60.0, bf16=True)
    assert torch.equal(fp32.waypoints, bf16.waypoints)
    assert_close(bf16.trajectory, fp32.trajectory, rtol=0, atol=0.5)


def test_goal_masses_are_the_share_of_draws_nearest_each_goal():
    # window 0: 3 draws at (0, 0), one at (9, 0); goals (1, 0) and (8, 0) -> 3/4 and 1/4
    # window 1: a tie at (5, 0) between goals (4, 0) and (6, 0) goes to the first goal
    draws = torch.tensor([[[0.0, 0.0], [0.0, 0.0], [9.0, 0.0], [0.0, 0.0]],
                          [[5.0, 0.0], [7.0, 0.0], [7.0, 0.0], [6.0, 0.0]]])  # (2, 4, 2)
    goals = torch.tensor([[[1.0, 0.0], [8.0, 0.0]], [[4.0, 0.0], [6.0, 0.0]]])  # (2, 2, 2)
    assert goal_masses(draws, goals).tolist() == [[0.75, 0.25], [0.25, 0.75]]


def test_ttst_masses_sum_to_one_and_favour_the_heavier_mode():
    logits = two_mode_logits()[None]  # (1, H, W)
    options = SamplingOptions(K_e=5, temperature=1.0, rel_threshold=0.01)
    goals, masses = ttst(logits, options, gen(0))
    assert torch.equal(goals, ttst_goals(logits, options, gen(0)))  # the same draws
    assert masses.shape == (1, 5) and (masses >= 0).all()
    assert_close(masses.sum(-1), torch.ones(1))
    single, mass = ttst(logits, SamplingOptions(K_e=1, temperature=1.8), gen(0))
    assert single.shape == (1, 1, 2) and mass.tolist() == [[1.0]]


def test_predict_weights_split_each_goal_mass_among_its_paths():
    model, past, x = tiny_model_and_windows(2)
    options = SamplingOptions(K_e=4, K_a=3, temperature=1.0, rel_threshold=0.01)
    p = predict(model, x, past[:, -1], options, gen(2), 60.0)
    assert p.weights.shape == (2, 12)
    assert_close(p.weights.sum(-1), torch.ones(2))
    by_path = p.weights.view(2, 3, 4)  # path-major: sample k is goal k % K_e, path k // K_e
    assert torch.equal(by_path, by_path[:, :1].expand(2, 3, 4))
    plain = SamplingOptions(K_e=4, K_a=1, temperature=1.0, use_ttst=False, use_cws=False)
    assert predict(model, x, past[:, -1], plain, gen(2), 60.0).weights is None


def test_nearest_centre_is_the_first_centre_at_the_least_squared_distance():
    points = torch.tensor([[[0.0, 0.0], [2.0, 0.0], [5.0, 5.0]]])  # (1, 3, 2)
    centres = torch.tensor([[[1.0, 0.0], [0.0, 1.0], [3.0, 0.0], [5.0, 4.0]]])  # (1, 4, 2)
    # (0, 0) is 1 from the first two centres (first wins); (2, 0) is 1 from centres 0 and 2.
    assert nearest_centre(points, centres).tolist() == [[0, 0, 3]]
    draws = torch.Generator().manual_seed(3)
    points = torch.randint(0, 6, (3, 50, 2), generator=draws).float()  # many exact ties
    centres = torch.randint(0, 6, (3, 7, 2), generator=draws).float()
    squared = (points[:, :, None] - centres[:, None]).square().sum(-1)  # (N, U, k)
    assert torch.equal(nearest_centre(points, centres), squared.argmin(-1))
    points = torch.rand(2, 300, 2, generator=draws) * 90  # non-integer points
    centres = torch.rand(2, 19, 2, generator=draws) * 90
    squared = (points[:, :, None] - centres[:, None]).square().sum(-1)
    assert torch.equal(nearest_centre(points, centres), squared.argmin(-1))


def test_kmeans_and_goal_masses_take_the_distinct_points_they_would_compute():
    """TTST computes `distinct_points` of its draws once for both: the same numbers as each
    computing its own."""
    draws = torch.randint(0, 12, (3, 400, 2), generator=gen(5)).float()  # (3, 400, 2) with repeats
    distinct = distinct_points(draws)
    assert torch.equal(kmeans(draws, 4, gen(1), distinct=distinct), kmeans(draws, 4, gen(1)))
    goals = kmeans(draws, 4, gen(1))
    assert torch.equal(goal_masses(draws, goals, distinct), goal_masses(draws, goals))
