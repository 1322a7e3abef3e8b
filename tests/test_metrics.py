"""The shared metric on hand-made numbers (3-4-5 triangles, so every distance is exact)."""

import math
import warnings

import numpy as np
import pytest
import torch

from pipeline.harness.metrics import (METRIC_KEYS, ade_fde, goal_errors, seeded_rounds, step_errors,
                                      summarize, summarize_rounds, window_errors)

# Window 0: sample 0 is best on ADE (errors 0, 4 -> ADE 2, FDE 4), sample 1 best on FDE (3, 3 ->
# ADE 3, FDE 3): the independent minima (2, 3) mix samples, the joint FDE is 4.
# Window 1: sample 1 is exact (best on both); sample 0 is off by 5 and 10 (ADE 7.5, FDE 10).
TRUTH = np.array([
    [[1.0, 0.0], [2.0, 0.0]],
    [[3.0, 4.0], [6.0, 8.0]],
])  # (N=2, n_f=2, 2)
PRED = np.array([
    [[[1.0, 0.0], [2.0, 4.0]], [[1.0, 3.0], [2.0, 3.0]]],
    [[[0.0, 0.0], [0.0, 0.0]], [[3.0, 4.0], [6.0, 8.0]]],
])  # (N=2, K=2, n_f=2, 2)


def test_step_errors_are_l2_distances():
    np.testing.assert_array_equal(step_errors(PRED, TRUTH), [[[0, 4], [3, 3]], [[5, 10], [0, 0]]])


def test_independent_and_joint_minima_differ():
    errors = window_errors(PRED, TRUTH)
    np.testing.assert_array_equal(errors.ade, [2.0, 0.0])
    np.testing.assert_array_equal(errors.fde, [3.0, 0.0])
    np.testing.assert_array_equal(errors.fde_joint, [4.0, 0.0])
    np.testing.assert_array_equal(errors.best_ade_sample, [0, 1])
    np.testing.assert_array_equal(errors.best_fde_sample, [1, 1])
    assert errors.k == 2
    assert summarize(errors) == {"ade": 1.0, "fde": 1.5, "ade_joint": 1.0, "fde_joint": 2.0,
                                 "k": 2, "n_windows": 2}


def test_goals_replace_the_path_end_for_fde_only():
    # Window 0: sample 0's goal is 3 px off (path end 4 px), sample 1's goal is exact.
    goals = np.array([[[2.0, 3.0], [2.0, 0.0]], [[6.0, 8.0], [12.0, 16.0]]])  # (N, K, 2)
    np.testing.assert_array_equal(goal_errors(goals, TRUTH), [[3, 0], [0, 10]])
    errors = window_errors(PRED, TRUTH, goals)
    np.testing.assert_array_equal(errors.ade, [2.0, 0.0])  # ADE still from the paths
    np.testing.assert_array_equal(errors.fde, [0.0, 0.0])  # min over goals
    np.testing.assert_array_equal(errors.fde_joint, [3.0, 10.0])  # goal of the best-ADE sample
    assert ade_fde(PRED, TRUTH, goals)["fde_joint"] == 6.5


def test_single_sample_is_plain_ade_fde():
    pred = PRED[:, :1]  # (N, 1, n_f, 2)
    assert ade_fde(pred, TRUTH) == {"ade": 4.75, "fde": 7.0, "ade_joint": 4.75, "fde_joint": 7.0,
                                    "k": 1, "n_windows": 2}


def test_ties_go_to_the_first_sample():
    pred = np.repeat(PRED[:, :1], 3, axis=1)
    errors = window_errors(pred, TRUTH)
    np.testing.assert_array_equal(errors.best_ade_sample, [0, 0])
    np.testing.assert_array_equal(errors.best_fde_sample, [0, 0])


def test_torch_inputs_give_the_same_numbers():
    expected = ade_fde(PRED, TRUTH)
    got = ade_fde(torch.tensor(PRED, dtype=torch.float32), torch.tensor(TRUTH, dtype=torch.float32))
    assert got == expected


def test_empty_input_gives_nan_means_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "mean of empty slice"
        summary = ade_fde(np.zeros((0, 20, 30, 2)), np.zeros((0, 30, 2)))
    assert math.isnan(summary["ade"]) and summary["n_windows"] == 0 and summary["k"] == 20


@pytest.mark.parametrize("pred, truth, goals, message", [
    (PRED[0], TRUTH, None, r"predictions must be \(N, K, n_f, 2\), got \(2, 2, 2\)"),  # no sample axis
    (PRED, TRUTH[:1], None, r"ground truth \(1, 2, 2\) does not match predictions"),  # window count
    (PRED, TRUTH[:, :1], None, r"ground truth \(2, 1, 2\) does not match"),  # horizon differs
    (PRED, TRUTH, np.zeros((2, 3, 2)), "goals give 3 samples, paths 2"),  # goals with another K
    (PRED[:, :, :1], TRUTH[:, :1], np.zeros((1, 2, 2)), r"with N = 2, got \(1, 2, 2\)"),  # another N
    (PRED, TRUTH, np.zeros((2, 2, 3)), r"goals must be \(N, K, 2\)"),  # not 2-D points
    (PRED, TRUTH, np.zeros((2, 2)), r"goals must be \(N, K, 2\)"),  # no sample axis
])
def test_mismatched_shapes_fail(pred, truth, goals, message):
    with pytest.raises(ValueError, match=message):
        window_errors(pred, truth, goals)


def test_the_final_step_is_the_last_of_any_horizon():
    """Three steps, so the last step is not also the second (as it is with two)."""
    truth = np.array([[[1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]])  # (1, 3, 2)
    pred = np.array([[[[1.0, 0.0], [2.0, 3.0], [3.0, 4.0]]]])  # (1, 1, 3, 2): off by 0, 3, 4
    errors = window_errors(pred, truth)
    assert errors.fde[0] == 4.0 and errors.ade[0] == pytest.approx(7 / 3)
    goals = np.array([[[3.0, 5.0]]])  # 5 from the final point, 5.0990 from the second
    np.testing.assert_array_equal(goal_errors(goals, truth), [[5.0]])
    assert window_errors(pred, truth, goals).fde[0] == 5.0


def test_float32_inputs_are_scored_in_float64():
    pred, truth = (PRED + 0.1).astype(np.float32), (TRUTH + 0.3).astype(np.float32)
    assert ade_fde(pred, truth) == ade_fde(pred.astype(np.float64), truth.astype(np.float64))
    errors = window_errors(pred, truth)
    assert errors.ade.dtype == np.float64 and errors.summary() == summarize(errors)
    assert errors.summary()["n_windows"] == 2


def test_a_tensor_that_requires_grad_is_scored_too():
    pred = torch.tensor(PRED, dtype=torch.float64, requires_grad=True)
    assert ade_fde(pred, TRUTH) == ade_fde(PRED, TRUTH)


def test_seeded_rounds_seed_each_round_and_summarize_over_them():
    seen = []

    def score_round(seed: int):
        seen.append(seed)
        return window_errors(PRED + (seed - 10), TRUTH) if seed == 11 else window_errors(PRED, TRUTH)

    record = seeded_rounds(score_round, rounds=3, seed=10)
    assert seen == [10, 11, 12]
    exact = ade_fde(PRED, TRUTH)
    shifted = ade_fde(PRED + 1, TRUTH)
    assert record["rounds"] == 3 and len(record["per_round"]) == 3
    assert record["per_round"][0] == {key: exact[key] for key in METRIC_KEYS}
    ades = [exact["ade"], shifted["ade"], exact["ade"]]
    assert record["ade"] == {"mean": pytest.approx(np.mean(ades)), "std": pytest.approx(np.std(ades)),
                             "min": min(ades), "max": max(ades)}
    assert set(record) == {*METRIC_KEYS, "rounds", "per_round"}


def test_one_round_has_zero_spread_and_no_round_is_an_error():
    record = seeded_rounds(lambda seed: window_errors(PRED, TRUTH), rounds=1, seed=0)
    assert record["fde"]["std"] == 0.0 and record["fde"]["mean"] == ade_fde(PRED, TRUTH)["fde"]
    with pytest.raises(ValueError, match="rounds must be >= 1, got 0"):
        seeded_rounds(lambda seed: window_errors(PRED, TRUTH), rounds=0, seed=0)
    with pytest.raises(ValueError, match="^no rounds to summarize$"):
        summarize_rounds([])
