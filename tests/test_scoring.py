"""Every metric of `pipeline.harness.scoring` on hand-made numbers (the arithmetic is in the
comments), plus the edge cases: ties, K = 1, degenerate KDEs, positions on pixel boundaries and
off the mask, windows that share no frames, bad shapes; and S-GAN's sequences of a small S-GAN
file, from our windows against S-GAN's loader rule stated again here."""

import json
import math

import numpy as np
import pytest
from scipy import linalg
from scipy.stats import gaussian_kde

from pipeline.benchmarks.base import class_values
from pipeline.benchmarks.ethucy import sgan_window_rows
from pipeline.benchmarks.short_term import read_rows
from pipeline.config.short_term import ShortTermParams
from pipeline.harness import scoring
from pipeline.harness.metrics import window_errors
from pipeline.harness.scoring import (ALLOWED, FORBIDDEN, OUTSIDE, ade_sgan_sequence, aggregate,
                                      best_endpoint_ade, collisions,
                                      fde_sgan_sequence, forbidden_share, kde_log_pdf, kde_nll,
                                      mask_pixels, min_ade_fde, miss, one_sample_ade_fde,
                                      per_scene_means, scene_compliance, sequence_joint_min,
                                      sgan_sequence_scores, sgan_sequences, trajectory_scores)

# The 3-4-5 example of tests/test_metrics.py. Window 0: sample 0 errors (0, 4) -> ADE 2, FDE 4;
# sample 1 errors (3, 3) -> ADE 3, FDE 3. Window 1: sample 0 errors (5, 10) -> ADE 7.5, FDE 10;
# sample 1 exact.
TRUTH = np.array([
    [[1.0, 0.0], [2.0, 0.0]],
    [[3.0, 4.0], [6.0, 8.0]],
])  # (N=2, T=2, 2)
PRED = np.array([
    [[[1.0, 0.0], [2.0, 4.0]], [[1.0, 3.0], [2.0, 3.0]]],
    [[[0.0, 0.0], [0.0, 0.0]], [[3.0, 4.0], [6.0, 8.0]]],
])  # (N=2, K=2, T=2, 2)


# ---------------------------------------------------------------------------------------------
# Displacement errors


def test_min_ade_fde_independent_and_joint():
    got = min_ade_fde(PRED, TRUTH)
    np.testing.assert_array_equal(got["ade"], [2.0, 0.0])  # min(2, 3), min(7.5, 0)
    np.testing.assert_array_equal(got["fde"], [3.0, 0.0])  # min(4, 3): another sample than ADE's
    np.testing.assert_array_equal(got["ade_joint"], [2.0, 0.0])
    np.testing.assert_array_equal(got["fde_joint"], [4.0, 0.0])  # FDE of sample 0, best on ADE


def test_min_ade_fde_measures_fde_on_goals_where_given():
    # Goals (N, K, 2): window 0 sample 0 exact (FDE 0), sample 1 5 away; window 1 both 5 away.
    goals = np.array([[[2.0, 0.0], [5.0, 4.0]], [[3.0, 4.0], [9.0, 4.0]]])
    got = min_ade_fde(PRED, TRUTH, goals)
    np.testing.assert_array_equal(got["ade"], [2.0, 0.0])  # paths as before
    np.testing.assert_array_equal(got["fde"], [0.0, 5.0])  # on the goals, not the last points
    np.testing.assert_array_equal(got["fde_joint"], [0.0, 5.0])  # goal of the best-ADE sample
    errors = window_errors(PRED, TRUTH, goals)  # exactly the in-memory metric
    for key, value in (("ade", errors.ade), ("fde", errors.fde), ("ade_joint", errors.ade),
                       ("fde_joint", errors.fde_joint)):
        np.testing.assert_array_equal(got[key], value)
    with pytest.raises(ValueError, match=r"goals must be \(N, K, 2\)"):
        min_ade_fde(PRED, TRUTH, goals[:, :, 0])


def test_best_endpoint_ade_takes_the_path_of_the_best_endpoint():
    # Window 0: endpoint errors 4 and 3 -> sample 1, ADE 3 (> min-ADE 2). Window 1: sample 1, 0.
    np.testing.assert_array_equal(best_endpoint_ade(PRED, TRUTH), [3.0, 0.0])


def test_best_endpoint_ties_go_to_the_first_sample():
    truth = np.array([[[0.0, 0.0], [0.0, 0.0]]])  # (1, 2, 2)
    # Both endpoints 5 away; sample 0 errors (1, 5) -> ADE 3, sample 1 errors (0, 5) -> ADE 2.5.
    pred = np.array([[[[1.0, 0.0], [3.0, 4.0]], [[0.0, 0.0], [4.0, 3.0]]]])  # (1, 2, 2, 2)
    np.testing.assert_array_equal(best_endpoint_ade(pred, truth), [3.0])
    np.testing.assert_array_equal(best_endpoint_ade(pred[:, ::-1], truth), [2.5])


def test_single_sample_best_endpoint_is_its_ade():
    np.testing.assert_array_equal(best_endpoint_ade(PRED[:, :1], TRUTH), [2.0, 7.5])


def test_miss_is_strictly_beyond_the_threshold():
    # min-FDE 3 and 0: at threshold 3 window 0 is a hit (not > 3), just below it a miss.
    np.testing.assert_array_equal(miss(PRED, TRUTH, 3.0), [False, False])
    np.testing.assert_array_equal(miss(PRED, TRUTH, 2.999), [True, False])
    np.testing.assert_array_equal(miss(PRED[:, :1], TRUTH, 5.0), [False, True])  # FDE 4, 10
    with pytest.raises(ValueError, match="threshold"):
        miss(PRED, TRUTH, -1.0)


def test_miss_takes_one_threshold_per_window():
    # min-FDE 3 and 0: window 0 misses at 2.5 (not at 3), window 1 hits at any threshold >= 0.
    np.testing.assert_array_equal(miss(PRED, TRUTH, np.array([2.5, 0.0])), [True, False])
    np.testing.assert_array_equal(miss(PRED, TRUTH, np.array([3.0, 0.0])), [False, False])
    with pytest.raises(ValueError, match=r"threshold must be \(2,\), got shape \(3,\)"):
        miss(PRED, TRUTH, np.ones(3))
    with pytest.raises(ValueError, match="threshold"):
        miss(PRED, TRUTH, np.array([1.0, np.nan]))


def test_goals_are_the_endpoints_of_best_endpoint_and_miss():
    # Goals: window 0 sample 0 exact, sample 1 5 away -> sample 0 (ADE 2), min-FDE 0;
    # window 1 sample 0 5 away, sample 1 (5, 0) away: a tie -> sample 0 (ADE 7.5), min-FDE 5.
    goals = np.array([[[2.0, 0.0], [5.0, 4.0]], [[3.0, 4.0], [9.0, 4.0]]])
    np.testing.assert_array_equal(best_endpoint_ade(PRED, TRUTH, goals), [2.0, 7.5])
    np.testing.assert_array_equal(miss(PRED, TRUTH, 4.0, goals), [False, True])
    with pytest.raises(ValueError, match=r"goals must be \(N, K, 2\) = \(2, 2, 2\)"):
        best_endpoint_ade(PRED, TRUTH, goals[:, :1])


@pytest.mark.parametrize("metric", [min_ade_fde, best_endpoint_ade, kde_nll,
                                    lambda p, t: miss(p, t, 1.0)])
def test_bad_shapes_are_named(metric):
    with pytest.raises(ValueError, match=r"\(N, K, T, 2\).*got shape \(2, 2, 2\)"):
        metric(PRED[:, 0], TRUTH)
    with pytest.raises(ValueError, match=r"ground truth.*\(2, 2, 2\).*got shape \(2, 3, 2\)"):
        metric(PRED, np.zeros((2, 3, 2)))


# ---------------------------------------------------------------------------------------------
# One sample


def test_one_sample_is_the_mean_over_samples_on_the_3_4_5_example():
    # Window 0: ADE (2, 3) -> 2.5, FDE (4, 3) -> 3.5; window 1: ADE (7.5, 0) -> 3.75, FDE (10, 0)
    # -> 5. Above min-ADE (2, 0) and min-FDE (3, 0).
    got = one_sample_ade_fde(PRED, TRUTH)
    assert list(got) == ["ade_one_sample", "fde_one_sample"]
    np.testing.assert_array_equal(got["ade_one_sample"], [2.5, 3.75])
    np.testing.assert_array_equal(got["fde_one_sample"], [3.5, 5.0])
    # Goals: window 0 (0, 5) -> 2.5, window 1 (5, 5) -> 5; the ADE stays on the paths.
    goals = np.array([[[2.0, 0.0], [5.0, 4.0]], [[3.0, 4.0], [9.0, 4.0]]])
    with_goals = one_sample_ade_fde(PRED, TRUTH, goals)
    np.testing.assert_array_equal(with_goals["fde_one_sample"], [2.5, 5.0])
    np.testing.assert_array_equal(with_goals["ade_one_sample"], [2.5, 3.75])


def test_one_sample_of_a_deterministic_model_is_its_best_of_k():
    # K copies of one path (the constant-velocity model): every protocol gives the same number.
    pred = np.repeat(PRED[:, :1], 20, axis=1)  # (2, 20, 2, 2)
    got, best = one_sample_ade_fde(pred, TRUTH), min_ade_fde(pred, TRUTH)
    np.testing.assert_array_equal(got["ade_one_sample"], best["ade"])  # (2, 7.5)
    np.testing.assert_array_equal(got["fde_one_sample"], best["fde"])  # (4, 10)
    with pytest.raises(ValueError, match=r"predictions must be \(N, K, T, 2\)"):
        one_sample_ade_fde(PRED[0], TRUTH)


# ---------------------------------------------------------------------------------------------
# S-GAN's sequence protocol


def test_sequence_joint_min_one_sample_for_the_whole_sequence():
    # Windows 0, 1 in one sequence: per window the minima 1 and 2 (mean 1.5) come from samples 0
    # and 1; summed over the sequence the samples give 1 + 3 = 4 and 4 + 2 = 6: min 4, / 2 = 2.
    errors = np.array([[1.0, 4.0], [3.0, 2.0]])  # (N=2, K=2)
    assert errors.min(axis=1).mean() == 1.5
    assert sequence_joint_min(errors, [0, 0]) == 2.0
    assert sequence_joint_min(errors, [0, 1]) == 1.5  # a sequence per window: the per-window mean


def test_sequence_joint_min_two_sequences():
    # Sequence a (windows 0, 2): samples 1 + 3 = 4, 4 + 2 = 6 -> 4. Sequence b (windows 1, 3):
    # 5 + 2 = 7, 1 + 2 = 3 -> 3. (4 + 3) / 4 windows = 1.75; per window (1 + 1 + 2 + 2) / 4 = 1.5.
    errors = np.array([[1.0, 4.0], [5.0, 1.0], [3.0, 2.0], [2.0, 2.0]])  # (N=4, K=2)
    sequences = np.array(["a", "b", "a", "b"])
    assert sequence_joint_min(errors, sequences) == 1.75
    assert errors.min(axis=1).mean() == 1.5
    order = [3, 0, 2, 1]  # the windows' order does not matter
    assert sequence_joint_min(errors[order], sequences[order]) == 1.75


def test_with_one_sample_every_protocol_agrees():
    # K = 1: (2 + 7.5) / 2 = 4.75 whatever the sequences, as min-ADE and best-endpoint ADE.
    pred = PRED[:, :1]
    for sequences in ([0, 0], [0, 1]):
        assert ade_sgan_sequence(pred, TRUTH, sequences) == 4.75
        assert fde_sgan_sequence(pred, TRUTH, sequences) == 7.0  # (4 + 10) / 2
    assert min_ade_fde(pred, TRUTH)["ade"].mean() == 4.75
    assert best_endpoint_ade(pred, TRUTH).mean() == 4.75
    assert sequence_joint_min([[1.0], [3.0], [5.0], [2.0]], [0, 1, 0, 2]) == 2.75  # 11 / 4


def test_ade_and_fde_of_sgan_sequences_on_the_3_4_5_example():
    # Per sample: window 0 ADE (2, 3), FDE (4, 3); window 1 ADE (7.5, 0), FDE (10, 0).
    # One sequence: ADE sums (9.5, 3) -> 3 / 2 = 1.5 (per window: 1); FDE sums (14, 3) -> 1.5.
    assert ade_sgan_sequence(PRED, TRUTH, [0, 0]) == 1.5
    assert fde_sgan_sequence(PRED, TRUTH, [0, 0]) == 1.5
    # A sequence per window: ADE (2 + 0) / 2 = 1 from sample 0 of window 0, FDE (3 + 0) / 2 = 1.5
    # from its sample 1: each is minimised on its own (the joint FDE, 2, is not it).
    assert ade_sgan_sequence(PRED, TRUTH, [0, 1]) == 1.0
    assert fde_sgan_sequence(PRED, TRUTH, [0, 1]) == 1.5
    assert min_ade_fde(PRED, TRUTH)["fde_joint"].mean() == 2.0
    # Goals: window 0 (0, 5), window 1 (5, 5); one sequence: sums (5, 10) -> 5 / 2.
    goals = np.array([[[2.0, 0.0], [5.0, 4.0]], [[3.0, 4.0], [9.0, 4.0]]])
    assert fde_sgan_sequence(PRED, TRUTH, [0, 0], goals) == 2.5
    with pytest.raises(ValueError, match=r"sequences must be \(2,\), got shape \(3,\)"):
        ade_sgan_sequence(PRED, TRUTH, [0, 0, 0])


def test_sgan_sequence_scores_over_all_windows_and_per_scene():
    # Scene a: windows 0, 1 of the 3-4-5 example in one sequence (ADE 1.5, FDE 1.5 as above);
    # scene b: window 0 again, alone (ADE 2, FDE 3). All: ADE (3 + 2) / 3, FDE (3 + 3) / 3.
    pred, truth = PRED[[0, 1, 0]], TRUTH[[0, 1, 0]]
    got = sgan_sequence_scores(pred, truth, [0, 0, 1], ["a", "a", "b"])
    assert got == {"all": {"ade_sgan_sequence": 5 / 3, "fde_sgan_sequence": 2.0},
                   "per_scene": {"a": {"ade_sgan_sequence": 1.5, "fde_sgan_sequence": 1.5},
                                 "b": {"ade_sgan_sequence": 2.0, "fde_sgan_sequence": 3.0}}}
    with pytest.raises(ValueError, match="a sequence spans two scenes"):
        sgan_sequence_scores(pred, truth, [0, 0, 0], ["a", "a", "b"])


def test_sgan_sequences_key_scene_and_first_frame():
    # Sorted keys (a, 10), (a, 20), (b, 0), (b, 10) are sequences 0 .. 3.
    got = sgan_sequences(["b", "a", "b", "a", "b"], np.array([10, 10, 10, 20, 0]))
    np.testing.assert_array_equal(got, [3, 0, 3, 1, 2])
    with pytest.raises(ValueError, match="first_frame must be integers"):
        sgan_sequences(["a"], np.array([1.5]))


SEQ_LEN = 20  # S-GAN's obs_len 8 + pred_len 12
# (pedestrian, first frame, last frame) of two S-GAN files, frames 10 apart, 0 .. 290 (30 frames).
# students001: ped 1 throughout; ped 2 the first 20 frames; ped 5 21 frames from 20; ped 3 from 50
# to the end; ped 4 16 frames, never a whole run. Runs from 10 and 40 hold ped 1 alone (dropped).
# students003: the same frame numbers, peds 1 and 2 only: sequences of its own.
SGAN_FILES = {"students001": [(1, 0, 290), (2, 0, 190), (3, 50, 290), (4, 100, 250),
                              (5, 20, 220)],
              "students003": [(1, 0, 290), (2, 0, 190)]}


def write_sgan_file(path, peds) -> None:
    """S-GAN's format: `frame ped x y`, tab-separated, rows by frame, then pedestrian."""
    rows = sorted((frame, ped) for ped, first, last in peds for frame in range(first, last + 1, 10))
    path.write_text("".join(f"{frame}.0\t{ped}.0\t{0.1 * ped:.2f}\t{frame / 100:.2f}\n"
                            for frame, ped in rows))


def sgan_loader_sequences(rows: np.ndarray) -> list[tuple[float, frozenset]]:
    """S-GAN's loader rule, said again: for every start among the file's sorted distinct frames
    with 20 frames from there, the pedestrians present in all 20 form a sequence, kept when there
    is more than one (min_ped = 1). (start frame, pedestrians) of each kept sequence."""
    frames = sorted(set(rows[:, 0].tolist()))
    present = {}
    for frame, ped in rows[:, :2].tolist():
        present.setdefault(ped, set()).add(frame)
    out = []
    for start in range(len(frames) - SEQ_LEN + 1):
        run = frames[start:start + SEQ_LEN]
        peds = frozenset(p for p, seen in present.items() if all(f in seen for f in run))
        if len(peds) > 1:
            out.append((run[0], peds))
    return out


def test_sgan_sequences_of_our_windows_are_sgan_loaders(tmp_path):
    params = ShortTermParams()
    assert params.window_length == SEQ_LEN and params.ethucy_min_agents == 2  # "> 1"
    expected, scene_id, first_frame, peds = set(), [], [], []
    for name, file_peds in SGAN_FILES.items():
        path = tmp_path / f"{name}.txt"
        write_sgan_file(path, file_peds)
        rows = read_rows(path, "frame ped x y")
        expected |= {(name, start, members) for start, members in sgan_loader_sequences(rows)}
        windows = sgan_window_rows(rows, params.window_length, params.ethucy_min_agents, path)
        scene_id += [name] * len(windows)
        first_frame.append(rows[windows[:, 0], 0].astype(np.int64))
        peds.append(rows[windows[:, 0], 1])
    first_frame, peds = np.concatenate(first_frame), np.concatenate(peds)
    sequences = sgan_sequences(np.array(scene_id), first_frame)
    got = set()
    for s in np.unique(sequences):
        at = np.flatnonzero(sequences == s)
        (scene,), (start,) = {scene_id[i] for i in at}, set(first_frame[at].tolist())
        got.add((scene, start, frozenset(peds[at].tolist())))
    assert got == expected
    assert len(sequences) == sum(len(members) for _, _, members in expected)  # no window twice
    # Spot checks: students001 starts 0 .. 100 but 10 and 40 (ped 1 alone); 0 holds peds 1, 2.
    starts = sorted(start for scene, start, _ in expected if scene == "students001")
    assert starts == [0, 20, 30, 50, 60, 70, 80, 90, 100]
    assert ("students001", 0, frozenset({1.0, 2.0})) in expected
    assert {s for scene, s, _ in expected if scene == "students003"} == {0}


# ---------------------------------------------------------------------------------------------
# KDE negative log-likelihood

# Three samples (-1, -1), (1, -1), (0, 2): mean (0, 0); with K - 1 = 2 in the denominator
# var x = (1 + 1 + 0) / 2 = 1, var y = (1 + 1 + 4) / 2 = 3, cov = (1 - 1 + 0) / 2 = 0. Scott's
# factor 3^(-1/6), so the kernel covariance is H = diag(3^(-1/3), 3^(2/3)), det H = 3^(1/3).
# At the truth (0, 0) every kernel's quadratic form is the same, 4 * 3^(-2/3):
#   (-1, -1): 1 / 3^(-1/3) + 1 / 3^(2/3) = 3^(1/3) + 3^(-2/3) = 4 * 3^(-2/3); (0, 2): 4 / 3^(2/3).
# log pdf = -log(2 pi) - log(det H) / 2 - 4 * 3^(-2/3) / 2 = -1.8379 - 0.1831 - 0.9615 = -2.9825.
TRIANGLE = np.array([[-1.0, -1.0], [1.0, -1.0], [0.0, 2.0]])  # (K=3, 2)
TRIANGLE_LOG_PDF = -math.log(2 * math.pi) - math.log(3) / 6 - 2 * 3 ** (-2 / 3)


def test_kde_nll_by_hand():
    pred = TRIANGLE[None, :, None]  # (1, 3, 1, 2)
    nll = kde_nll(pred, np.zeros((1, 1, 2)))
    assert nll.shape == (1, 1)
    assert nll[0, 0] == pytest.approx(-TRIANGLE_LOG_PDF, abs=1e-12)
    assert nll[0, 0] == pytest.approx(2.98248, abs=1e-5)
    scipy_value = gaussian_kde(TRIANGLE.T).logpdf([0.0, 0.0])[0]
    assert scipy_value == pytest.approx(TRIANGLE_LOG_PDF, abs=1e-12)


def random_case(n=40, k=20, t=6, seed=0):
    rng = np.random.default_rng(seed)
    pred = rng.normal(size=(n, k, t, 2)) * [4.0, 1.0] + rng.normal(size=(n, 1, t, 2)) * 10
    pred[..., 1] += 0.7 * pred[..., 0]  # correlated x and y
    truth = pred.mean(axis=1) + rng.normal(size=(n, t, 2)) * 3  # (N, T, 2)
    return pred, truth, rng


def scipy_log_pdf(pred, truth, weights=None):
    n, _, t, _ = pred.shape
    return np.array([[gaussian_kde(pred[i, :, j].T, weights=None if weights is None else weights[i])
                      .logpdf(truth[i, j])[0] for j in range(t)] for i in range(n)])


def test_vectorised_kde_matches_scipy():
    pred, truth, _ = random_case()
    log_pdf, degenerate = kde_log_pdf(pred, truth)
    assert not degenerate.any()
    np.testing.assert_allclose(log_pdf, scipy_log_pdf(pred, truth), rtol=0, atol=1e-9)


def test_weighted_kde_matches_scipy():
    pred, truth, rng = random_case(seed=1)
    weights = rng.uniform(0.1, 3.0, (len(pred), pred.shape[1]))  # (N, K), not normalised
    log_pdf, _ = kde_log_pdf(pred, truth, weights)
    np.testing.assert_allclose(log_pdf, scipy_log_pdf(pred, truth, weights), rtol=0, atol=1e-9)
    assert not np.allclose(log_pdf, kde_log_pdf(pred, truth)[0])  # the weights matter


def test_zero_weight_drops_a_sample():
    # scipy returns NaN with a zero weight; here the sample simply does not count.
    pred, truth, rng = random_case(n=5, seed=2)
    weights = rng.uniform(0.5, 1.0, (5, 20))
    weights[:, :4] = 0.0
    log_pdf, _ = kde_log_pdf(pred, truth, weights)
    np.testing.assert_allclose(log_pdf, scipy_log_pdf(pred[:, 4:], truth, weights[:, 4:]),
                               rtol=0, atol=1e-9)


def test_log_pdf_is_clipped_at_the_floor():
    pred = TRIANGLE[None, :, None]  # (1, 3, 1, 2)
    far = np.array([[[100.0, 100.0]]])  # log pdf about -1.7e4
    assert kde_log_pdf(pred, far)[0][0, 0] < -1000
    assert kde_nll(pred, far)[0, 0] == 20.0
    assert kde_nll(pred, far, log_pdf_floor=-5.0)[0, 0] == 5.0
    # Near the samples the floor does not bind: 2.98 < 5.
    near = kde_nll(pred, np.zeros((1, 1, 2)), log_pdf_floor=-5.0)[0, 0]
    assert near == pytest.approx(2.98248, abs=1e-5)


@pytest.mark.parametrize("samples", [
    np.zeros((20, 2)) + [3.1, -7.3],  # all identical (not exactly representable: rounding)
    np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.5, 3.5]]) * 0.1,  # one diagonal line
    np.array([[0.0, 5.0], [1.0, 5.0], [7.0, 5.0]]),  # a horizontal line
    np.array([[0.0, 0.0], [1.0, 2.0]]),  # K = 2: always a line
    np.array([[4.0, 2.0]]),  # K = 1, as a deterministic model
])
def test_degenerate_kde_scores_the_floor_whatever_the_truth(samples):
    pred = samples[None, :, None]  # (1, K, 1, 2)
    for truth in (samples[:1], samples[:1] + 0.01):  # on a sample, and beside it
        log_pdf, degenerate = kde_log_pdf(pred, truth[None])
        assert degenerate[0, 0] and np.isnan(log_pdf[0, 0])
        assert kde_nll(pred, truth[None])[0, 0] == 20.0
        assert kde_nll(pred, truth[None], log_pdf_floor=-7.0)[0, 0] == 7.0


def test_scipy_cannot_fit_identical_samples():
    # Why the degenerate rule exists: scipy raises where Trajectron++ then returns NaN.
    with pytest.raises((linalg.LinAlgError, ValueError)):
        gaussian_kde(np.zeros((2, 20)))


def test_degenerate_steps_do_not_affect_the_others():
    pred, truth, _ = random_case(n=3, t=4, seed=3)
    pred[1, :, 2] = pred[1, 0, 2]  # window 1, step 2: all samples at one point
    log_pdf, degenerate = kde_log_pdf(pred, truth)
    expected = np.zeros((3, 4), dtype=bool)
    expected[1, 2] = True
    np.testing.assert_array_equal(degenerate, expected)
    reference = scipy_log_pdf(np.delete(pred, 1, axis=0), np.delete(truth, 1, axis=0))
    np.testing.assert_allclose(np.delete(log_pdf, 1, axis=0), reference, rtol=0, atol=1e-9)


def test_only_two_positive_weights_are_degenerate():
    pred, truth, _ = random_case(n=1, k=5, t=1, seed=4)
    weights = np.array([[0.0, 1.0, 0.0, 2.0, 0.0]])
    assert kde_log_pdf(pred, truth, weights)[1].all()
    with pytest.raises(ValueError, match=r"weights must be \(N, K\) = \(1, 5\), got shape \(1, 4"):
        kde_log_pdf(pred, truth, weights[:, :4])


# ---------------------------------------------------------------------------------------------
# Scene compliance

# A 3 x 4 mask (rows y, columns x) with class values; structure = 3 and tree = 5 are forbidden.
MASK = np.array([
    [1, 1, 3, 3],
    [2, 5, 4, 1],
    [1, 1, 1, 1],
])
FORBIDDEN_VALUES = (3, 5)


def test_forbidden_classes_are_structure_and_tree():
    assert class_values() == FORBIDDEN_VALUES
    with pytest.raises(ValueError, match="unknown class"):
        class_values(("lava",))


def test_pixel_lookup_rounds_to_pixel_centres():
    # Scale 1: integer coordinates are pixel centres, pixel i covers [i - 0.5, i + 0.5).
    xs = np.array([0.0, 0.49, 0.5, -0.5, -0.51, 3.49, 3.5])
    np.testing.assert_array_equal(mask_pixels(np.stack([xs, xs], -1), 1.0)[:, 0],
                                  [0, 0, 1, 0, -1, 3, 4])
    # Scale 1/2 (mask at half the resolution): mask pixel j covers [2j - 0.5, 2j + 1.5).
    xs = np.array([-0.5, 1.49, 1.5, 3.49, 3.5])
    np.testing.assert_array_equal(mask_pixels(np.stack([xs, xs], -1), 0.5)[:, 0], [0, 0, 1, 1, 2])


def test_scene_compliance_by_hand():
    positions = np.array([
        [2.0, 0.0],  # column 2, row 0: 3 structure -> forbidden
        [0.5, 1.0],  # on the boundary of columns 0 | 1 -> column 1, row 1: 5 tree -> forbidden
        [0.49, 1.0],  # column 0, row 1: 2 road -> allowed
        [3.0, 2.49],  # column 3, row 2: 1 pavement -> allowed
        [3.0, 2.5],  # row 3 of a 3-row mask -> outside
        [3.5, 0.0],  # column 4 of a 4-column mask -> outside
        [-0.51, 0.0],  # column -1 -> outside
    ])  # (7, 2)
    status = scene_compliance(positions, np.zeros(7, dtype=int), [MASK], FORBIDDEN_VALUES, 1.0)
    np.testing.assert_array_equal(status, [FORBIDDEN, FORBIDDEN, ALLOWED, ALLOWED, OUTSIDE, OUTSIDE,
                                           OUTSIDE])
    # 2 forbidden of 4 inside (the 2 outside do not count).
    np.testing.assert_array_equal(forbidden_share(status[None]), [0.5])


def test_scene_compliance_per_scene_and_scale():
    # Scene 0 at scale 1: (2, 0) -> column 2, row 0: 3 structure -> forbidden.
    # Scene 1: MASK at half its image's resolution, pixel floor((x + 0.5) / 2):
    #   (4, 2) -> column 2, row 1: 4 terrain -> allowed;
    #   (1.4, 1.4) -> column 0, row 0: 1 pavement -> allowed;
    #   (5.5, -0.5) -> column 3, row 0: 3 -> forbidden; (50, 0) -> column 25 -> outside.
    positions = np.array([
        [[[2.0, 0.0]], [[2.0, 0.0]]],  # window 0, scene 0: K = 2, T = 1
        [[[4.0, 2.0]], [[1.4, 1.4]]],  # window 1, scene 1
        [[[5.5, -0.5]], [[50.0, 0.0]]],  # window 2, scene 1: forbidden, outside
    ])  # (N=3, K=2, T=1, 2)
    status = scene_compliance(positions, np.array([0, 1, 1]), [MASK, MASK], FORBIDDEN_VALUES,
                              [1.0, 0.5])
    assert status.shape == (3, 2, 1)
    np.testing.assert_array_equal(status[..., 0], [[FORBIDDEN, FORBIDDEN], [ALLOWED, ALLOWED],
                                                   [FORBIDDEN, OUTSIDE]])
    np.testing.assert_array_equal(forbidden_share(status), [1.0, 0.0, 1.0])


def test_share_is_nan_when_nothing_is_inside():
    status = scene_compliance(np.array([[[-5.0, 0.0], [9.0, 9.0]]]), np.array([0]), [MASK],
                              FORBIDDEN_VALUES)  # (1, 2) both off the mask
    np.testing.assert_array_equal(status, [[OUTSIDE, OUTSIDE]])
    assert np.isnan(forbidden_share(status)[0])


def test_scene_compliance_bad_inputs():
    with pytest.raises(ValueError, match=r"positions must be \(\.\.\., 2\), got shape \(2, 3\)"):
        scene_compliance(np.zeros((2, 3)), np.zeros(2, dtype=int), [MASK], FORBIDDEN_VALUES)
    with pytest.raises(ValueError, match=r"leading part of \(2, 5\), got shape \(5,\)"):
        scene_compliance(np.zeros((2, 5, 2)), np.zeros(5, dtype=int), [MASK], FORBIDDEN_VALUES)
    with pytest.raises(ValueError, match="scene_index runs 0..1, masks has 1"):
        scene_compliance(np.zeros((2, 2)), np.array([0, 1]), [MASK], FORBIDDEN_VALUES)


# ---------------------------------------------------------------------------------------------
# Collisions


def collision_case():
    """Five windows, K = 2, T = 3, for threshold 1 (positions per step, frames below):
    w0 (scene a, agent 1, frames 10 20 30) and w1 (scene a, agent 2, frames 20 30 40) share frames
    20 and 30 (w0 steps 1, 2 = w1 steps 0, 1). Sample 0 at frame 20: (0, 0) and (0.5, 0), 0.5 apart:
    a collision. Sample 1: 5 apart at frames 20 and 30; w0 at frame 10 and w1 at frame 40 are both
    at (9, 9), but those frames are not shared: no collision. Truths: 1 apart at frame 20 (not < 1),
    3 at frame 30: none.
    w2 (scene a, agent 1 like w0, frames 20 30 40) shares every frame with w1. Frame 20: sample 0
    (4.5, 0) vs (0.5, 0): 4; sample 1 (4.5, 0) vs (5, 0): 0.5, a collision. Frames 30, 40: >= 3
    apart. Truths 3 and 4 apart. With w0 it is never compared (same agent).
    w3 (scene b, frames 10 20 30) has w0's positions, in another scene: alone.
    w4 (scene a, agent 3, frames 100 110 120) shares no frame: alone.
    """
    w0 = [[9, 9], [0, 0], [0, 3]]
    pred = np.array([
        [w0, w0],
        [[[0.5, 0], [20, 20], [30, 30]], [[5, 0], [5, 3], [9, 9]]],
        [[[4.5, 0], [5, 6], [40, 40]], [[4.5, 0], [5, 6], [40, 40]]],
        [w0, w0],
        [w0, w0],
    ], dtype=float)  # (N=5, K=2, T=3, 2)
    truth = np.array([w0, [[1, 0], [3, 3], [50, 50]], [[4, 0], [3, 7], [60, 60]], w0, w0],
                     dtype=float)  # (5, 3, 2)
    frames = np.array([[10, 20, 30], [20, 30, 40], [20, 30, 40], [10, 20, 30], [100, 110, 120]])
    return pred, truth, np.array(["a", "a", "a", "b", "a"]), frames, np.array([1, 2, 1, 2, 3])


def test_collisions_by_hand():
    pred, truth, scene, frames, agents = collision_case()
    # w0 collides in sample 0 (with w1); w1 in sample 0 (w0) and sample 1 (w2); w2 in sample 1 (w1).
    got = collisions(pred, truth, scene, frames, 1.0, agents=agents)
    np.testing.assert_array_equal(got.pred_share, [0.5, 1.0, 0.5, 0.0, 0.0])
    np.testing.assert_array_equal(got.truth, [False, False, False, False, False])
    np.testing.assert_array_equal(got.copresent, [True, True, True, False, False])


def test_truth_collision_is_strictly_below_the_threshold():
    pred, truth, scene, frames, agents = collision_case()
    # w0 and w1's truths are exactly 1.0 apart at frame 20: a collision only for a threshold > 1.
    np.testing.assert_array_equal(collisions(pred, truth, scene, frames, 1.01, agents=agents).truth,
                                  [True, True, False, False, False])


def test_two_windows_sharing_one_frame():
    # Frames (0, 1, 2) and (2, 3, 4) share frame 2 only: step 2 of the first, step 0 of the second.
    # K = 1; there they are 0.6 apart (< 1); everywhere else they sit on the same point (0, 0).
    first = np.array([[[0.0, 0.0], [0.0, 0.0], [0.0, 0.6]]])  # (K=1, T=3, 2)
    second = np.zeros((1, 3, 2))
    pred = np.stack([first, second])  # (2, 1, 3, 2)
    frames = np.array([[0, 1, 2], [2, 3, 4]])
    got = collisions(pred, pred[:, 0], np.array([0, 0]), frames, 1.0, agents=np.array([5, 6]))
    np.testing.assert_array_equal(got.pred_share, [1.0, 1.0])
    np.testing.assert_array_equal(got.truth, [True, True])
    got = collisions(pred, pred[:, 0], np.array([0, 0]), frames, 0.5, agents=np.array([5, 6]))
    np.testing.assert_array_equal(got.pred_share, [0.0, 0.0])  # 0.6 is not < 0.5
    np.testing.assert_array_equal(got.copresent, [True, True])


def test_same_agent_never_collides_with_itself():
    pred, truth, scene, frames, agents = collision_case()
    truth[2, 1] = truth[0, 2]  # w2's truth on w0's at frame 30 (3 from w1's (3, 3))
    assert not collisions(pred, truth, scene, frames, 1.0, agents=agents).truth[2]
    assert collisions(pred, truth, scene, frames, 1.0, agents=np.arange(5)).truth[2]


def brute_force(pred, truth, scene, frames, threshold, agents):
    n, k, t, _ = pred.shape
    pred_hit, truth_hit = np.zeros((n, k), bool), np.zeros(n, bool)
    for a in range(n):
        for b in range(n):
            if a == b or scene[a] != scene[b] or agents[a] == agents[b]:
                continue
            for i in range(t):
                for j in range(t):
                    if frames[a, i] != frames[b, j]:
                        continue
                    truth_hit[a] |= np.linalg.norm(truth[a, i] - truth[b, j]) < threshold
                    distance = np.linalg.norm(pred[a, :, i] - pred[b, :, j], axis=-1)  # (K,)
                    pred_hit[a] |= distance < threshold
    return pred_hit.mean(axis=1), truth_hit


def test_collisions_match_brute_force_in_small_chunks(monkeypatch):
    rng = np.random.default_rng(0)
    n, k, t = 60, 4, 5
    scene = rng.integers(0, 3, n)
    agents = rng.integers(0, 12, n)
    start = rng.integers(0, 15, n)
    frames = (start[:, None] + np.arange(t)) * 10  # (N, T)
    truth = rng.uniform(0, 6, (n, t, 2))
    pred = truth[:, None] + rng.normal(0, 1.0, (n, k, t, 2))
    expected_share, expected_truth = brute_force(pred, truth, scene, frames, 0.8, agents)
    assert 0 < expected_share.mean() < 1 and 0 < expected_truth.mean() < 1  # a case with both
    for chunk in (7, 10**9):  # many chunks (7 pairs each, or one group), and one
        monkeypatch.setattr(scoring, "PAIR_CHUNK", chunk)
        got = collisions(pred, truth, scene, frames, 0.8, agents=agents)
        np.testing.assert_array_equal(got.pred_share, expected_share)
        np.testing.assert_array_equal(got.truth, expected_truth)


def test_collisions_bad_inputs():
    pred, truth, scene, frames, agents = collision_case()
    with pytest.raises(ValueError, match=r"frames must be \(N, T\) = \(5, 3\).*got shape \(5, 2\)"):
        collisions(pred, truth, scene, frames[:, :2], 1.0, agents=agents)
    with pytest.raises(ValueError, match="strictly increasing"):
        collisions(pred, truth, scene, frames[:, ::-1], 1.0, agents=agents)
    with pytest.raises(ValueError, match=r"agents must be \(5,\), got shape \(4,\)"):
        collisions(pred, truth, scene, frames, 1.0, agents=agents[:4])
    with pytest.raises(ValueError, match=r"scene must be \(5,\), got shape \(5, 1\)"):
        collisions(pred, truth, scene[:, None], frames, 1.0, agents=agents)


# ---------------------------------------------------------------------------------------------
# Aggregation


def test_per_scene_means_leave_nan_out():
    # Scene a: (1 + 2) / 2 = 1.5; scene b: 3 (its NaN left out); scene c: only NaN -> None.
    means = per_scene_means([1.0, 2.0, 3.0, np.nan, np.nan], ["a", "a", "b", "b", "c"])
    assert means == {"a": 1.5, "b": 3.0, "c": None}


def test_aggregate_layout_and_values():
    scenes = np.array(["b", "a", "a", "a"])
    got = aggregate({"ade": [4.0, 1.0, 2.0, 3.0], "miss": np.array([True, False, False, True])},
                    scenes)
    # ade: over windows (4 + 1 + 2 + 3) / 4 = 2.5; per scene a 2, b 4; over scenes (2 + 4) / 2 = 3.
    # miss: over windows 2 / 4 = 0.5; a 1/3, b 1; over scenes (1/3 + 1) / 2 = 2/3.
    assert got["n_windows"] == 4 and got["n_scenes"] == 2
    assert got["window_mean"] == {"ade": 2.5, "miss": 0.5}
    assert got["scene_mean"]["ade"] == 3.0
    assert got["scene_mean"]["miss"] == pytest.approx(2 / 3)
    assert got["per_scene"] == {"a": {"n_windows": 3, "ade": 2.0, "miss": pytest.approx(1 / 3)},
                                "b": {"n_windows": 1, "ade": 4.0, "miss": 1.0}}
    json.dumps(got, allow_nan=False)  # JSON-able, no NaN


def test_aggregate_names_a_bad_metric_shape():
    with pytest.raises(ValueError, match=r"ade must be \(2,\), got shape \(3,\)"):
        aggregate({"ade": [1.0, 2.0, 3.0]}, ["a", "b"])


def test_trajectory_scores_collect_the_path_metrics():
    pred, truth, _ = random_case(n=6, k=5, t=3, seed=5)
    pred[0, :, 1] = pred[0, 0, 1]  # one degenerate step of three in window 0
    got, nll = trajectory_scores(pred, truth, miss_threshold=5.0)
    assert set(got) == {"ade", "fde", "ade_joint", "fde_joint", "ade_best_endpoint", "miss",
                        "kde_nll", "kde_degenerate"}
    assert all(v.shape == (6,) for v in got.values())
    np.testing.assert_array_equal(nll, kde_nll(pred, truth))  # (N, T)
    np.testing.assert_array_equal(got["kde_nll"], nll.mean(axis=1))
    np.testing.assert_array_equal(got["kde_degenerate"], [1 / 3, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(got["miss"], miss(pred, truth, 5.0))
    assert (got["ade_best_endpoint"] >= got["ade"]).all()


def test_trajectory_scores_take_endpoints_from_goals():
    goals = np.array([[[2.0, 0.0], [5.0, 4.0]], [[3.0, 4.0], [9.0, 4.0]]])  # FDE (0, 5), (5, 5)
    got, _ = trajectory_scores(PRED, TRUTH, miss_threshold=4.0, goals=goals)
    np.testing.assert_array_equal(got["fde"], [0.0, 5.0])
    np.testing.assert_array_equal(got["ade_best_endpoint"], [2.0, 7.5])
    np.testing.assert_array_equal(got["miss"], [False, True])
