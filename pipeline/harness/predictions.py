"""The one file format every stored test prediction is kept in, so that scoring reads only files.

One parquet per benchmark and model, long format, one row per (window, sample, step) of the
predicted future, sorted by window_id, sample, step:

| column    | type    | meaning                                                                |
|-----------|---------|------------------------------------------------------------------------|
| window_id | int64   | the window table's id of the window predicted                          |
| sample    | int32   | 0 .. K-1, the sample's index (the order the model drew them in)        |
| step      | int32   | 0 .. T-1, future step (step 0 is the first predicted position)         |
| x, y      | float64 | predicted position in the benchmark's unit (pixels for SDD, metres...) |
| weight    | float64 | the sample's probability or weight where the model gives one (Y-net:   |
|           |         | its goal cluster's mass), the same on every step; NaN where it has none|

Every window has the same K and T, and every (sample, step) of it exactly once: a table is a dense
(N, K, T, 2) array written long, so that it can be read with pandas by someone who has never seen
this code and still be turned back into arrays without guessing.

What was predicted under which settings travels inside the file, as JSON in the parquet schema's
metadata (key `predictions`): at least `model`, `benchmark`, `unit` and `seeds` (the seeds the
samples were drawn with; an empty list for a deterministic model), plus whatever else the writer
adds. A file is written atomically (`pipeline.io.write_with`), so a stopped run never leaves a
half-written prediction file behind.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.io import write_with

COLUMNS = {
    "window_id": "int64",
    "sample": "int32",
    "step": "int32",
    "x": "float64",
    "y": "float64",
    "weight": "float64",
}
METADATA_KEY = b"predictions"  # the parquet schema metadata key the JSON metadata is stored under
REQUIRED_METADATA = ("model", "benchmark", "unit", "seeds")


def predictions_table(window_ids: Any, samples: Any, weights: Any | None = None) -> pd.DataFrame:
    """The long table of predictions `samples` (N, K, T, 2) for windows `window_ids` (N,), with the
    samples' `weights` (N, K) or NaN where the model has none. Rows follow the arrays' order."""
    window_ids = np.asarray(window_ids)
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 4 or samples.shape[-1] != 2:
        raise ValueError(f"samples must be (N, K, T, 2), got shape {samples.shape}")
    n, k, t, _ = samples.shape
    if window_ids.shape != (n,) or window_ids.dtype.kind not in "iu":
        raise ValueError(f"window_ids must be ({n},) integers, got shape {window_ids.shape} "
                         f"of {window_ids.dtype}")
    if weights is None:
        weights = np.full((n, k), np.nan)
    weights = np.asarray(weights, dtype=np.float64)
    if weights.shape != (n, k):
        raise ValueError(f"weights must be ({n}, {k}), got shape {weights.shape}")
    rows = n * k * t
    table = pd.DataFrame({
        "window_id": np.repeat(window_ids.astype(np.int64), k * t),
        "sample": np.tile(np.repeat(np.arange(k, dtype=np.int32), t), n),
        "step": np.tile(np.arange(t, dtype=np.int32), n * k),
        "x": samples[..., 0].reshape(rows),
        "y": samples[..., 1].reshape(rows),
        "weight": np.repeat(weights.reshape(n * k), t),
    })
    prediction_arrays(table)  # a table that cannot be read back is never handed out
    return table


def _first(mask: np.ndarray, *columns: np.ndarray) -> str:
    """'window 3 sample 0 step 4': the first row where `mask` holds, for error messages."""
    i = int(np.flatnonzero(mask)[0])
    window, sample, step = (int(c[i]) for c in columns)
    return f"window {window} sample {sample} step {step}"


def prediction_arrays(table: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(window_ids (N,), samples (N, K, T, 2), weights (N, K)) of a predictions table, windows in
    ascending window_id order (join with the window table by id, never by position).

    Raises ValueError naming what is wrong: a missing column or one of the wrong kind, a duplicate
    or missing (window, sample, step), windows with different K or T, a non-finite position, a
    weight that changes along a sample's steps, is negative, or is given for some samples only.
    """
    missing = [c for c in COLUMNS if c not in table.columns]
    if missing:
        raise ValueError(f"predictions table lacks column(s) {missing}")
    for name, dtype in COLUMNS.items():
        kind = np.dtype(dtype).kind
        if table[name].dtype.kind != kind:
            raise ValueError(f"column {name}: dtype {table[name].dtype}, expected {dtype}")
    window = table["window_id"].to_numpy(np.int64)
    sample = table["sample"].to_numpy(np.int64)
    step = table["step"].to_numpy(np.int64)
    xy = table[["x", "y"]].to_numpy(np.float64)  # (rows, 2)
    weight = table["weight"].to_numpy(np.float64)
    if len(table) == 0:
        raise ValueError("predictions table is empty")
    for name, values in (("sample", sample), ("step", step)):
        if values.min() < 0:
            raise ValueError(f"column {name}: negative value {values.min()} at "
                             f"{_first(values < 0, window, sample, step)}")
    bad = ~np.isfinite(xy).all(axis=1)
    if bad.any():
        raise ValueError(f"{int(bad.sum())} non-finite position(s), first at "
                         f"{_first(bad, window, sample, step)}")

    order = np.lexsort((step, sample, window))
    window, sample, step = window[order], sample[order], step[order]
    xy, weight = xy[order], weight[order]
    same = (window[1:] == window[:-1]) & (sample[1:] == sample[:-1]) & (step[1:] == step[:-1])
    if same.any():
        raise ValueError(f"{int(same.sum())} duplicate row(s), first "
                         f"{_first(np.append(same, False), window, sample, step)}")
    ids, counts = np.unique(window, return_counts=True)  # (N,)
    n, k, t = len(ids), int(sample.max()) + 1, int(step.max()) + 1
    short = counts != k * t
    if short.any():
        i = int(np.flatnonzero(short)[0])
        raise ValueError(f"{int(short.sum())} window(s) without every sample 0..{k - 1} and step "
                         f"0..{t - 1}: window {ids[i]} has {counts[i]} rows, expected {k * t}")
    # Sorted, duplicate-free and k*t rows per window with sample < k, step < t: each window then
    # holds every (sample, step) exactly once, so the reshape below is exact.
    samples = xy.reshape(n, k, t, 2)
    weights_kt = weight.reshape(n, k, t)
    nan = np.isnan(weights_kt)
    if nan.any() and not nan.all():
        raise ValueError(f"weight is NaN for {int(nan.sum())} of {nan.size} rows: a model gives "
                         f"a weight for every sample or for none")
    if not nan.any():
        if not (weights_kt == weights_kt[..., :1]).all():
            raise ValueError("weight changes along a sample's steps (one weight per sample)")
        if not np.isfinite(weights_kt).all() or (weights_kt < 0).any():
            raise ValueError("weights must be finite and >= 0")
    return ids, samples, weights_kt[..., 0]


def write_predictions(table: pd.DataFrame, path: Path, metadata: dict[str, Any]) -> None:
    """Write a predictions table (checked first) to parquet at `path`, atomically, with `metadata`
    (JSON-able; at least `REQUIRED_METADATA`) in the schema metadata."""
    missing = [key for key in REQUIRED_METADATA if key not in metadata]
    if missing:
        raise ValueError(f"prediction metadata lacks {missing} "
                         f"(required: {list(REQUIRED_METADATA)})")
    prediction_arrays(table)
    arrow = pa.Table.from_pandas(table[list(COLUMNS)].astype(COLUMNS), preserve_index=False)
    arrow = arrow.replace_schema_metadata({**(arrow.schema.metadata or {}),
                                           METADATA_KEY: json.dumps(metadata).encode()})
    write_with(Path(path), lambda tmp: pq.write_table(arrow, tmp))


def read_predictions(path: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    """(table, metadata) of a file `write_predictions` wrote; the table is checked on reading."""
    arrow = pq.read_table(path)
    stored = (arrow.schema.metadata or {}).get(METADATA_KEY)
    if stored is None:
        raise ValueError(f"{path}: no '{METADATA_KEY.decode()}' metadata: not a predictions file")
    table = arrow.to_pandas()
    prediction_arrays(table)
    return table, json.loads(stored)
