"""The stored-predictions format: arrays -> table -> parquet -> table -> arrays, and every way a
table can be wrong, named in the error."""

import json
import os

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from pipeline.harness.predictions import (COLUMNS, predictions_table, prediction_arrays,
                                          read_predictions, write_predictions)

METADATA = {"model": "ynet", "benchmark": "sdd_long_term_tf30", "unit": "px", "seeds": [0, 1]}


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
    assert row["weight"] == weights[0, 1]


def test_arrays_come_back_sorted_by_window_id_from_any_row_order():
    ids, samples, weights = example()
    table = predictions_table(ids, samples, weights).sample(frac=1.0, random_state=0)
    got_ids, got_samples, got_weights = prediction_arrays(table)
    order = np.argsort(ids)  # ids 3, 7, 11 = rows 1, 0, 2
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
    got_ids, got_samples, got_weights = prediction_arrays(table)
    order = np.argsort(ids)
    np.testing.assert_array_equal(got_ids, ids[order])
    np.testing.assert_array_equal(got_samples, samples[order])  # float64: exact
    np.testing.assert_array_equal(got_weights, weights[order])


def test_a_model_without_weights_stores_nan(tmp_path):
    ids, samples, _ = example(k=1)
    path = tmp_path / "cv.parquet"
    write_predictions(predictions_table(ids, samples), path, {**METADATA, "seeds": []})
    table, metadata = read_predictions(path)
    assert table["weight"].isna().all() and metadata["seeds"] == []
    _, got_samples, got_weights = prediction_arrays(table)
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
    with pytest.raises(ValueError, match="1 duplicate row.*window 3 sample 0 step 1"):
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
    with pytest.raises(ValueError, match="sample: negative value -1 at window 7 sample -1 step 0"):
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
