"""The stored-predictions format: arrays -> table -> parquet -> table -> arrays, rounds and goals,
and every way a table can be wrong, named in the error."""

import json
import os

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from pipeline.harness.predictions import (COLUMNS, PredictionRounds, concat_rounds, in_order,
                                          predictions_table, prediction_arrays,
                                          read_prediction_rounds, read_predictions, round_arrays,
                                          rounds, write_no_predictions, write_predictions)

METADATA = {"model": "ynet", "benchmark": "sdd_long_term_tf30", "unit": "px", "seeds": [0]}


def example(n: int = 3, k: int = 2, t: int = 4, seed: int = 0):
    rng = np.random.default_rng(seed)
    ids = np.array([7, 3, 11][:n])  # not sorted: the table keeps them, the arrays sort them
    samples = rng.normal(size=(n, k, t, 2)) * 100  # (N, K, T, 2)
    weights = rng.dirichlet(np.ones(k), n)  # (N, K)
    return ids, samples, weights


def test_table_layout_is_one_row_per_window_sample_step():
    ids, samples, weights = example()
    table = predictions_table(ids, samples, weights)
    assert list(table.columns) == list(COLUMNS)
    assert {c: str(table[c].dtype) for c in table.columns} == COLUMNS
    assert len(table) == 3 * 2 * 4
    # Row 5 = window 0 (id 7), sample 1, step 1.
    row = table.iloc[5]
    assert (row["window_id"], row["sample"], row["step"]) == (7, 1, 1)
    assert (row["x"], row["y"]) == tuple(samples[0, 1, 1])
    assert row["weight"] == weights[0, 1] and row["round"] == 0
    assert np.isnan(row["goal_x"]) and np.isnan(row["goal_y"])  # no goals given


def test_arrays_come_back_sorted_by_window_id_from_any_row_order():
    ids, samples, weights = example()
    table = predictions_table(ids, samples, weights).sample(frac=1.0, random_state=0)
    got_ids, got_samples, got_weights, got_goals = prediction_arrays(table)
    order = np.argsort(ids)  # ids 3, 7, 11 = rows 1, 0, 2
    assert got_goals is None
    np.testing.assert_array_equal(got_ids, [3, 7, 11])
    np.testing.assert_array_equal(got_samples, samples[order])
    np.testing.assert_array_equal(got_weights, weights[order])


def test_round_trip_through_parquet_keeps_values_dtypes_and_metadata(tmp_path):
    ids, samples, weights = example()
    path = tmp_path / "sub" / "ynet.parquet"
    write_predictions(predictions_table(ids, samples, weights), path, METADATA)
    assert [p.name for p in path.parent.iterdir()] == ["ynet.parquet"]  # no temporary file left
    table, metadata = read_predictions(path)
    assert metadata == METADATA
    assert {c: str(table[c].dtype) for c in table.columns} == COLUMNS
    assert json.loads(pq.read_schema(path).metadata[b"predictions"]) == METADATA
    got_ids, got_samples, got_weights, _ = prediction_arrays(table)
    order = np.argsort(ids)
    np.testing.assert_array_equal(got_ids, ids[order])
    np.testing.assert_array_equal(got_samples, samples[order])  # float64: exact
    np.testing.assert_array_equal(got_weights, weights[order])


def test_a_model_without_weights_stores_nan(tmp_path):
    ids, samples, _ = example(k=1)
    path = tmp_path / "cv.parquet"
    write_predictions(predictions_table(ids, samples), path, METADATA)
    table, metadata = read_predictions(path)
    assert table["weight"].isna().all() and metadata["seeds"] == [0]
    _, got_samples, got_weights, _ = prediction_arrays(table)
    assert got_samples.shape == (3, 1, 4, 2) and got_weights.shape == (3, 1)
    assert np.isnan(got_weights).all()


def test_metadata_must_name_model_benchmark_unit_and_seeds(tmp_path):
    ids, samples, _ = example()
    with pytest.raises(ValueError, match=r"lacks \['seeds'\]"):
        write_predictions(predictions_table(ids, samples), tmp_path / "p.parquet",
                          {"model": "m", "benchmark": "b", "unit": "m"})
    assert not any(tmp_path.iterdir())


def test_a_parquet_without_prediction_metadata_is_refused(tmp_path):
    ids, samples, _ = example()
    path = tmp_path / "plain.parquet"
    predictions_table(ids, samples).to_parquet(path, index=False)
    with pytest.raises(ValueError, match="not a predictions file"):
        read_predictions(path)


def test_a_bad_table_is_never_written(tmp_path):
    ids, samples, _ = example()
    table = predictions_table(ids, samples)
    table.loc[4, "x"] = np.inf
    with pytest.raises(ValueError, match="non-finite"):
        write_predictions(table, tmp_path / "p.parquet", METADATA)
    assert not os.listdir(tmp_path)


@pytest.mark.parametrize("shape, match", [
    ((3, 2, 4), r"\(N, K, T, 2\), got shape \(3, 2, 4\)"),
    ((3, 2, 4, 3), r"got shape \(3, 2, 4, 3\)"),
])
def test_bad_sample_shapes_are_named(shape, match):
    with pytest.raises(ValueError, match=match):
        predictions_table(np.arange(3), np.zeros(shape))


def test_bad_id_and_weight_shapes_are_named():
    with pytest.raises(ValueError, match=r"window_ids must be \(3,\).*shape \(2,\)"):
        predictions_table(np.arange(2), np.zeros((3, 2, 4, 2)))
    with pytest.raises(ValueError, match=r"weights must be \(3, 2\), got shape \(3, 3\)"):
        predictions_table(np.arange(3), np.zeros((3, 2, 4, 2)), np.ones((3, 3)))


def table_of_example() -> pd.DataFrame:
    ids, samples, weights = example()
    return predictions_table(ids, samples, weights)


def test_duplicate_row_is_named():
    table = table_of_example()
    table = pd.concat([table, table.iloc[[9]]], ignore_index=True)  # window 3, sample 0, step 1
    with pytest.raises(ValueError, match="1 duplicate row.*round 0 window 3 sample 0 step 1"):
        prediction_arrays(table)


def test_missing_row_is_named():
    table = table_of_example().drop(index=10)  # a row of window 3 (second window)
    with pytest.raises(ValueError, match="window 3 has 7 rows, expected 8"):
        prediction_arrays(table)


def test_windows_with_different_k_are_refused():
    ids, samples, _ = example()
    small = predictions_table(np.array([99]), samples[:1, :1])  # K = 1 beside K = 2
    with pytest.raises(ValueError, match="window 99 has 4 rows, expected 8"):
        prediction_arrays(pd.concat([table_of_example(), small], ignore_index=True))


def test_a_step_gap_is_refused():
    table = table_of_example()
    table.loc[table["step"] == 3, "step"] = 4  # steps 0, 1, 2, 4: step 3 missing everywhere
    with pytest.raises(ValueError, match="without every sample 0..1 and step 0..4"):
        prediction_arrays(table)


def test_negative_sample_is_named():
    table = table_of_example()
    table.loc[0, "sample"] = -1
    with pytest.raises(ValueError, match="sample: negative value -1 at round 0 window 7 sample -1 "
                                         "step 0"):
        prediction_arrays(table)


def test_missing_and_mistyped_columns_are_named():
    with pytest.raises(ValueError, match=r"lacks column\(s\) \['weight'\]"):
        prediction_arrays(table_of_example().drop(columns="weight"))
    table = table_of_example()
    table["window_id"] = table["window_id"].astype(str)
    with pytest.raises(ValueError, match="column window_id: dtype"):
        prediction_arrays(table)


def test_weights_must_be_per_sample_and_all_or_none():
    table = table_of_example()
    table.loc[1, "weight"] = 0.5  # window 7 sample 0 step 1 differs from its step 0
    with pytest.raises(ValueError, match="changes along a sample's steps"):
        prediction_arrays(table)
    table = table_of_example()
    table.loc[table["window_id"] == 3, "weight"] = np.nan
    with pytest.raises(ValueError, match="NaN for 8 of 24 rows"):
        prediction_arrays(table)
    table = table_of_example()
    table["weight"] = -table["weight"]
    with pytest.raises(ValueError, match=">= 0"):
        prediction_arrays(table)


# ---------------------------------------------------------------------------------------------
# Rounds and goals


def three_rounds(goals: bool = False) -> tuple[pd.DataFrame, list]:
    """Rounds 0, 1, 2 of the example (each its own samples), with goals if asked."""
    ids = example()[0]
    drawn = [example(seed=r)[1:] for r in range(3)]  # [(samples, weights)] per round
    goal = [s[:, :, -1] + 0.5 for s, _ in drawn] if goals else [None] * 3
    tables = [predictions_table(ids, s, w, goal[r], round=r) for r, (s, w) in enumerate(drawn)]
    return concat_rounds(tables), [(s, w, g) for (s, w), g in zip(drawn, goal)]


def test_each_round_is_selected_by_its_index():
    table, drawn = three_rounds()
    assert rounds(table) == [0, 1, 2] and len(table) == 3 * 24
    order = np.argsort(example()[0])
    for r, (samples, weights, _) in enumerate(drawn):
        got = prediction_arrays(table.sample(frac=1.0, random_state=r), round=r)
        np.testing.assert_array_equal(got.samples, samples[order])
        np.testing.assert_array_equal(got.weights, weights[order])
    assert {r: a.samples.shape for r, a in round_arrays(table).items()} == {
        r: (3, 2, 4, 2) for r in range(3)}
    with pytest.raises(ValueError, match=r"holds rounds \[0, 1, 2\]: say which"):
        prediction_arrays(table)
    with pytest.raises(ValueError, match=r"no round 3: the table holds rounds \[0, 1, 2\]"):
        prediction_arrays(table, round=3)


def test_goals_round_trip_through_parquet(tmp_path):
    table, drawn = three_rounds(goals=True)
    path = tmp_path / "ynet.parquet"
    write_predictions(table, path, {**METADATA, "seeds": [5, 6, 7]})
    back, metadata = read_predictions(path)
    assert metadata["seeds"] == [5, 6, 7]
    assert list(back.columns) == list(COLUMNS) and len(back) == len(table)
    # written sorted by round, window_id, sample, step
    assert back[["round", "window_id", "sample", "step"]].equals(
        back[["round", "window_id", "sample", "step"]].sort_values(["round", "window_id", "sample",
                                                                      "step"]))
    order = np.argsort(example()[0])
    for r, (samples, weights, goals) in enumerate(drawn):
        got = prediction_arrays(back, round=r)
        np.testing.assert_array_equal(got.samples, samples[order])  # float64: exact
        np.testing.assert_array_equal(got.goals, goals[order])
        np.testing.assert_array_equal(got.weights, weights[order])
    by_round, again = read_prediction_rounds(path)  # the same, as arrays, checked once
    assert again == metadata and list(by_round) == [0, 1, 2]
    for r, arrays in by_round.items():
        for got, expected in zip(arrays, prediction_arrays(back, round=r)):
            np.testing.assert_array_equal(got, expected)


def test_prediction_rounds_keep_every_round_with_its_seed(tmp_path):
    ids, samples, _ = example()
    kept = PredictionRounds(ids)
    for seed in (10, 11):
        kept.add(seed, samples + seed, goals=samples[:, :, -1])
    kept.write(tmp_path / "p.parquet", {k: v for k, v in METADATA.items() if k != "seeds"})
    table, metadata = read_predictions(tmp_path / "p.parquet")
    assert metadata["seeds"] == [10, 11] and rounds(table) == [0, 1]
    got = prediction_arrays(table, round=1)
    np.testing.assert_array_equal(got.samples, (samples + 11)[np.argsort(ids)])


def test_rounds_over_other_windows_k_or_t_are_named():
    ids, samples, _ = example()
    first = predictions_table(ids, samples)
    with pytest.raises(ValueError, match=r"round 1 covers other windows than round 0: "
                                         r"1 missing \[11\], 1 extra \[12\]"):
        concat_rounds([first, predictions_table(np.array([7, 3, 12]), samples, round=1)])
    with pytest.raises(ValueError, match="round 1 has K = 1 samples and T = 4 steps, "
                                         "round 0 K = 2 and T = 4"):
        concat_rounds([first, predictions_table(ids, samples[:, :1], round=1)])
    with pytest.raises(ValueError, match="round 1 has K = 2 samples and T = 3 steps"):
        concat_rounds([first, predictions_table(ids, samples[:, :, :3], round=1)])
    with pytest.raises(ValueError, match=r"round\(s\) \[0\] given in more than one table"):
        concat_rounds([first, first])
    with pytest.raises(ValueError, match=r"rounds must be 0 .. R-1 without gaps, got \[0, 2\]"):
        concat_rounds([first, predictions_table(ids, samples, round=2)])
    with pytest.raises(ValueError, match="round 1: 1 window.*window 3 has 7 rows, expected 8"):
        prediction_arrays(concat_rounds([first, predictions_table(ids, samples, round=1)])
                          .drop(index=24 + 10), round=0)


def test_goals_must_be_per_sample_and_all_or_none():
    ids, samples, _ = example()
    table = predictions_table(ids, samples, goals=samples[:, :, -1])
    changed = table.copy()
    changed.loc[1, "goal_x"] += 1.0  # window 7 sample 0 step 1 differs from its step 0
    with pytest.raises(ValueError, match="round 0: goal changes along a sample's steps"):
        prediction_arrays(changed)
    partial = table.copy()
    partial.loc[partial["window_id"] == 3, "goal_y"] = np.nan
    with pytest.raises(ValueError, match="goal_x / goal_y are NaN in 8 of 24 rows"):
        prediction_arrays(partial)
    infinite = table.copy()
    infinite.loc[0:3, "goal_x"] = np.inf  # every step of window 7 sample 0
    with pytest.raises(ValueError, match=r"goal infinite in 4 row\(s\)"):
        prediction_arrays(infinite)
    with pytest.raises(ValueError, match=r"goals must be \(3, 2, 2\), got shape \(3, 2\)"):
        predictions_table(ids, samples, goals=samples[:, :, -1, 0])


def test_seeds_must_be_one_per_round(tmp_path):
    table, _ = three_rounds()
    with pytest.raises(ValueError, match=r"one seed per round: 3 round\(s\), seeds \[0\]"):
        write_predictions(table, tmp_path / "p.parquet", METADATA)
    assert not any(tmp_path.iterdir())


def test_a_model_not_run_gets_an_empty_file_that_says_why(tmp_path):
    path = tmp_path / "ynet.parquet"
    write_no_predictions(path, {"model": "ynet", "benchmark": "sdd_long_term_tf5", "unit": "px"},
                         "not trained at t_f = 5 s")
    table, metadata = read_predictions(path)
    assert len(table) == 0 and list(table.columns) == list(COLUMNS)
    assert metadata["not_run_reason"] == "not trained at t_f = 5 s" and metadata["seeds"] == []
    assert read_prediction_rounds(path) == ({}, metadata)
    with pytest.raises(ValueError, match="predictions table is empty"):
        prediction_arrays(table)
    empty = tmp_path / "empty.parquet"  # without a reason an empty table is not a predictions file
    write_no_predictions(empty, {"model": "m", "benchmark": "b", "unit": "px"}, "x")
    arrow = pq.read_table(empty)
    stored = json.loads(arrow.schema.metadata[b"predictions"])
    del stored["not_run_reason"]
    pq.write_table(arrow.replace_schema_metadata({b"predictions": json.dumps(stored).encode()}), empty)
    with pytest.raises(ValueError, match="empty"):
        read_predictions(empty)


def test_rows_in_order_are_recognised():
    first = np.array([0, 0, 1, 1])
    assert in_order([first, np.array([5, 7, 2, 2])])  # ties in both keys are in order
    assert not in_order([first, np.array([7, 5, 2, 3])])  # 7 before 5 within first == 0
    assert in_order([first, np.array([5, 7, 1, 2])]) and in_order([np.array([3])])
    ids, samples, _ = example()  # ids 7, 3, 11: the table as built is out of order, the arrays not
    table = predictions_table(ids, samples)
    keys = [table[c].to_numpy() for c in ("round", "window_id", "sample", "step")]
    assert not in_order(keys)
    ordered = table.sort_values(["round", "window_id", "sample", "step"])
    for got, expected in zip(round_arrays(ordered)[0], round_arrays(table)[0]):
        np.testing.assert_array_equal(got, expected)
