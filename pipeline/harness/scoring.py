"""Every metric the benchmark reports, computed from stored predictions
(`pipeline.harness.predictions`) and the ground truth: pure numpy functions, one value per window
(or per window and step), and one aggregation into means per window and per scene.

Inputs: predictions `pred` (N, K, T, 2) and the future ground truth `truth` (N, T, 2), both in the
benchmark's unit (original image pixels for SDD, metres for ETH/UCY); optional sample weights
(N, K) and, for min-ADE/FDE, separately predicted goals (N, K, 2). Every function checks its shapes and raises ValueError naming the shape it got.

- `min_ade_fde`: the paper's best-of-K ADE and FDE (independent minima) and the joint ones (one
  sample), straight from `pipeline.harness.metrics.window_errors` (FDE on the goals where given).
- `best_endpoint_ade`: ADE of the sample whose endpoint is closest to the true one (PECNet's
  protocol: its test code picks the best destination first, then scores that sample's path).
- `miss`: whether the best endpoint is further than a stated threshold (the miss rate's windows).
- `ade_one_sample` / `fde_one_sample` (`one_sample_ade_fde`): the mean over the K samples of each
  sample's ADE / FDE, the expected error of one sample drawn at random: a K = 1 score from K.
- `ade_sgan_sequence` / `fde_sgan_sequence`: S-GAN's protocol (its `evaluate_model.py`, the
  source of the paper's ETH/UCY S-GAN row): each sample's error is summed over every window of a
  sequence (`sgan_sequences`: one scene and start frame, as S-GAN's loader groups pedestrians),
  the minimum of those sums over the K samples is taken per sequence (one sample index for the
  whole sequence), and the minima are summed over sequences and divided by the window count. One
  number per set of windows, not a mean of per-window values: `sgan_sequence_scores` gives it
  over all windows and per scene (a sequence never spans two scenes). ADE and FDE are minimised
  separately. At least the paper's per-window minima; equal to them for K = 1.
- `kde_nll`: negative log-likelihood of the ground truth under a Gaussian KDE of the K samples, per
  step, clipped as Trajectron++ and TrajNet++ do.
- `scene_compliance` / `forbidden_share`: the share of positions on classes a pedestrian cannot
  stand on (structure, tree) in the hand-labelled masks, for predictions and for the ground truth.
- `collisions`: how often samples of agents that share frames come closer than a threshold.
- `per_scene_means` / `aggregate`: means over windows and over scenes, as a JSON-able dict.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pipeline.harness.metrics import as_numpy, goal_errors, step_errors, window_errors

# ---------------------------------------------------------------------------------------------
# Shapes


def check_paths(pred: Any, truth: Any) -> tuple[np.ndarray, np.ndarray]:
    """float64 (N, K, T, 2) predictions and (N, T, 2) ground truth, or a ValueError naming both."""
    pred, truth = as_numpy(pred), as_numpy(truth)
    if pred.ndim != 4 or pred.shape[-1] != 2 or pred.shape[1] < 1 or pred.shape[2] < 1:
        raise ValueError(f"predictions must be (N, K, T, 2) with K, T >= 1, got shape {pred.shape}")
    if truth.shape != (pred.shape[0], pred.shape[2], 2):
        raise ValueError(f"ground truth must be (N, T, 2) = {(pred.shape[0], pred.shape[2], 2)} "
                         f"for predictions {pred.shape}, got shape {truth.shape}")
    return pred, truth


def check_per_window(values: Any, n: int, name: str) -> np.ndarray:
    """A (N,) array, or a ValueError naming `name` and the shape it got."""
    values = np.asarray(values)
    if values.shape != (n,):
        raise ValueError(f"{name} must be ({n},), got shape {values.shape}")
    return values


# ---------------------------------------------------------------------------------------------
# Displacement errors


def min_ade_fde(pred: Any, truth: Any, goals: Any | None = None) -> dict[str, np.ndarray]:
    """Per window (N,): 'ade' and 'fde', min over K taken independently (the paper's protocol; the
    two may come from different samples), and 'ade_joint' / 'fde_joint', both of the one sample
    with the lowest ADE (ties to the lowest index). Keys as `metrics.METRIC_KEYS`.

    `goals` (N, K, 2), for a model that predicts a goal apart from its path (Y-net: a stored file's
    goal_x / goal_y), measure FDE on the goal instead of the path's last point, exactly as
    `metrics.window_errors(pred, truth, goals)` does when scoring in memory."""
    pred, truth = check_paths(pred, truth)
    errors = window_errors(pred, truth, goals)
    return {"ade": errors.ade, "fde": errors.fde, "ade_joint": errors.ade,
            "fde_joint": errors.fde_joint}


def endpoint_errors(pred: np.ndarray, truth: np.ndarray, goals: Any | None) -> np.ndarray:
    """(N, K) distance of each sample's endpoint to the true final point: the path's last point,
    or the sample's separately predicted goal (N, K, 2) where given, as `min_ade_fde`'s FDE."""
    if goals is None:
        return step_errors(pred[:, :, -1:], truth[:, -1:])[..., 0]
    errors = goal_errors(goals, truth)  # (N, K)
    if errors.shape != pred.shape[:2]:
        raise ValueError(f"goals must be (N, K, 2) = {(*pred.shape[:2], 2)}, got shape "
                         f"{np.shape(goals)}")
    return errors


def best_endpoint_ade(pred: Any, truth: Any, goals: Any | None = None) -> np.ndarray:
    """(N,) ADE of the sample whose endpoint is closest to the true final point, ties to the
    lowest sample index: PECNet's protocol, which picks the best of K destinations and scores the
    path to it. At least min-ADE; equal to it where one sample is best at both. `goals` (N, K, 2):
    the endpoint is the sampled goal (Y-net samples a goal, then a path to it, as PECNet samples a
    destination), so the endpoint is the one min-FDE is measured on."""
    pred, truth = check_paths(pred, truth)
    best = endpoint_errors(pred, truth, goals).argmin(axis=1)  # (N,) first index on ties
    ade = step_errors(pred, truth).mean(axis=-1)  # (N, K)
    return ade[np.arange(len(best)), best]


def miss(pred: Any, truth: Any, threshold: Any, goals: Any | None = None) -> np.ndarray:
    """(N,) bool: min-FDE > `threshold` (strictly: an endpoint exactly at the threshold is a hit),
    min-FDE on `goals` (N, K, 2) where given, as `min_ade_fde`'s.

    `threshold` is in the benchmark's unit, as pred and truth are: metres for ETH/UCY (2 m is the
    Argoverse-style miss rate's), original image pixels for SDD; one distance, or one per window
    (N,) (a distance in metres converted with each scene's own scale). The caller states it; this
    module has no default because no one value fits both units."""
    pred, truth = check_paths(pred, truth)
    limit = np.asarray(threshold, dtype=np.float64)  # () or (N,)
    if limit.ndim:
        check_per_window(limit, len(pred), "threshold")
    if not np.isfinite(limit).all() or (limit < 0).any():
        raise ValueError(f"threshold must be a finite distance >= 0, got {threshold}")
    return endpoint_errors(pred, truth, goals).min(axis=1) > limit


# ---------------------------------------------------------------------------------------------
# One sample (K = 1 from K stored samples)

ADE_ONE_SAMPLE, FDE_ONE_SAMPLE = "ade_one_sample", "fde_one_sample"


def one_sample_ade_fde(pred: Any, truth: Any, goals: Any | None = None) -> dict[str, np.ndarray]:
    """Per window (N,): `ADE_ONE_SAMPLE` and `FDE_ONE_SAMPLE`, the mean over the K samples of each
    sample's ADE and FDE: the expected error of one sample drawn at random from the model's K,
    i.e. the model's K = 1 score, without sampling again. FDE on `goals` (N, K, 2) where given, as
    `min_ade_fde`'s. At least min-ADE / min-FDE; equal to them when the K samples coincide (a
    deterministic model) or K = 1."""
    pred, truth = check_paths(pred, truth)
    return {ADE_ONE_SAMPLE: step_errors(pred, truth).mean(axis=-1).mean(axis=1),
            FDE_ONE_SAMPLE: endpoint_errors(pred, truth, goals).mean(axis=1)}


# ---------------------------------------------------------------------------------------------
# S-GAN's sequence protocol

ADE_SGAN_SEQUENCE, FDE_SGAN_SEQUENCE = "ade_sgan_sequence", "fde_sgan_sequence"


def sgan_sequences(scene_id: Any, first_frame: Any) -> np.ndarray:
    """(N,) int64 S-GAN sequence of each window, from its scene_id (N,) and the raw frame of its
    first step first_frame (N,): windows with equal (scene_id, first_frame) share one, numbered
    in (scene, frame) order.

    S-GAN's loader makes one sequence per file and start frame (the pedestrians present in all of
    the next 20 frames), and `pipeline.benchmarks.ethucy` cuts the ETH/UCY windows as it does, one
    scene_id per S-GAN file, so this key gives S-GAN's sequences back. For other windows (SDD's
    1 FPS tracks) it groups those that start together: S-GAN's rule applied to those windows."""
    scene_id = np.asarray(scene_id)
    first_frame = check_per_window(first_frame, len(scene_id), "first_frame")
    check_per_window(scene_id, len(first_frame), "scene_id")
    if first_frame.dtype.kind not in "iu":
        raise ValueError(f"first_frame must be integers, got {first_frame.dtype}")
    scene_code = np.unique(scene_id, return_inverse=True)[1].reshape(-1)  # (N,)
    keys = np.stack([scene_code, first_frame.astype(np.int64)], axis=1)  # (N, 2)
    if not len(keys):
        return np.zeros(0, dtype=np.int64)
    return np.unique(keys, axis=0, return_inverse=True)[1].reshape(-1).astype(np.int64)


def sequence_joint_min(errors: Any, sequences: Any) -> float:
    """S-GAN's best of K (its `evaluate_helper`): errors (N, K) of each window and sample, summed
    over the windows of each sequence (sequences (N,), any labels), the minimum over k of those
    sums per sequence, summed over sequences and divided by N. Every pedestrian of a sequence is
    scored with the same sample, so this is at least the mean of the per-window minima, and equal
    to it where one sample is best for every window of each sequence (always for K = 1)."""
    errors = as_numpy(errors)
    if errors.ndim != 2 or errors.shape[0] < 1 or errors.shape[1] < 1:
        raise ValueError(f"errors must be (N, K) with N, K >= 1, got shape {errors.shape}")
    sequences = check_per_window(sequences, len(errors), "sequences")
    code = np.unique(sequences, return_inverse=True)[1].reshape(-1)  # (N,) 0 .. S - 1
    sums = np.zeros((code.max() + 1, errors.shape[1]))  # (S, K) each sequence's error per sample
    np.add.at(sums, code, errors)
    return float(sums.min(axis=1).sum() / len(errors))


def ade_sgan_sequence(pred: Any, truth: Any, sequences: Any) -> float:
    """S-GAN's ADE: `sequence_joint_min` of each window's and sample's ADE (N, K) over
    `sequences` (N,) (`sgan_sequences`); S-GAN's sum of displacements over every predicted step
    of the sequence, divided by N * T, is the same number."""
    pred, truth = check_paths(pred, truth)
    return sequence_joint_min(step_errors(pred, truth).mean(axis=-1), sequences)


def fde_sgan_sequence(pred: Any, truth: Any, sequences: Any, goals: Any | None = None) -> float:
    """S-GAN's FDE: `sequence_joint_min` of each window's and sample's final displacement (N, K)
    over `sequences` (N,), minimised apart from the ADE (it may pick another sample); on `goals`
    (N, K, 2) where given, as `min_ade_fde`'s FDE."""
    pred, truth = check_paths(pred, truth)
    return sequence_joint_min(endpoint_errors(pred, truth, goals), sequences)


def sgan_sequence_scores(pred: Any, truth: Any, sequences: Any, scenes: Any,
                         goals: Any | None = None) -> dict[str, Any]:
    """`ade_sgan_sequence` and `fde_sgan_sequence` over all windows and per scene (the same
    formula over the scene's windows): {"all": {name: value}, "per_scene": {scene: {name: value}}},
    scenes in sorted order. Each is a number of its set of windows, not a mean of per-window
    values; as a sequence never spans two scenes (a ValueError otherwise), the value over all
    windows is the per-scene values' mean weighted by the scenes' window counts."""
    pred, truth = check_paths(pred, truth)
    sequences = check_per_window(sequences, len(pred), "sequences")
    scenes = check_per_window(scenes, len(pred), "scenes")
    scene_code = np.unique(scenes, return_inverse=True)[1].reshape(-1)  # (N,)
    sequence_code = np.unique(sequences, return_inverse=True)[1].reshape(-1)  # (N,)
    if len(np.unique(np.stack([sequence_code, scene_code], axis=1), axis=0)) \
            != len(np.unique(sequence_code)):
        raise ValueError("a sequence spans two scenes: sequences must lie within one scene")
    goals = None if goals is None else as_numpy(goals)

    def scores(rows: np.ndarray | slice) -> dict[str, float]:
        goals_rows = None if goals is None else goals[rows]
        return {ADE_SGAN_SEQUENCE: ade_sgan_sequence(pred[rows], truth[rows], sequences[rows]),
                FDE_SGAN_SEQUENCE: fde_sgan_sequence(pred[rows], truth[rows], sequences[rows],
                                                     goals_rows)}

    return {"all": scores(slice(None)),
            "per_scene": {str(scene): scores(scenes == scene) for scene in np.unique(scenes)}}


# ---------------------------------------------------------------------------------------------
# KDE negative log-likelihood

LOG_PDF_FLOOR = -20.0  # Trajectron++'s `log_pdf_lower_bound`: one step's NLL is at most 20
DEGENERATE_RTOL = 1e-10  # 1 - correlation^2 at or below this: the samples lie on a line


def kde_log_pdf(pred: Any, truth: Any, weights: Any | None = None) -> tuple[np.ndarray, np.ndarray]:
    """log-density of the ground truth under a 2-D Gaussian KDE of the K samples, per window and
    step, and where that KDE does not exist: (log_pdf (N, T), degenerate (N, T) bool).

    The KDE is `scipy.stats.gaussian_kde(samples, weights=w)` (Scott's bandwidth, neff^(-1/6) with
    neff = 1 / sum(w^2), times the samples' weighted covariance), computed for all windows and
    steps at once with a closed-form 2x2 Cholesky factor instead of one scipy object per step;
    it agrees with scipy to rounding (tests: 1e-9).

    Degenerate (log_pdf NaN): fewer than 3 samples of positive weight, or samples with no spread
    along some direction (all identical, or on one line: 1 - corr^2 <= DEGENERATE_RTOL, or a
    variance below rounding). Their covariance is singular, so the KDE has no density: scipy
    raises LinAlgError (or, near the limit, returns a number rounding made up).
    """
    pred, truth = check_paths(pred, truth)
    n, k, t, _ = pred.shape
    if weights is None:
        w = np.full((n, k), 1.0 / k)
    else:
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (n, k):
            raise ValueError(f"weights must be (N, K) = {(n, k)}, got shape {w.shape}")
        if not np.isfinite(w).all() or (w < 0).any() or (w.sum(axis=1) <= 0).any():
            raise ValueError("weights must be finite, >= 0, and not all 0 in a window")
        w = w / w.sum(axis=1, keepdims=True)
    w2 = (w * w).sum(axis=1)  # (N,) sum of squared normalised weights = 1 / neff
    fact = 1.0 - w2  # (N,) np.cov's normaliser with aweights (= (K-1)/K unweighted)
    factor = w2 ** (1.0 / 6.0)  # (N,) Scott: neff^(-1/(d+4)), d = 2
    few = (w > 0).sum(axis=1) < 3  # (N,) two points always lie on a line

    x = pred.transpose(0, 2, 1, 3)  # (N, T, K, 2)
    d = x - x[:, :, :1]  # (N, T, K, 2) shifted to sample 0: identical samples give exact zeros
    wk = w[:, None, :, None]  # (N, 1, K, 1)
    dev = d - (wk * d).sum(axis=2, keepdims=True)  # (N, T, K, 2) minus the weighted mean
    a = (wk[..., 0] * dev[..., 0] ** 2).sum(axis=2)  # (N, T) fact * var(x)
    b = (wk[..., 0] * dev[..., 0] * dev[..., 1]).sum(axis=2)  # (N, T) fact * cov(x, y)
    c = (wk[..., 0] * dev[..., 1] ** 2).sum(axis=2)  # (N, T) fact * var(y)
    spread = (d ** 2).max(axis=2)  # (N, T, 2) squared largest offset from sample 0
    degenerate = (few[:, None] | (a <= 1e-24 * spread[..., 0]) | (c <= 1e-24 * spread[..., 1])
                  | (a * c - b * b <= DEGENERATE_RTOL * a * c))  # (N, T)
    # Placeholders where degenerate (masked below): elsewhere c - b^2 / a = det / a > 0.
    a, c = np.where(degenerate, 1.0, a), np.where(degenerate, 1.0, c)
    b = np.where(degenerate, 0.0, b)
    scale = factor[:, None] / np.sqrt(np.where(few, 1.0, fact))[:, None]  # (N, 1)
    l11 = np.sqrt(a) * scale  # (N, T) kernel covariance = L L^T, L = [[l11, 0], [l21, l22]]
    l21 = b / np.sqrt(a) * scale
    l22 = np.sqrt(c - b * b / a) * scale

    diff = truth[:, :, None] - x  # (N, T, K, 2)
    z1 = diff[..., 0] / l11[..., None]  # (N, T, K) whitened offsets: z = L^-1 diff
    z2 = (diff[..., 1] - l21[..., None] * z1) / l22[..., None]
    with np.errstate(divide="ignore"):
        terms = np.log(w)[:, None, :] - 0.5 * (z1 * z1 + z2 * z2)  # (N, T, K); -inf at weight 0
    top = terms.max(axis=2)  # (N, T) log-sum-exp, shifted by the largest term
    log_pdf = (top + np.log(np.exp(terms - top[..., None]).sum(axis=2))
               - np.log(l11) - np.log(l22) - np.log(2 * np.pi))  # (N, T)
    return np.where(degenerate, np.nan, log_pdf), degenerate


def kde_nll(pred: Any, truth: Any, log_pdf_floor: float = LOG_PDF_FLOOR,
            weights: Any | None = None) -> np.ndarray:
    """(N, T) negative log-likelihood of the ground truth at each step under a Gaussian KDE of that
    step's K samples, the log-pdf clipped below at `log_pdf_floor` (so each value is at most
    -log_pdf_floor). Trajectron++'s `compute_kde_nll` (and TrajNet++'s) does this with one
    `scipy.stats.gaussian_kde` per step, then averages over steps and windows; average this
    array the same way. `weights` (N, K), e.g. Y-net's goal cluster masses, make it a weighted
    KDE; the literature's protocol is unweighted (None).

    A density has a unit: this is per unit^2 of the benchmark (pixels or metres), so values in
    pixels and metres differ by 2 log(pixels per metre) and only compare within one unit.

    Degenerate steps (`kde_log_pdf`: fewer than 3 samples, or samples on a point or a line, as
    from a deterministic model or K = 1) have no density; they score the floor, -log_pdf_floor,
    the worst value, whatever the truth: a model must not gain by collapsing its samples.
    Trajectron++ instead lets scipy's LinAlgError turn the whole batch's NLL into NaN. Count
    them with `kde_log_pdf(...)[1]` where it matters.
    """
    return clipped_nll(*kde_log_pdf(pred, truth, weights), log_pdf_floor)


def clipped_nll(log_pdf: np.ndarray, degenerate: np.ndarray, log_pdf_floor: float) -> np.ndarray:
    """-max(log_pdf, floor), and -floor where the KDE is degenerate (`kde_nll`)."""
    return -np.where(degenerate, log_pdf_floor, np.maximum(log_pdf, log_pdf_floor))


# ---------------------------------------------------------------------------------------------
# Scene compliance

ALLOWED, FORBIDDEN, OUTSIDE = 0, 1, 2  # per-position status of `scene_compliance`
def mask_pixels(positions: np.ndarray, scale: float | np.ndarray) -> np.ndarray:
    """Integer (column, row) of the mask pixel nearest to each position (..., 2) = (x, y).

    Convention: integer coordinates are pixel centres (pixel i of the original image is centred at
    i, as the annotations' pixel indices are), so original pixel i covers [i - 0.5, i + 0.5). A
    mask at `scale` mask pixels per original pixel, resized centre-aligned (as cv2.resize's area
    and linear modes are), has mask pixel j cover [j / scale - 0.5, (j + 1) / scale - 0.5) of the
    original: j = floor((x + 0.5) * scale). A position on a boundary goes to the pixel right of /
    below it (at scale 1: round half up). cv2's INTER_NEAREST is not centre-aligned: resize masks
    with INTER_NEAREST_EXACT, or keep them at the original resolution (scale 1).
    """
    return np.floor((positions + 0.5) * scale).astype(np.int64)


def scene_compliance(positions: Any, scene_index: Any, masks: Sequence[np.ndarray],
                     forbidden_classes: Collection[int], scale: Sequence[float] | float = 1.0
                     ) -> np.ndarray:
    """int8 status of each position (...,): FORBIDDEN (on a class in `forbidden_classes`), ALLOWED
    (on any other class) or OUTSIDE (off the mask), looked up at the nearest mask pixel
    (`mask_pixels` states the rounding).

    positions: (..., 2) (x, y) in original image pixels (ETH/UCY metres must first go through the
    scene's homography); scene_index: ints into `masks`, of a leading part of positions' shape,
    e.g. (N,) for (N, K, T, 2); masks: 2-D arrays (H_s, W_s) of class values per scene; scale: mask
    pixels per original image pixel, one per scene (or one for all).
    """
    positions = as_numpy(positions)
    scene_index = np.asarray(scene_index)
    if positions.ndim < 1 or positions.shape[-1] != 2:
        raise ValueError(f"positions must be (..., 2), got shape {positions.shape}")
    if not np.isfinite(positions).all():
        raise ValueError("positions must be finite")
    lead = positions.shape[:-1]
    if scene_index.shape != lead[:scene_index.ndim] or scene_index.dtype.kind not in "iu":
        raise ValueError(f"scene_index must be integers of a leading part of {lead}, got shape "
                         f"{scene_index.shape} of {scene_index.dtype}")
    scales = np.broadcast_to(np.asarray(scale, dtype=np.float64), (len(masks),))
    trailing = (1,) * (len(lead) - scene_index.ndim)  # scene_index (N,) -> (N, 1, 1) for (N, K, T)
    scene = np.broadcast_to(scene_index.reshape(scene_index.shape + trailing), lead)
    scene = scene.reshape(-1)  # (P,)
    flat = positions.reshape(-1, 2)  # (P, 2)
    status = np.full(len(flat), OUTSIDE, dtype=np.int8)  # (P,)
    if len(scene) and (scene.min() < 0 or scene.max() >= len(masks)):
        raise ValueError(f"scene_index runs {scene.min()}..{scene.max()}, masks has {len(masks)}")
    forbidden = np.asarray(sorted(forbidden_classes), dtype=np.int64)
    for s in np.unique(scene):
        mask = np.asarray(masks[s])
        if mask.ndim != 2:
            raise ValueError(f"masks[{s}] must be (H, W), got shape {mask.shape}")
        at = np.flatnonzero(scene == s)  # (P_s,)
        col, row = mask_pixels(flat[at], scales[s]).T  # (P_s,) each
        inside = (col >= 0) & (col < mask.shape[1]) & (row >= 0) & (row < mask.shape[0])
        classes = mask[row[inside], col[inside]]
        status[at[inside]] = np.where(np.isin(classes, forbidden), FORBIDDEN, ALLOWED)
    return status.reshape(lead)


def forbidden_share(status: np.ndarray) -> np.ndarray:
    """(N,) per window: positions on a forbidden class / positions inside the mask, over every axis
    but the first (all K samples and T steps of a prediction; the T steps of the ground truth).
    NaN where no position of the window is inside the mask."""
    status = np.asarray(status)
    flat = status.reshape(len(status), -1)  # (N, positions)
    forbidden = (flat == FORBIDDEN).sum(axis=1)
    inside = (flat != OUTSIDE).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(inside > 0, forbidden / inside, np.nan)


# ---------------------------------------------------------------------------------------------
# Collisions

PAIR_CHUNK = 2_000_000  # row pairs checked at once: bounds memory at ~ PAIR_CHUNK * K * 16 bytes


@dataclass(frozen=True)
class Collisions:
    """Per window (N,): how its future meets the futures of other agents in the same frames."""

    pred_share: np.ndarray  # (N,) share of its K samples that collide with any co-present agent
    truth: np.ndarray  # (N,) bool, whether its ground truth collides with any co-present agent
    copresent: np.ndarray  # (N,) bool, whether another agent shares any of its future frames


def _group_pairs(sizes: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pair (i < j) of positions within each group of `sizes` rows starting at `starts`
    (positions in one sorted order): (first, second) index arrays, sum of m (m - 1) / 2 long."""
    local = np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes)  # index in group
    position = np.repeat(starts, sizes) + local
    partners = np.repeat(sizes, sizes) - 1 - local  # later rows of the same group
    first = np.repeat(position, partners)
    offset = np.arange(len(first)) - np.repeat(np.cumsum(partners) - partners, partners)
    return first, first + 1 + offset


def collisions(pred: Any, truth: Any, scene: Any, frames: Any, threshold: float, *,
               agents: Any) -> Collisions:
    """Collisions between agents that share frames, for the predictions and for the ground truth.

    Two windows of the same scene whose future frames overlap (`frames` (N, T) ints, strictly
    increasing in each window) are co-present, unless they are of the same agent (`agents` (N,),
    track ids: overlapping windows of one track would otherwise collide with themselves). Sample k
    of one window is compared with sample k of the other, as the literature does for models whose
    agents are sampled independently (there is no joint sample to compare otherwise): the pair
    collides in sample k if at any shared frame their positions are closer than `threshold`
    (strictly; in the benchmark's unit). Only the sampled steps are checked, not the segments
    between them (TrajNet++ also interpolates between steps). Window a's `pred_share` is the share
    of k in which it collides with at least one co-present agent; `truth` the same for the ground
    truth (0 or 1). A window with no co-present agent has 0 and False; `copresent` tells them apart.

    Rows (window, step) are grouped by (scene, frame); all pairs within a group are formed at once,
    a pair whose K-sample bounding boxes stay `threshold` apart is dropped before the K distances.
    """
    pred, truth = check_paths(pred, truth)
    n, k, t, _ = pred.shape
    scene = check_per_window(scene, n, "scene")
    agents = check_per_window(agents, n, "agents")
    frames = np.asarray(frames)
    if frames.shape != (n, t) or frames.dtype.kind not in "iu":
        raise ValueError(f"frames must be (N, T) = {(n, t)} integers, got shape {frames.shape} "
                         f"of {frames.dtype}")
    if t > 1 and not (np.diff(frames, axis=1) > 0).all():
        raise ValueError("frames must be strictly increasing within each window")
    if not np.isfinite(threshold) or threshold < 0:
        raise ValueError(f"threshold must be a finite distance >= 0, got {threshold}")
    limit = threshold * threshold

    scene_code = np.unique(scene, return_inverse=True)[1].reshape(n)  # (N,)
    agent_code = np.unique(agents, return_inverse=True)[1].reshape(n)  # (N,)
    row_window = np.repeat(np.arange(n), t)  # (R,) rows are (window, step), R = N * T
    row_frame = frames.reshape(-1).astype(np.int64)  # (R,)
    order = np.lexsort((row_frame, np.repeat(scene_code, t)))  # (R,) grouped by (scene, frame)
    key_scene, key_frame = np.repeat(scene_code, t)[order], row_frame[order]
    new = np.flatnonzero(np.r_[True, (key_scene[1:] != key_scene[:-1])
                                     | (key_frame[1:] != key_frame[:-1])])  # group starts
    sizes = np.diff(np.r_[new, len(order)])
    keep = sizes > 1
    starts, sizes = new[keep], sizes[keep]

    rows_xy = pred.transpose(0, 2, 1, 3).reshape(n * t, k, 2)  # (R, K, 2)
    lo_x, lo_y = rows_xy.min(axis=1).T  # (R,) each: the K samples' bounding box per row
    hi_x, hi_y = rows_xy.max(axis=1).T
    true_x, true_y = truth.reshape(n * t, 2).T  # (R,) each
    pred_hit = np.zeros((n, k), dtype=bool)
    truth_hit = np.zeros(n, dtype=bool)
    copresent = np.zeros(n, dtype=bool)

    pairs = sizes * (sizes - 1) // 2
    ends = np.cumsum(pairs)
    begin = 0
    while begin < len(sizes):  # chunks of groups with about PAIR_CHUNK pairs (at least one group)
        stop = max(begin + 1, int(np.searchsorted(ends, ends[begin] - pairs[begin] + PAIR_CHUNK,
                                                  side="right")))
        first, second = _group_pairs(sizes[begin:stop], starts[begin:stop])
        ra, rb = order[first], order[second]  # (P,) rows of each pair
        wa, wb = row_window[ra], row_window[rb]  # (P,)
        other = agent_code[wa] != agent_code[wb]
        ra, rb, wa, wb = ra[other], rb[other], wa[other], wb[other]
        copresent[wa] = copresent[wb] = True
        close = (true_x[ra] - true_x[rb]) ** 2 + (true_y[ra] - true_y[rb]) ** 2 < limit  # (P,)
        truth_hit[wa[close]] = truth_hit[wb[close]] = True
        gap_x = np.maximum(np.maximum(lo_x[ra] - hi_x[rb], lo_x[rb] - hi_x[ra]), 0.0)  # (P,)
        gap_y = np.maximum(np.maximum(lo_y[ra] - hi_y[rb], lo_y[rb] - hi_y[ra]), 0.0)
        near = gap_x * gap_x + gap_y * gap_y < limit  # (P,) the boxes come within threshold
        ra, rb, wa, wb = ra[near], rb[near], wa[near], wb[near]
        diff = rows_xy[ra] - rows_xy[rb]  # (P', K, 2)
        p, s = np.nonzero(diff[..., 0] ** 2 + diff[..., 1] ** 2 < limit)  # hits (pair, k)
        pred_hit[wa[p], s] = pred_hit[wb[p], s] = True
        begin = stop
    return Collisions(pred_share=pred_hit.mean(axis=1), truth=truth_hit, copresent=copresent)


# ---------------------------------------------------------------------------------------------
# Aggregation


def _mean(values: np.ndarray) -> float | None:
    """Mean of the finite values; None (JSON null) where there is none."""
    finite = values[np.isfinite(values)]
    return float(finite.mean()) if len(finite) else None


def per_scene_means(values: Any, scenes: Any) -> dict[str, float | None]:
    """{scene: mean of `values` (N,) over its windows}, scenes in sorted order. NaN values (e.g. a
    compliance share of a window wholly off the mask) are left out; None if a scene has no other."""
    values = np.asarray(values, dtype=np.float64)
    scenes = check_per_window(scenes, len(values), "scenes")
    names, code = np.unique(scenes, return_inverse=True)
    return {str(name): _mean(values[code.reshape(-1) == i]) for i, name in enumerate(names)}


def aggregate(per_window: dict[str, Any], scenes: Any) -> dict[str, Any]:
    """Means of per-window metrics `{name: (N,)}` (bools count as 0/1) over windows and over scenes.

    Layout (JSON-able; None where no window has a finite value):
        {"n_windows": N, "n_scenes": S,
         "window_mean": {metric: mean over windows},
         "scene_mean": {metric: mean over scenes of the per-scene means (each scene counts once,
                        however many windows it has)},
         "per_scene": {scene: {"n_windows": n, metric: mean over its windows}}}
    NaN values are left out of every mean (`per_scene_means`).
    """
    scenes = np.asarray(scenes)
    n = len(scenes)
    values = {name: check_per_window(np.asarray(v, dtype=np.float64), n, name)
              for name, v in per_window.items()}
    names, counts = np.unique(scenes, return_counts=True)
    per_scene: dict[str, dict[str, Any]] = {str(s): {"n_windows": int(c)}
                                            for s, c in zip(names, counts)}
    scene_mean = {}
    for metric, v in values.items():
        means = per_scene_means(v, scenes)
        for scene, mean in means.items():
            per_scene[scene][metric] = mean
        scene_mean[metric] = _mean(np.array([np.nan if m is None else m for m in means.values()]))
    return {"n_windows": n, "n_scenes": len(names),
            "window_mean": {metric: _mean(v) for metric, v in values.items()},
            "scene_mean": scene_mean, "per_scene": per_scene}


def trajectory_scores(pred: Any, truth: Any, miss_threshold: Any, *, goals: Any | None = None,
                      weights: Any | None = None, log_pdf_floor: float = LOG_PDF_FLOOR
                      ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Every metric that needs only the paths: per window (N,) each, `min_ade_fde`'s four,
    'ade_best_endpoint', 'miss' (at `miss_threshold`, one or (N,)), 'kde_nll' (mean over steps) and
    'kde_degenerate' (share of steps whose KDE is degenerate, scored at the floor); and the NLL per
    window and step (N, T). `goals` (N, K, 2) are the endpoints of FDE, best endpoint and miss."""
    log_pdf, degenerate = kde_log_pdf(pred, truth, weights)  # (N, T) each
    nll = clipped_nll(log_pdf, degenerate, log_pdf_floor)  # (N, T)
    per_window = {**min_ade_fde(pred, truth, goals),
                  "ade_best_endpoint": best_endpoint_ade(pred, truth, goals),
                  "miss": miss(pred, truth, miss_threshold, goals), "kde_nll": nll.mean(axis=1),
                  "kde_degenerate": degenerate.mean(axis=1)}
    return per_window, nll
