"""From heatmaps to positions: softargmax, the Test-Time Sampling Trick (TTST), Conditioned Waypoint
Sampling (CWS), and `predict`, which runs the whole inference for a batch of windows.

Positions are `(x, y)` in pixels of the padded map (x = column, y = row; see `ynet.heatmaps`).
Randomness only comes from the `torch.Generator` passed in: same generator state, same inputs, same
thread count -> bit-identical results. The K = K_e * K_a samples of a window are ordered path-major:
sample `k` is goal `k % K_e` with aleatoric path `k // K_e` (as the authors order them).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch
import torch.nn.functional as F

from ynet.heatmaps import distance_maps
from ynet.model import YNet


@dataclass(frozen=True)
class SamplingOptions:
    """How `predict` draws goals and waypoints. Defaults: the authors' long-term SDD config; the
    temperature has none (the pipeline's is params.yaml `ttst.temperature`): give it by name."""

    K_e: int = 20
    """Goals per window (epistemic samples)."""
    K_a: int = 1
    """Paths per goal (aleatoric samples): sets of waypoints drawn for each goal."""
    temperature: float = field(kw_only=True)
    """Goal/waypoint maps are sigmoid(logits / temperature) before sampling; higher = more diverse."""
    rel_threshold: float = 0.002
    """TTST never samples goal pixels below rel_threshold * max (outlier suppression)."""
    use_ttst: bool = True
    """TTST: k-means over many samples. False: the K_e goals are plain draws from the goal map."""
    use_cws: bool = True
    """CWS: waypoints conditioned on the goal. False: each waypoint drawn from its map independently."""
    sigma_factor: float = 6.0
    """CWS prior width: sigma = (distance + 5) / sigma_factor across the direction of travel."""
    ratio: float = 2.0
    """CWS prior: sigma along the direction of travel is sigma / ratio (with `rot`)."""
    rot: bool = True
    """True (the authors' SDD config): the prior is narrow along the direction of travel (sigma /
    ratio) and wide across it (sigma). False: the authors' code still aligns the prior with the
    travel, the other way round: wide along it (sigma), narrow across (sigma / ratio)."""
    ttst_samples: int = 10_000
    """Points drawn from the goal map for TTST's k-means."""
    kmeans_max_iter: int = 1000
    kmeans_tol: float = 1e-3
    """k-means stops when (sum of the centres' moves)^2 < tol, as kmeans_pytorch does."""
    cws_rel_threshold: float = 0.05
    """Paths after the first draw waypoints from pixels above this fraction of the map's maximum."""

    def __post_init__(self):
        if self.K_e < 1 or self.K_a < 1:
            raise ValueError("K_e and K_a must be at least 1")
        if self.temperature <= 0:
            raise ValueError("temperature must be positive")
        if not (0 <= self.rel_threshold < 1 and 0 <= self.cws_rel_threshold < 1):
            raise ValueError("relative thresholds must lie in [0, 1)")
        if self.use_ttst and self.ttst_samples < self.K_e:
            raise ValueError("ttst_samples must be at least K_e")
        if self.use_cws and self.sigma_factor - (self.K_a - 1) <= 0:
            # path a uses sigma_factor - a
            raise ValueError(f"CWS needs sigma_factor > K_a - 1, got {self.sigma_factor} and {self.K_a}")

    @property
    def K(self) -> int:
        return self.K_e * self.K_a


@dataclass(frozen=True)
class Prediction:
    """`predict`'s output, in map pixels. ADE uses `trajectory`; FDE uses `goals` (the sampled goal,
    not the trajectory decoder's last step), as the authors do."""

    trajectory: torch.Tensor  # (B, K, n_f, 2) softargmax of every trajectory heatmap
    goals: torch.Tensor  # (B, K, 2) the sampled goal of each sample
    waypoints: torch.Tensor  # (B, K, n_w, 2) the sampled waypoints, goal last
    weights: torch.Tensor | None = None
    """(B, K) each sample's share of its window, summing to 1: with TTST the `goal_masses` of its
    goal split evenly among the goal's K_a paths; None without TTST (plain draws carry no mass)."""


def _coords(height: int, width: int, like: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    ys = torch.arange(height, dtype=like.dtype, device=like.device)
    xs = torch.arange(width, dtype=like.dtype, device=like.device)
    return ys, xs


def expected_position(prob: torch.Tensor) -> torch.Tensor:
    """Mean position of maps that already sum to 1: (..., H, W) -> (..., 2) as (x, y)."""
    ys, xs = _coords(prob.shape[-2], prob.shape[-1], prob)
    x = (prob.sum(-2) * xs).sum(-1)  # (...)
    y = (prob.sum(-1) * ys).sum(-1)
    return torch.stack([x, y], dim=-1)


def softargmax(logits: torch.Tensor) -> torch.Tensor:
    """The paper's robust argmax: the mean position under a spatial softmax of each map.

    logits (..., H, W) -> (..., 2) as (x, y).
    """
    prob = torch.softmax(logits.flatten(-2), dim=-1).view_as(logits)  # (..., H, W)
    return expected_position(prob)


def sample_positions(
    prob: torch.Tensor,
    num_samples: int,
    generator: torch.Generator,
    rel_threshold: float | None = None,
    replacement: bool = True,
) -> torch.Tensor:
    """Pixels drawn from non-negative maps: (..., H, W) -> (..., num_samples, 2).

    Positions are pixel centres (whole numbers). `rel_threshold` zeroes pixels below that fraction
    of each map's maximum first. `replacement=False` draws `num_samples` distinct pixels.
    """
    height, width = prob.shape[-2:]
    flat = prob.reshape(-1, height * width)  # (N, H*W)
    if rel_threshold:
        keep = flat >= flat.amax(-1, keepdim=True) * rel_threshold
        flat = torch.where(keep, flat, torch.zeros_like(flat))
    idx = torch.multinomial(flat, num_samples, replacement=replacement, generator=generator)  # (N, S)
    xy = torch.stack([idx % width, torch.div(idx, width, rounding_mode="floor")], dim=-1)
    return xy.to(prob.dtype).reshape(*prob.shape[:-2], num_samples, 2)


def sorted_runs(points: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Each set's points in (x, y) order and where each run of equal points starts: (N, P, 2) ->
    (N, P, 2), (N, P) bool. Two stable sorts (much faster than a `torch.unique(dim=0)` over
    (set, x, y) rows, which gives the same order)."""
    n, p, _ = points.shape
    order = points[..., 1].argsort(dim=-1, stable=True)  # (N, P) by y ...
    order = order.gather(1, points[..., 0].gather(1, order).argsort(dim=-1, stable=True))  # ... then x
    ordered = points.gather(1, order[..., None].expand(n, p, 2))  # (N, P, 2) sorted by (x, y)
    first = torch.ones(n, p, dtype=torch.bool, device=points.device)  # (N, P) starts a new point
    first[:, 1:] = (ordered[:, 1:] != ordered[:, :-1]).any(-1)
    return ordered, first


def distinct_points(points: torch.Tensor, size: int | None = None
                    ) -> tuple[torch.Tensor, torch.Tensor]:
    """Each set's distinct points and how often each occurs: (N, P, 2) -> (N, U, 2), (N, U).

    Distinct points come in (x, y) order (`sorted_runs`); sets with fewer than U distinct points
    are padded with weight-0 copies of their first point.
    U is the most distinct points of any set, read on the host (a sync on a GPU); `size` (at
    least that, P always is) fixes U instead, so nothing waits for the device.
    """
    n, p, _ = points.shape
    ordered, first = sorted_runs(points)  # (N, P, 2), (N, P)
    slot = first.cumsum(1) - 1  # (N, P) index of each sorted point among its set's distinct ones
    size = int(slot[:, -1].max()) + 1 if size is None else size  # U
    unique = points[:, :1].repeat(1, size, 1)  # (N, U, 2)
    unique.scatter_(1, slot[..., None].expand(n, p, 2), ordered)  # equal points write equal values
    weights = points.new_zeros(unique.shape[:2]).scatter_add_(1, slot, points.new_ones(n, p))
    return unique, weights


def nearest_centre(points: torch.Tensor, centres: torch.Tensor) -> torch.Tensor:
    """Index of each point's nearest centre, the first on ties: (N, U, 2), (N, k, 2) -> (N, U).

    Compares squared distances, as kmeans_pytorch's `pairwise_distance` does (no square root,
    which could round two different distances to a tie). An argmin over a short last axis (k of
    about 20) is slow on a CPU, so this takes the minimum along the centre axis of (N, k, U), which
    vectorises, and picks the first centre that attains it (in-place ops on contiguous float
    tensors: a bool mask would cost more than the distances).
    """
    k = centres.shape[1]
    px, py = (c.contiguous() for c in points.unbind(-1))  # (N, U) each
    cx, cy = (c.contiguous() for c in centres.unbind(-1))  # (N, k) each
    squared = (px[:, None] - cx[..., None]).square_()  # (N, k, U)
    squared.add_((py[:, None] - cy[..., None]).square_())
    is_nearest = squared.eq_(squared.amin(1, keepdim=True))  # 1.0 where a centre attains the min
    rank_from_last = torch.arange(k, 0, -1, dtype=squared.dtype, device=squared.device)[:, None]
    return k - is_nearest.mul_(rank_from_last).amax(1).long()  # the first centre at the minimum


def cluster_means(unique: torch.Tensor, weights: torch.Tensor, weighted: torch.Tensor,
                  centres: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """One Lloyd step over weighted points (N, U, 2), weights (N, U), their product (N, U, 2) and
    centres (N, k, 2): the weighted mean of each centre's points (N, k, 2), 0 for an empty
    cluster, and which clusters are empty (N, k)."""
    n, k, _ = centres.shape
    nearest = nearest_centre(unique, centres)  # (N, U)
    counts = centres.new_zeros(n, k).scatter_add_(1, nearest, weights)  # (N, k)
    sums = centres.new_zeros(n, k, 2).scatter_add_(1, nearest[..., None].expand(n, -1, 2), weighted)
    return sums / counts.clamp_min(1)[..., None], counts == 0


def point_counts(points: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Each set's points in (x, y) order, each distinct one counted once: (N, P, 2) -> (N, P, 2),
    (N, P), the count at a point's first copy and 0 at its other copies.

    `distinct_points` at a fixed size without its scatters (on a GPU whose deterministic mode is
    on, `scatter_` and `scatter_add_` take a slow sort-based path): the count of a run of equal
    points is where the run ends minus where it starts, found by a binary search of the run
    numbers. Weight-0 copies change no k-means centre and no goal mass.
    """
    n, p, _ = points.shape
    ordered, first = sorted_runs(points)  # (N, P, 2), (N, P)
    run = first.cumsum(1)  # (N, P) non-decreasing: the run each sorted point belongs to
    end = torch.searchsorted(run, run, right=True)  # (N, P) one past the run's last point
    start = torch.arange(p, device=points.device)  # a run's first point is where it starts
    return ordered, torch.where(first, end - start, 0).to(points.dtype)


def nearest_one_hot(rows: torch.Tensor, centres: torch.Tensor, clusters: torch.Tensor,
                    out: torch.Tensor) -> torch.Tensor:
    """Which centre each point is nearest to (the first on ties), one-hot, written into `out`
    (N, k, U) of any dtype: points as rows (N, 1, U, 2), centres (N, k, 2) and `clusters`
    arange(k)[:, None] (k, 1), shaped once by a caller that loops. The squared distances are
    `nearest_centre`'s, (px - cx)^2 + (py - cy)^2 in float32, and so is the assignment."""
    squared = (rows - centres.unsqueeze(2)).square_().sum(-1)  # (N, k, U)
    return torch.eq(squared.argmin(1, keepdim=True), clusters, out=out)


def nearest_sums(points: torch.Tensor, centres: torch.Tensor, masses: torch.Tensor) -> torch.Tensor:
    """For each centre, the sum of `masses` over the points nearest to it (`nearest_one_hot`):
    points (N, U, 2), centres (N, k, 2), masses (N, U, m) float64 -> (N, k, m) float64.

    A one-hot assignment times the masses: a matrix product, deterministic and fast on a GPU,
    where a `scatter_add_` is deterministic only through a sort. float64 (which no TF32 setting
    touches) keeps sums of whole numbers below 2^53 exact, so they equal a float32
    `scatter_add_`'s wherever that one is exact (sums below 2^24).
    """
    (n, k, _), u = centres.shape, points.shape[1]
    clusters = torch.arange(k, device=points.device)[:, None]  # (k, 1)
    one_hot = masses.new_empty(n, k, u)  # (N, k, U)
    return torch.bmm(nearest_one_hot(points.unsqueeze(1), centres, clusters, one_hot), masses)


def random_points(points: torch.Tensor, k: int, generator: torch.Generator) -> torch.Tensor:
    """k points of each set drawn uniformly, with replacement: (N, P, 2) -> (N, k, 2)."""
    n, p, _ = points.shape
    index = torch.randint(p, (n, k), generator=generator, device=points.device)  # (N, k)
    return torch.gather(points, 1, index[..., None].expand(n, k, 2))


def kmeans(
    points: torch.Tensor,
    k: int,
    generator: torch.Generator,
    max_iter: int = 1000,
    tol: float = 1e-3,
    distinct: tuple[torch.Tensor, torch.Tensor] | None = None,
    check_every: int | None = None,
) -> torch.Tensor:
    """Lloyd's k-means on many point sets at once: (N, P, 2) -> centres (N, k, 2).

    Like kmeans_pytorch (the authors' choice): initial centres are k distinct random points of each
    set; a cluster that empties restarts at a random point; a set stops updating once the squared sum
    of its centres' moves drops below `tol`.

    TTST's points are pixels drawn with replacement, so a set of 10,000 holds a few thousand distinct
    ones: the iterations run on those, weighted by their counts, and sum each cluster with
    `scatter_add` (no (N, U, k) one-hot). Random draws still index the full sets, so the centres are
    the ones the plain algorithm finds (bit-identical for whole-number points, whose sums are exact
    in float32 in any order). `distinct`: `distinct_points(points)`, where the caller has it already
    (weight-0 padding points change nothing).

    `check_every` None: the host reads, every iteration, whether a cluster emptied (restart points
    are drawn only then) and whether every set has stopped, and `distinct_points` reads its size:
    about two host syncs per iteration, which on a GPU cost far more than the iteration's small
    kernels. `check_every` n: the sync-light mode for GPUs (`sync_light_lloyd`).
    """
    if check_every is not None and check_every < 1:
        raise ValueError(f"check_every must be at least 1, got {check_every}")
    n, p, _ = points.shape
    first = torch.rand(n, p, generator=generator, device=points.device).argsort(dim=-1)[:, :k]  # (N, k)
    centres = torch.gather(points, 1, first[..., None].expand(n, k, 2))  # (N, k, 2)
    if check_every is not None:
        unique, weights = point_counts(points) if distinct is None else distinct
        return sync_light_lloyd(points, unique, weights, centres, generator, max_iter, tol,
                                check_every)
    if distinct is None:
        distinct = distinct_points(points)
    unique, weights = distinct  # (N, U, 2), (N, U)
    weighted = unique * weights[..., None]  # (N, U, 2)
    active = torch.ones(n, dtype=torch.bool, device=points.device)
    for _ in range(max_iter):
        new, empty = cluster_means(unique, weights, weighted, centres)  # (N, k, 2), (N, k)
        if empty.any():
            new = torch.where(empty[..., None], random_points(points, k, generator), new)
        shift = (new - centres).square().sum(-1).sqrt().sum(-1)  # (N,)
        centres = torch.where(active[:, None, None], new, centres)
        active &= shift.square() >= tol
        if not active.any():
            break
    return centres


def sync_light_lloyd(points: torch.Tensor, unique: torch.Tensor, weights: torch.Tensor,
                     centres: torch.Tensor, generator: torch.Generator, max_iter: int, tol: float,
                     check_every: int) -> torch.Tensor:
    """`kmeans`' iterations for GPUs: fixed shapes, no host read but one every `check_every`
    iterations, no scatter. points (N, P, 2), weighted points (N, U, 2) and (N, U) (`point_counts`
    or `distinct_points`), initial centres (N, k, 2) -> centres (N, k, 2).

    The iterations run in blocks of `check_every`. A block draws, in one go, a restart point for
    every cluster and iteration, taken only where a cluster empties (no host branch: the draws, and
    so the generator's stream, differ from the default mode's, but repeat with the seed). Clusters
    are summed by `nearest_sums` (a one-hot matrix product). Every set iterates to the block's end;
    then the moves of each iteration are compared with `tol` all at once and each set keeps the
    centres of the first iteration whose move fell below it, frozen from then on: the default
    mode's stop, found after the fact. The host reads only whether every set has stopped, once a
    block. So where no cluster ever empties (and sums stay below 2^24) the centres equal the
    default mode's, bit for bit.
    """
    n, k, _ = centres.shape
    masses = torch.cat([unique * weights[..., None], weights[..., None]], dim=-1).double()  # (N, U, 3)
    rows = unique.unsqueeze(1)  # (N, 1, U, 2)
    clusters = torch.arange(k, device=points.device)[:, None]  # (k, 1)
    one_hot = masses.new_empty(n, k, unique.shape[1])  # (N, k, U), rewritten every iteration
    means = centres.new_empty(n, k, 2)  # (N, k, 2), likewise
    stopped = torch.zeros(n, dtype=torch.bool, device=points.device)  # (N,) frozen for good
    for start in range(0, max_iter, check_every):
        steps = min(check_every, max_iter - start)
        restarts = random_points(points, steps * k, generator).unflatten(1, (steps, k))  # (N, T, k, 2)
        trail = [centres]  # the centres before the block, then after each iteration
        for restart in restarts.unbind(1):  # (N, k, 2) each
            # (N, k, 3): each cluster's sums of x and y and its count (`nearest_sums`)
            summed = torch.bmm(nearest_one_hot(rows, trail[-1], clusters, one_hot), masses)
            sums, counts = summed.split([2, 1], dim=-1)  # (N, k, 2), (N, k, 1)
            # divided in float64, rounded once to float32: float32's own division of the same
            # whole numbers (float64 has room for float32's rounding)
            torch.div(sums, counts, out=means)
            trail.append(torch.where(counts == 0, restart, means))  # (N, k, 2)
        moves = torch.stack(trail, 1).diff(dim=1)  # (N, T, k, 2)
        settled = moves.square().sum(-1).sqrt().sum(-1).square() < tol  # (N, T)
        # each set's first settled iteration, or the block's last: the centres it ends the block with
        last = torch.cat([settled[:, :-1], settled.new_ones(n, 1)], 1).int().argmax(1)  # (N,)
        reached = torch.stack(trail[1:], 1).gather(1, last[:, None, None, None].expand(n, 1, k, 2))
        centres = torch.where(stopped[:, None, None], centres, reached[:, 0])
        stopped |= settled.any(1)
        if start + steps < max_iter and bool(stopped.all()):
            break
    return centres


def goal_masses(draws: torch.Tensor, goals: torch.Tensor,
                distinct: tuple[torch.Tensor, torch.Tensor] | None = None,
                sync_light: bool = False) -> torch.Tensor:
    """TTST's weight of each goal: the share of the goal-map draws (B, S, 2) nearest to it among
    the goals (B, K_e, 2) -> (B, K_e), rows summing to 1 (the first goal on ties). The softargmax
    goal competes with the k-means centres, so each goal weighs the part of the map it stands for.
    `distinct`: `distinct_points(draws)` (or `point_counts`), where the caller has it already.
    `sync_light`: summed by `nearest_sums` (no scatter; the same numbers, the counts being whole)."""
    if sync_light:
        unique, counts = point_counts(draws) if distinct is None else distinct  # (B, S, 2), (B, S)
        masses = nearest_sums(unique, goals, counts[..., None].double())[..., 0].to(counts.dtype)
        return masses / draws.shape[1]
    unique, counts = distinct_points(draws) if distinct is None else distinct  # (B, U, 2), (B, U)
    nearest = nearest_centre(unique, goals)  # (B, U)
    masses = counts.new_zeros(goals.shape[:2]).scatter_add_(1, nearest, counts)  # (B, K_e)
    return masses / draws.shape[1]


def ttst(
    goal_logits: torch.Tensor, options: SamplingOptions, generator: torch.Generator,
    check_every: int | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """TTST: K_e goals per window from goal logits (B, H, W) -> goals (B, K_e, 2) and their
    `goal_masses` (B, K_e).

    Goal 0 is the softargmax of the raw logits; the other K_e - 1 are k-means centres of
    `ttst_samples` draws from sigmoid(logits / T), pixels below rel_threshold * max suppressed.
    Clustering many draws spreads the few goals over the modes instead of wasting them nearby.
    `check_every`: `kmeans`' (an int: its sync-light mode for GPUs, which counts the draws with
    `point_counts` and weighs the goals by `nearest_sums`: fixed shapes, no scatter).
    """
    best = softargmax(goal_logits)[:, None]  # (B, 1, 2)
    if options.K_e == 1:
        return best, torch.ones_like(best[..., 0])
    prob = torch.sigmoid(goal_logits / options.temperature)  # (B, H, W)
    draws = sample_positions(prob, options.ttst_samples, generator, options.rel_threshold)  # (B, S, 2)
    sync_light = check_every is not None
    # (B, U, 2), (B, U): for the k-means and the masses (U = S in the sync-light mode)
    distinct = point_counts(draws) if sync_light else distinct_points(draws)
    centres = kmeans(draws, options.K_e - 1, generator, options.kmeans_max_iter, options.kmeans_tol,
                     distinct, check_every)
    goals = torch.cat([best, centres], dim=1)  # (B, K_e, 2)
    return goals, goal_masses(draws, goals, distinct, sync_light)


def ttst_goals(
    goal_logits: torch.Tensor, options: SamplingOptions, generator: torch.Generator
) -> torch.Tensor:
    """TTST's goals (B, K_e, 2) without their masses (`ttst`)."""
    return ttst(goal_logits, options, generator)[0]


def cws_log_prior(
    mean: torch.Tensor,
    travel: torch.Tensor,
    sigma_factor: torch.Tensor,
    ratio: float,
    rot: bool,
    height: int,
    width: int,
) -> torch.Tensor:
    """Log of CWS's Gaussian prior, up to a constant: (B, K, H, W).

    mean: (B, K, 2) the constant-velocity point; travel: (B, K, 2) last observed position minus the
    later point (goal or later waypoint); sigma_factor: (K,) per sample. With sigma =
    (|travel| + 5) / sigma_factor (the "+5" keeps it positive when goal and agent coincide), the
    prior's standard deviation is sigma / ratio along the direction of travel and sigma across it
    (`rot=True`, the authors' SDD config and the paper's text: the waypoint's progress along the
    path is pinned down, its sideways offset left to the waypoint map). `rot=False` does what the
    authors' code does with that flag: the same axes, the widths swapped (sigma along, sigma / ratio
    across). A zero travel takes the y axis as its direction.
    """
    ys, xs = _coords(height, width, mean)
    sigma = (travel.norm(dim=-1) + 5.0) / sigma_factor  # (B, K)
    angle = torch.atan2(travel[..., 0], travel[..., 1])  # from the y axis: zero travel -> (0, 1)
    ux, uy = torch.sin(angle), torch.cos(angle)  # (B, K) unit direction of travel
    vx = (xs - mean[..., 0, None])[..., None, :]  # (B, K, 1, W)
    vy = (ys - mean[..., 1, None])[..., :, None]  # (B, K, H, 1)
    along = vx * ux[..., None, None] + vy * uy[..., None, None]  # (B, K, H, W)
    across = vy * ux[..., None, None] - vx * uy[..., None, None]
    wide = sigma[..., None, None]
    narrow = wide / ratio
    s_along, s_across = (narrow, wide) if rot else (wide, narrow)
    return -0.5 * ((along / s_along).square() + (across / s_across).square())


def cws_prior(
    last_observed: torch.Tensor,
    later: torch.Tensor,
    fraction: float,
    sigma_factor: float,
    ratio: float,
    rot: bool,
    height: int,
    width: int,
) -> torch.Tensor:
    """CWS's prior for a waypoint, normalised to sum 1: (B, K, H, W).

    Centred on the point `fraction` of the way from `later` (B, K, 2) back to `last_observed` (B, 2).
    """
    travel = last_observed[:, None] - later  # (B, K, 2)
    mean = later + travel * fraction
    factor = torch.full((later.shape[1],), float(sigma_factor), dtype=later.dtype, device=later.device)
    logp = cws_log_prior(mean, travel, factor, ratio, rot, height, width)
    return torch.softmax(logp.flatten(-2), -1).view_as(logp)


def cws_waypoints(
    waypoint_logits: torch.Tensor,
    goals: torch.Tensor,
    last_observed: torch.Tensor,
    options: SamplingOptions,
    generator: torch.Generator,
) -> torch.Tensor:
    """CWS: waypoints conditioned on each sampled goal, from the last waypoint back to the first.

    waypoint_logits: (B, n_w, H, W), goal last; goals: (B, K_a*K_e, 2) path-major; last_observed:
    (B, 2) -> (B, K_a*K_e, n_w, 2), goal last. For waypoint i (0-based, goal excluded) the prior is
    centred 1 / (i + 2) of the way from the later point back to the agent (the authors' equal-spacing
    rule; the midpoint for a single waypoint), multiplied with sigmoid(logits_i / T) and renormalised
    (here as a softmax of the summed logs, which cannot underflow to 0 / 0). Path 0 takes the mean
    position of that map (the authors' "softargmax" of an already normalised map); path a >= 1 draws
    one pixel (above cws_rel_threshold * max) with sigma_factor - a, so later paths get a tighter
    prior. Paths are processed one at a time to bound memory at (B, K_e, H, W) per map.
    """
    n_w, height, width = waypoint_logits.shape[1:]
    log_maps = F.logsigmoid(waypoint_logits / options.temperature)  # (B, n_w, H, W)
    paths = []
    for a, path_goals in enumerate(goals.split(options.K_e, dim=1)):  # each (B, K_e, 2)
        sigma_factor = torch.full((path_goals.shape[1],), options.sigma_factor - a, dtype=goals.dtype,
                                  device=goals.device)
        chosen = [path_goals]
        later = path_goals
        for i in reversed(range(n_w - 1)):
            travel = last_observed[:, None] - later  # (B, K_e, 2)
            mean = later + travel / (i + 2)
            log_prior = cws_log_prior(
                mean, travel, sigma_factor, options.ratio, options.rot, height, width
            )  # (B, K_e, H, W)
            logp = log_maps[:, i, None] + log_prior  # (B, K_e, H, W)
            prob = torch.softmax(logp.flatten(-2), -1).view_as(logp)
            if a == 0:
                later = expected_position(prob)  # (B, K_e, 2)
            else:
                later = sample_positions(prob, 1, generator, options.cws_rel_threshold)[:, :, 0]
            chosen.append(later)
        paths.append(torch.stack(chosen[::-1], dim=2))  # (B, K_e, n_w, 2)
    return torch.cat(paths, dim=1)  # (B, K_a*K_e, n_w, 2)


def draw_goals(goal_logits: torch.Tensor, options: SamplingOptions, generator: torch.Generator,
               check_every: int | None = None) -> tuple[torch.Tensor, torch.Tensor | None]:
    """The K_e goals of each window from its goal logits (B, H, W): TTST's goals (B, K_e, 2) and
    masses (B, K_e) (`ttst`; `check_every` its k-means mode), or without TTST K_e distinct pixels
    drawn from sigmoid(goal / T) (as the authors: no relative threshold) and None."""
    if options.use_ttst:
        return ttst(goal_logits, options, generator, check_every)
    prob = torch.sigmoid(goal_logits / options.temperature)
    return sample_positions(prob, options.K_e, generator, replacement=False), None


def sample_weighted_waypoints(
    waypoint_logits: torch.Tensor,
    last_observed: torch.Tensor,
    options: SamplingOptions,
    generator: torch.Generator,
    check_every: int | None = None,
    goals: tuple[torch.Tensor, torch.Tensor | None] | None = None,
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Goals and waypoints for every sample: (B, n_w, H, W) logits, goal last -> (B, K_e*K_a, n_w, 2),
    and each sample's weight (B, K) (`Prediction.weights`; None without TTST).

    Goals: `draw_goals` (TTST, or K_e distinct pixels drawn from sigmoid(goal / T)), unless `goals`
    gives them already (its output for these windows: drawn for more windows at once). Waypoints:
    CWS, or one independent draw per sample from each sigmoid(waypoint / T) map. `check_every`:
    TTST's k-means mode (`kmeans`).
    """
    b, n_w, height, width = waypoint_logits.shape
    if goals is None:
        goals = draw_goals(waypoint_logits[:, -1], options, generator, check_every)
    goals, masses = goals  # (B, K_e, 2), (B, K_e) or None
    weights = None if masses is None else masses.repeat(1, options.K_a) / options.K_a  # (B, K)
    goals = goals.repeat(1, options.K_a, 1)  # (B, K, 2), path-major
    if n_w == 1:
        return goals[:, :, None], weights
    if options.use_cws:
        return cws_waypoints(waypoint_logits, goals, last_observed, options, generator), weights
    prob = torch.sigmoid(waypoint_logits[:, :-1] / options.temperature)  # (B, n_w - 1, H, W)
    drawn = sample_positions(prob, options.K, generator)  # (B, n_w - 1, K, 2)
    return torch.cat([drawn.transpose(1, 2), goals[:, :, None]], dim=2), weights  # (B, K, n_w, 2)


def sample_waypoints(
    waypoint_logits: torch.Tensor,
    last_observed: torch.Tensor,
    options: SamplingOptions,
    generator: torch.Generator,
) -> torch.Tensor:
    """`sample_weighted_waypoints` without the weights: (B, K_e*K_a, n_w, 2)."""
    return sample_weighted_waypoints(waypoint_logits, last_observed, options, generator)[0]


@dataclass(frozen=True)
class Encoded:
    """What `encode` computes once for a batch of windows and every sampling of them reuses: the
    encoder's features and the waypoint logits (goal last). Nothing in it is random."""

    features: list[torch.Tensor]  # encoder features, fine to coarse, channels_last
    waypoint_logits: torch.Tensor  # (B, n_w, H, W)


def encoder_features(model: YNet, scene_and_past: torch.Tensor) -> list[torch.Tensor]:
    """The encoder alone (float32, channels_last: about 1.5x faster convs on CPU) for a batch of
    windows on one map: (B, C + n_p, H, W) -> `Encoded.features`."""
    x = scene_and_past.contiguous(memory_format=torch.channels_last)
    with torch.inference_mode():
        return model.encode(x)


def encode(model: YNet, scene_and_past: torch.Tensor) -> Encoded:
    """The encoder and the goal decoder for a batch of windows on one map: (B, C + n_p, H, W) ->
    `Encoded`."""
    features = encoder_features(model, scene_and_past)
    with torch.inference_mode():
        goal_logits = model.predict_goals(features)  # (B, n_f, H, W)
        # one slice per waypoint: a list index would be copied to the GPU, waiting for it
        waypoint_logits = torch.stack([goal_logits[:, i] for i in model.config.waypoints], dim=1)
    return Encoded(features=features, waypoint_logits=waypoint_logits)


def predict_encoded(
    model: YNet,
    encoded: Encoded,
    last_observed: torch.Tensor,
    options: SamplingOptions,
    generator: torch.Generator,
    max_distance: float | None = None,
    chunk_size: int = 8,
    bf16: bool = False,
    check_every: int | None = None,
    goals: tuple[torch.Tensor, torch.Tensor | None] | None = None,
) -> Prediction:
    """`predict` after its `encode`: goals and waypoints drawn from `encoded`'s maps, and the
    trajectory decoder for every sample. Several samplings of one `encode` (other seeds, other
    options) give exactly what as many `predict` calls give, without re-running the encoder.
    `goals`: `draw_goals`' output for these windows, where it was drawn beforehand."""
    height, width = encoded.waypoint_logits.shape[-2:]
    with torch.inference_mode():
        samples, weights = sample_weighted_waypoints(encoded.waypoint_logits, last_observed.float(),
                                                     options, generator, check_every, goals)
        steps = []
        for start in range(0, options.K, chunk_size):
            chunk = samples[:, start : start + chunk_size]  # (B, k, n_w, 2)
            maps = distance_maps(chunk.flatten(1, 2), height, width, max_distance)  # (B, k*n_w, H, W)
            maps = maps.unflatten(1, chunk.shape[1:3])  # (B, k, n_w, H, W)
            with torch.autocast(samples.device.type, dtype=torch.bfloat16, enabled=bf16):
                logits = model.predict_trajectory(encoded.features, maps)  # (B, k, n_f, H, W)
            # Each chunk's large tensors are let go as soon as they are used, not when the next
            # chunk replaces them: the maps before the softmax, the bfloat16 logits before their
            # float32 copy's softmax, that copy before the next chunk's decoder.
            del maps
            logits = logits.float()
            steps.append(softargmax(logits))  # (B, k, n_f, 2)
            del logits
        trajectory = torch.cat(steps, dim=1)  # (B, K, n_f, 2)
    return Prediction(trajectory=trajectory, goals=samples[:, :, -1], waypoints=samples,
                      weights=weights)


def predict(
    model: YNet,
    scene_and_past: torch.Tensor,
    last_observed: torch.Tensor,
    options: SamplingOptions,
    generator: torch.Generator,
    max_distance: float | None = None,
    chunk_size: int = 8,
    bf16: bool = False,
    check_every: int | None = None,
) -> Prediction:
    """Y-net inference for a batch of windows on one map: K_e * K_a futures per window.

    scene_and_past: (B, C + n_p, H, W) as in training; last_observed: (B, 2) the agent's last
    observed position; max_distance: the distance-map normaliser used for training (for the goal and
    waypoint maps given to the trajectory decoder).

    The encoder and the goal decoder run once (`encode`); the trajectory decoder runs once per
    sample (`predict_encoded`), batched `chunk_size` samples per window at a time (its encoder
    skips are shared, see `ynet.model.shared_input_conv`), and only each heatmap's softargmax is
    kept. Everything runs in channels_last (about 1.5x faster convs on CPU).

    `bf16=True` runs the trajectory decoder (about three quarters of the time on CPU) under
    bfloat16 autocast (on the inputs' device): about 1.5x faster on CPUs with AMX / AVX512-BF16,
    and what GPUs want. Encoder, goal decoder and sampling stay float32, so goals and waypoints
    (and FDE) are bit-identical to float32; trajectory positions move by a fraction
    of a pixel (0.01 px mean, 0.04 px max on an overfitted tiny model like the tests').

    `check_every`: TTST's k-means mode (`kmeans`): None (the default) as always; an int for GPUs,
    a host sync every that many iterations instead of about two per iteration (other draws).
    """
    return predict_encoded(model, encode(model, scene_and_past), last_observed, options, generator,
                           max_distance, chunk_size, bf16, check_every)
