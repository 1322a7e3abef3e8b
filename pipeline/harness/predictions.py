"""The one file format every stored test prediction is kept in, so that scoring reads only files.

One parquet per benchmark and model, long format, one row per (round, window, sample, step) of the
predicted future, sorted by round, window_id, sample, step:

| column         | type    | meaning                                                              |
|----------------|---------|----------------------------------------------------------------------|
| round          | int32   | 0 .. R-1, the seeded sampling round (seed: metadata `seeds[round]`)  |
| window_id      | int64   | the window table's id of the window predicted                        |
| sample         | int32   | 0 .. K-1, the sample's index (the order the model drew them in)      |
| step           | int32   | 0 .. T-1, future step (step 0 is the first predicted position)       |
| x, y           | float64 | predicted position in the benchmark's unit (pixels for SDD, metres)  |
| weight         | float64 | the sample's probability or weight where the model gives one (e.g. a |
|                |         | goal cluster's mass), the same on every step; NaN where it has none  |
| goal_x, goal_y | float64 | the sample's separately predicted goal (Y-net's sampled goal, which  |
|                |         | its FDE is measured on), the same on every step; NaN where none      |

A benchmark scores R seeded rounds and reports mean and spread over them, so one file holds every
round of the setting it reports. Every round covers the same windows with the same K and T, and
every (sample, step) of a window exactly once: a round is a dense (N, K, T, 2) array written long,
so that it can be read with pandas by someone who has never seen this code and still be turned
back into arrays without guessing (`prediction_arrays(table, round=r)`).

What was predicted under which settings travels inside the file, as JSON in the parquet schema's
metadata (key `predictions`): at least `model`, `benchmark`, `unit` and `seeds` (one per round,
the seed round r was sampled with; a deterministic model records the seeds its rounds were given),
plus whatever else the writer adds. A stage that declares a predictions file but has nothing to
predict (a model not trained in this profile) writes an empty table whose metadata says why
(`not_run_reason`, `write_no_predictions`), so a declared output always exists. A file is written
atomically (`pipeline.io.write_with`), so a stopped run never leaves a half-written file behind.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.io import write_with

COLUMNS = {
    "round": "int32",
    "window_id": "int64",
    "sample": "int32",
    "step": "int32",
    "x": "float64",
    "y": "float64",
    "weight": "float64",
    "goal_x": "float64",
    "goal_y": "float64",
}
ORDER = ["round", "window_id", "sample", "step"]  # the rows' sort order in a written file
METADATA_KEY = b"predictions"  # the parquet schema metadata key the JSON metadata is stored under
REQUIRED_METADATA = ("model", "benchmark", "unit", "seeds")
NOT_RUN = "not_run_reason"  # metadata key of a file with no predictions, saying why


class PredictionArrays(NamedTuple):
    """One round of a predictions table as arrays, windows in ascending window_id order."""

    window_ids: np.ndarray  # (N,) int64
    samples: np.ndarray  # (N, K, T, 2) float64
    weights: np.ndarray  # (N, K) float64, NaN where the model gives none
    goals: np.ndarray | None  # (N, K, 2) float64, None where the model has no separate goal


def predictions_table(window_ids: Any, samples: Any, weights: Any | None = None,
                      goals: Any | None = None, round: int = 0) -> pd.DataFrame:
    """The long table of round `round`'s predictions `samples` (N, K, T, 2) for windows
    `window_ids` (N,), with the samples' `weights` (N, K) and `goals` (N, K, 2), NaN where the
    model has none. Rows follow the arrays' order; `concat_rounds` joins the rounds of a setting."""
    window_ids = np.asarray(window_ids)
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 4 or samples.shape[-1] != 2:
        raise ValueError(f"samples must be (N, K, T, 2), got shape {samples.shape}")
    n, k, t, _ = samples.shape
    if window_ids.shape != (n,) or window_ids.dtype.kind not in "iu":
        raise ValueError(f"window_ids must be ({n},) integers, got shape {window_ids.shape} "
                         f"of {window_ids.dtype}")
    if int(round) != round or round < 0:
        raise ValueError(f"round must be an integer >= 0, got {round}")
    weights = np.full((n, k), np.nan) if weights is None else np.asarray(weights, dtype=np.float64)
    if weights.shape != (n, k):
        raise ValueError(f"weights must be ({n}, {k}), got shape {weights.shape}")
    goals = np.full((n, k, 2), np.nan) if goals is None else np.asarray(goals, dtype=np.float64)
    if goals.shape != (n, k, 2):
        raise ValueError(f"goals must be ({n}, {k}, 2), got shape {goals.shape}")
    rows = n * k * t
    table = pd.DataFrame({
        "round": np.full(rows, round, dtype=np.int32),
        "window_id": np.repeat(window_ids.astype(np.int64), k * t),
        "sample": np.tile(np.repeat(np.arange(k, dtype=np.int32), t), n),
        "step": np.tile(np.arange(t, dtype=np.int32), n * k),
        "x": samples[..., 0].reshape(rows),
        "y": samples[..., 1].reshape(rows),
        "weight": np.repeat(weights.reshape(n * k), t),
        "goal_x": np.repeat(goals[..., 0].reshape(n * k), t),
        "goal_y": np.repeat(goals[..., 1].reshape(n * k), t),
    })
    round_arrays(table)  # a table that cannot be read back is never handed out
    return table


def concat_rounds(tables: Sequence[pd.DataFrame]) -> pd.DataFrame:
    """One table of the rounds of `tables` (each holding other rounds), checked as a whole: the
    rounds must be 0 .. R-1 and cover the same windows, K and T."""
    if not tables:
        raise ValueError("no rounds to concatenate")
    seen: set[int] = set()
    for table in tables:
        held = set(rounds(table))
        if held & seen:
            raise ValueError(f"round(s) {sorted(held & seen)} given in more than one table")
        seen |= held
    table = pd.concat(list(tables), ignore_index=True)
    check_all_rounds(list(round_arrays(table)))
    return table


def check_columns(table: pd.DataFrame) -> None:
    """Every column of `COLUMNS` present and of its kind, or a ValueError naming the column."""
    missing = [c for c in COLUMNS if c not in table.columns]
    if missing:
        raise ValueError(f"predictions table lacks column(s) {missing}")
    for name, dtype in COLUMNS.items():
        if table[name].dtype.kind != np.dtype(dtype).kind:
            raise ValueError(f"column {name}: dtype {table[name].dtype}, expected {dtype}")


def rounds(table: pd.DataFrame) -> list[int]:
    """The rounds a table holds, ascending (a whole setting's: [0, 1, ..., R-1])."""
    check_columns(table)
    held = np.unique(table["round"].to_numpy(np.int64))
    if len(held) == 0:
        raise ValueError("predictions table is empty")
    if held[0] < 0:
        raise ValueError(f"column round: negative value {held[0]}")
    return held.tolist()


def check_all_rounds(held: list[int]) -> None:
    """A ValueError unless `held` (`rounds`) is 0 .. R-1: every round of a setting, as a file
    holds them."""
    if held != list(range(len(held))):
        raise ValueError(f"rounds must be 0 .. R-1 without gaps, got {held}")


def _first(mask: np.ndarray, *columns: np.ndarray) -> str:
    """'round 0 window 3 sample 0 step 4': the first row where `mask` holds, for error messages."""
    i = int(np.flatnonzero(mask)[0])
    round_, window, sample, step = (int(c[i]) for c in columns)
    return f"round {round_} window {window} sample {sample} step {step}"


def _constant_per_sample(values: np.ndarray) -> bool:
    """values (N, K, T, ...) equal along T (NaN counts as equal to NaN)."""
    first = values[:, :, :1]
    return bool(((values == first) | (np.isnan(values) & np.isnan(first))).all())


def _one_round(r: int, window: np.ndarray, sample: np.ndarray, step: np.ndarray, xy: np.ndarray,
               weight: np.ndarray, goal: np.ndarray, has_goals: bool) -> PredictionArrays:
    """The arrays of one round's rows, already sorted by window, sample, step and duplicate-free."""
    ids, counts = np.unique(window, return_counts=True)  # (N,)
    n, k, t = len(ids), int(sample.max()) + 1, int(step.max()) + 1
    short = counts != k * t
    if short.any():
        i = int(np.flatnonzero(short)[0])
        raise ValueError(f"round {r}: {int(short.sum())} window(s) without every sample 0..{k - 1} "
                         f"and step 0..{t - 1}: window {ids[i]} has {counts[i]} rows, "
                         f"expected {k * t}")
    # Sorted, duplicate-free and k*t rows per window with sample < k, step < t: each window then
    # holds every (sample, step) exactly once, so the reshapes below are exact.
    weights = weight.reshape(n, k, t)
    goals = goal.reshape(n, k, t, 2)
    if not _constant_per_sample(weights):
        raise ValueError(f"round {r}: weight changes along a sample's steps "
                         f"(one weight per sample)")
    if not _constant_per_sample(goals):
        raise ValueError(f"round {r}: goal changes along a sample's steps (one goal per sample)")
    return PredictionArrays(ids, xy.reshape(n, k, t, 2), weights[..., 0],
                            goals[:, :, 0] if has_goals else None)


def _same_windows(r: int, got: PredictionArrays, r0: int, first: PredictionArrays) -> None:
    """A ValueError naming how round `r` differs from round `r0` in windows, K or T."""
    if not np.array_equal(got.window_ids, first.window_ids):
        missing = np.setdiff1d(first.window_ids, got.window_ids)
        extra = np.setdiff1d(got.window_ids, first.window_ids)
        raise ValueError(f"round {r} covers other windows than round {r0}: {len(missing)} missing "
                         f"{missing[:3].tolist()}, {len(extra)} extra {extra[:3].tolist()}")
    (_, k, t, _), (_, k0, t0, _) = got.samples.shape, first.samples.shape
    if (k, t) != (k0, t0):
        raise ValueError(f"round {r} has K = {k} samples and T = {t} steps, "
                         f"round {r0} K = {k0} and T = {t0}")


def in_order(keys: Sequence[np.ndarray]) -> bool:
    """Whether rows given as key columns (each (rows,)) are sorted by the first key, then the
    second, ... (ties allowed): as `np.lexsort(keys[::-1])` would leave them."""
    later = np.zeros(max(len(keys[0]) - 1, 0), dtype=bool)  # a row before its predecessor
    tied = ~later  # equal to its predecessor in every key so far
    for key in keys:
        later |= tied & (key[1:] < key[:-1])
        tied &= key[1:] == key[:-1]
    return not later.any()


def round_arrays(table: pd.DataFrame) -> dict[int, PredictionArrays]:
    """Every round of a predictions table as arrays, {round: `PredictionArrays`} (windows in
    ascending window_id order: join with the window table by id, never by position), the whole
    table checked once.

    Raises ValueError naming what is wrong: a missing column or one of the wrong kind, a negative
    round, sample or step, a duplicate or missing (round, window, sample, step), windows with
    different K or T, a round that covers other windows or another K or T than the first, a
    non-finite position, a weight or goal that changes along a sample's steps or is given for some
    rows only, a negative or infinite weight, an infinite goal.
    """
    held = rounds(table)
    rnd, window, sample, step = (table[c].to_numpy(np.int64) for c in ORDER)
    xy = table[["x", "y"]].to_numpy(np.float64)  # (rows, 2)
    weight = table["weight"].to_numpy(np.float64)
    goal = table[["goal_x", "goal_y"]].to_numpy(np.float64)  # (rows, 2)
    keys = (rnd, window, sample, step)
    for name, values in (("sample", sample), ("step", step)):
        if values.min() < 0:
            raise ValueError(f"column {name}: negative value {values.min()} at "
                             f"{_first(values < 0, *keys)}")
    bad = ~np.isfinite(xy).all(axis=1)
    if bad.any():
        raise ValueError(f"{int(bad.sum())} non-finite position(s), first at {_first(bad, *keys)}")
    has_goals = not np.isnan(goal).any()

    if not in_order(keys):  # a written file is in order already: no sort, no copies
        order = np.lexsort((step, sample, window, rnd))
        rnd, window, sample, step = keys = tuple(c[order] for c in keys)
        xy, weight, goal = xy[order], weight[order], goal[order]
    same = ((rnd[1:] == rnd[:-1]) & (window[1:] == window[:-1]) & (sample[1:] == sample[:-1])
            & (step[1:] == step[:-1]))
    if same.any():
        raise ValueError(f"{int(same.sum())} duplicate row(s), first "
                         f"{_first(np.append(same, False), *keys)}")
    bounds = np.searchsorted(rnd, [*held, held[-1] + 1])  # round held[i]: bounds[i]:bounds[i+1]
    result: dict[int, PredictionArrays] = {}
    for i, r in enumerate(held):
        part = slice(bounds[i], bounds[i + 1])
        arrays = _one_round(r, window[part], sample[part], step[part], xy[part], weight[part],
                            goal[part], has_goals)
        if result:
            _same_windows(r, arrays, held[0], result[held[0]])
        result[r] = arrays
    nan = np.isnan(weight)
    if nan.any() and not nan.all():
        raise ValueError(f"weight is NaN for {int(nan.sum())} of {nan.size} rows: a model gives "
                         f"a weight for every sample or for none")
    if not nan.any() and (np.isinf(weight).any() or (weight < 0).any()):
        raise ValueError("weights must be finite and >= 0")
    no_goal = np.isnan(goal)
    if no_goal.any() and not no_goal.all():
        raise ValueError(f"goal_x / goal_y are NaN in {int(no_goal.any(axis=1).sum())} of "
                         f"{len(goal)} rows: a model gives a goal (both coordinates) for every "
                         f"sample or for none")
    if np.isinf(goal).any():
        raise ValueError(f"goal infinite in {int(np.isinf(goal).any(axis=1).sum())} row(s)")
    return result


def prediction_arrays(table: pd.DataFrame, round: int | None = None) -> PredictionArrays:
    """Round `round` of a predictions table as arrays (the whole table is checked, as
    `round_arrays` does); `round` may be left out only when the table holds one round."""
    every = round_arrays(table)
    if round is None:
        if len(every) != 1:
            raise ValueError(f"the table holds rounds {list(every)}: say which (round=r)")
        return next(iter(every.values()))
    if round not in every:
        raise ValueError(f"no round {round}: the table holds rounds {list(every)}")
    return every[round]


def _required(metadata: dict[str, Any], keys: Sequence[str]) -> None:
    missing = [key for key in keys if key not in metadata]
    if missing:
        raise ValueError(f"prediction metadata lacks {missing} (required: {list(keys)})")


def _write(table: pd.DataFrame, path: Path, metadata: dict[str, Any]) -> None:
    arrow = pa.Table.from_pandas(table[list(COLUMNS)].astype(COLUMNS), preserve_index=False)
    arrow = arrow.replace_schema_metadata({**(arrow.schema.metadata or {}),
                                           METADATA_KEY: json.dumps(metadata).encode()})
    write_with(Path(path), lambda tmp: pq.write_table(arrow, tmp))


def _check_file_rounds(table: pd.DataFrame, metadata: dict[str, Any]
                       ) -> dict[int, PredictionArrays]:
    """The table checked, holding rounds 0 .. R-1, and the metadata one seed per round: its
    `round_arrays`."""
    by_round = round_arrays(table)
    held = list(by_round)
    check_all_rounds(held)
    seeds = metadata["seeds"]
    if not isinstance(seeds, list) or len(seeds) != len(held):
        raise ValueError(f"metadata seeds must list one seed per round: {len(held)} round(s), "
                         f"seeds {seeds!r}")
    return by_round


def write_predictions(table: pd.DataFrame, path: Path, metadata: dict[str, Any]) -> None:
    """Write a predictions table (checked first, rows in `ORDER`) to parquet at `path`, atomically,
    with `metadata` (JSON-able; at least `REQUIRED_METADATA`, one seed per round) in the schema
    metadata."""
    _required(metadata, REQUIRED_METADATA)
    _check_file_rounds(table, metadata)
    _write(table.sort_values(ORDER, kind="stable"), path, metadata)


def write_no_predictions(path: Path, metadata: dict[str, Any], reason: str) -> None:
    """Write an empty predictions file at `path` whose metadata (model, benchmark, unit and the
    rest of `metadata`, no seeds) says why nothing was predicted: a declared output that exists
    even where the model was not run."""
    _required(metadata, REQUIRED_METADATA[:-1])
    _write(pd.DataFrame({c: pd.Series(dtype=d) for c, d in COLUMNS.items()}), path,
           {**metadata, "seeds": [], NOT_RUN: reason})


def _read_checked(path: Path) -> tuple[pd.DataFrame, dict[int, PredictionArrays], dict[str, Any]]:
    """(table, its `round_arrays`, metadata) of a predictions file, the table checked once (an
    empty one, with no rounds, only where the metadata has a `not_run_reason`)."""
    arrow = pq.read_table(path)
    stored = (arrow.schema.metadata or {}).get(METADATA_KEY)
    if stored is None:
        raise ValueError(f"{path}: no '{METADATA_KEY.decode()}' metadata: not a predictions file")
    table, metadata = arrow.to_pandas(), json.loads(stored)
    if NOT_RUN in metadata and len(table) == 0:
        check_columns(table)
        return table, {}, metadata
    return table, _check_file_rounds(table, metadata), metadata


def read_predictions(path: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    """(table, metadata) of a file `write_predictions` or `write_no_predictions` wrote; the table is
    checked on reading (an empty one only where the metadata has a `not_run_reason`)."""
    table, _, metadata = _read_checked(path)
    return table, metadata


def read_prediction_rounds(path: Path) -> tuple[dict[int, PredictionArrays], dict[str, Any]]:
    """({round: `PredictionArrays`}, metadata) of a predictions file, checked as `read_predictions`
    checks it, once (what scoring every stored file reads); {} for a file that says why nothing
    was predicted (`not_run_reason`)."""
    _, by_round, metadata = _read_checked(path)
    return by_round, metadata


class PredictionRounds:
    """The rounds of one setting kept as a scorer samples them (`add`, round 0 first), written as
    one predictions file with their seeds (`write`). `add` only keeps a copy of the arrays (the
    scorer's timing stays its own); the table is built and checked when asked for."""

    def __init__(self, window_ids: Any):
        self.window_ids = np.asarray(window_ids)  # (N,) the windows every round predicts
        self.drawn: list[tuple[np.ndarray, np.ndarray | None, np.ndarray | None]] = []
        self.seeds: list[int] = []

    def add(self, seed: int, samples: Any, weights: Any | None = None,
            goals: Any | None = None) -> None:
        """Keep the next round: `samples` (N, K, T, 2) drawn with `seed`, with the samples'
        `weights` (N, K) and `goals` (N, K, 2) where the model has them."""
        self.drawn.append(tuple(None if a is None else np.array(a, dtype=np.float64)
                                 for a in (samples, weights, goals)))
        self.seeds.append(int(seed))

    def table(self) -> pd.DataFrame:
        return concat_rounds([predictions_table(self.window_ids, samples, weights, goals, round=r)
                              for r, (samples, weights, goals) in enumerate(self.drawn)])

    def write(self, path: Path, metadata: dict[str, Any]) -> None:
        """`write_predictions` of every round kept, `metadata` plus the rounds' `seeds`."""
        write_predictions(self.table(), path, {**metadata, "seeds": self.seeds})
