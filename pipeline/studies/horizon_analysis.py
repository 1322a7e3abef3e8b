"""Why does Y-net's error stop growing after 30 s? Data, model or leak (stage `horizon_analysis`).

Each horizon t_f is scored on its own test windows (`data/horizon_windows/tf<t>.parquet`; Y-net's
30-s point on the release windows), so a curve of error against t_f mixes the horizon with who is
in the set. This module measures, per horizon, on the test split only (nothing is chosen on it):

- the data: test windows, their sources (`raw` / `release_chain`), distinct tracks and videos, and
  the quartiles of walker speed, future path length and net displacement over the future, with the
  share of walkers standing still (`STANDING_NET_PX`) and slow (`SLOW_SPEED_PX_S`);
- two references: constant velocity (its stored predictions) and the straight line from the last
  observed position to the true final one (`straight_to_goal`: FDE 0 by construction, so its ADE
  is the part of the error a perfect goal leaves);
- every stored model's best-of-K ADE / FDE over its own windows (mean over its stored rounds), also
  split into moving and standing walkers, FDE / ADE, and how far its K endpoints (goals where it
  has them) spread and reach from the last observed position;
- one population: the test windows of the longest horizon truncated at every shorter horizon
  (`truncate`), scored with the longest horizon's stored predictions over their first t steps, and
  with any predictions of t steps a caller ran on those truncated windows (the stage: each
  horizon's own Y-net);
- a leak check over every window table (`leak_check`): test videos among train / val videos, and
  test windows sharing a track and frames, or only frames, of a video with a train / val window,
  at the same or any other horizon;
- Y-net's training curves (`history.csv`) and its goal error against its path error.

Distances are original image pixels; a window's future is n_f steps at 1 FPS, so t_f = n_f seconds.
`read_horizon` reads one horizon's window table and stored predictions; everything else is numpy /
pandas on what was read, and `analyse` assembles the record the stage writes.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.data.window_table import WindowArrays, to_arrays
from pipeline.harness.metrics import window_errors
from pipeline.harness.predictions import NOT_RUN, PredictionArrays, read_prediction_rounds
from pipeline.model_list import YNET

STANDING_NET_PX = 50.0
"""A walker stands still when its final position is less than this far (pixels, about 1.5-2 m at
SDD's 0.03-0.04 m per pixel) from its last observed one, whatever the horizon."""
SLOW_SPEED_PX_S = 5.0
"""A walker is slow when its future path length over t_f is below this (pixels per second, about
0.2 m/s; walking is about 30-40 px/s)."""
SUBJECT = YNET
"""The model whose curve is in question: its per-window errors and its own horizon models."""
TEST = "test"
TRAIN_VAL = ("train", "val")


# ---------------------------------------------------------------------------------------------
# The windows' futures


def future_track(past: np.ndarray, future: np.ndarray) -> np.ndarray:
    """(N, n_f + 1, 2): the last observed position of past (N, n_p, 2), then future (N, n_f, 2)."""
    return np.concatenate([past[:, -1:], future], axis=1)


def path_lengths(past: np.ndarray, future: np.ndarray) -> np.ndarray:
    """(N,) length of the polyline from the last observed position through every future one."""
    return np.linalg.norm(np.diff(future_track(past, future), axis=1), axis=-1).sum(axis=1)


def net_displacements(past: np.ndarray, future: np.ndarray) -> np.ndarray:
    """(N,) distance from the last observed position to the final one."""
    return np.linalg.norm(future[:, -1] - past[:, -1], axis=-1)


def speeds(past: np.ndarray, future: np.ndarray, seconds: float) -> np.ndarray:
    """(N,) mean walking speed over the future: path length / `seconds` (t_f), pixels per second."""
    return path_lengths(past, future) / seconds


def standing_share(net: np.ndarray, threshold: float = STANDING_NET_PX) -> float | None:
    """Share of windows whose net displacement is below `threshold`; None for no window."""
    return float((np.asarray(net) < threshold).mean()) if len(net) else None


def quartiles(values: np.ndarray) -> dict[str, float | None]:
    """{q25, median, q75} of `values` (linear interpolation); None for no value."""
    if not len(values):
        return {"q25": None, "median": None, "q75": None}
    q25, median, q75 = np.percentile(values, [25, 50, 75])
    return {"q25": float(q25), "median": float(median), "q75": float(q75)}


def straight_to_goal(past: np.ndarray, future: np.ndarray) -> np.ndarray:
    """(N, n_f, 2) the straight line at constant speed from the last observed position to the true
    final position: step k of n_f is last + k / n_f (final - last), so its last step is exact."""
    last, final = past[:, -1], future[:, -1]  # (N, 2)
    fraction = np.arange(1, future.shape[1] + 1) / future.shape[1]  # (n_f,)
    return last[:, None] + fraction[None, :, None] * (final - last)[:, None]


def truncate(values: np.ndarray, steps: int) -> np.ndarray:
    """The first `steps` future steps of truth (N, T, 2) or predictions (N, K, T, 2)."""
    if not 1 <= steps <= values.shape[-2]:
        raise ValueError(f"cannot keep {steps} of {values.shape[-2]} steps")
    return values[..., :steps, :]


def truncated_arrays(arrays: WindowArrays, steps: int) -> WindowArrays:
    """The windows of `arrays` with their future cut to its first `steps` steps."""
    return replace(arrays, future=truncate(arrays.future, steps))


def data_summary(arrays: WindowArrays, sources: np.ndarray, seconds: float) -> dict[str, Any]:
    """What the windows of `arrays` are: counts by source (N,), distinct tracks and videos, and the
    quartiles of speed, path length and net displacement over `seconds` of future."""
    net = net_displacements(arrays.past, arrays.future)
    speed = speeds(arrays.past, arrays.future, seconds)
    names, counts = np.unique(np.asarray(sources, dtype=str), return_counts=True)
    return {
        "windows": len(arrays),
        "sources": {str(n): int(c) for n, c in zip(names, counts, strict=True)},
        "tracks": len(set(zip(arrays.scene_id.tolist(), arrays.track_id.tolist(), strict=True))),
        "videos": len(set(arrays.scene_id.tolist())),
        "speed_px_s": quartiles(speed),
        "path_length_px": quartiles(path_lengths(arrays.past, arrays.future)),
        "net_displacement_px": quartiles(net),
        "standing_share": standing_share(net),
        "slow_share": float((speed < SLOW_SPEED_PX_S).mean()) if len(speed) else None,
    }


# ---------------------------------------------------------------------------------------------
# Scores


@dataclass(frozen=True)
class Errors:
    """Best-of-K errors per window (rows in the windows' order) of each scored round."""

    ade: np.ndarray  # (R, N) min over K of ADE
    fde: np.ndarray  # (R, N) min over K of FDE (on the goals where the model has them)

    def summary(self, rows: np.ndarray | slice = slice(None)) -> dict[str, Any]:
        """Means over windows `rows`, then over rounds; FDE / ADE of those means."""
        ade, fde = self.ade[:, rows], self.fde[:, rows]
        if ade.shape[1] == 0:
            return {"windows": 0, "ade": None, "fde": None, "fde_over_ade": None,
                    "rounds": int(ade.shape[0])}
        mean_ade, mean_fde = float(ade.mean(axis=1).mean()), float(fde.mean(axis=1).mean())
        return {"windows": int(ade.shape[1]), "ade": mean_ade, "fde": mean_fde,
                "fde_over_ade": mean_fde / mean_ade if mean_ade > 0 else None,
                "rounds": int(ade.shape[0])}


def rows_of(window_ids: np.ndarray, wanted: np.ndarray, source: str) -> np.ndarray:
    """Positions in `window_ids` (unique, any order) of the ids `wanted`; a ValueError naming
    `source` for ids it lacks (predictions are joined to windows by id, never by position)."""
    order = np.argsort(window_ids, kind="stable")
    at = np.searchsorted(window_ids, wanted, sorter=order)
    found = at < len(window_ids)
    found[found] = window_ids[order[at[found]]] == wanted[found]
    if not found.all():
        raise ValueError(f"{source}: {int((~found).sum())} window id(s) not among the test "
                         f"windows, e.g. {wanted[~found][:3].tolist()}")
    return order[at]


def score_rounds(rounds: Mapping[int, PredictionArrays], arrays: WindowArrays,
                 steps: int | None = None, source: str = "predictions") -> Errors:
    """Best-of-K errors of every stored round against the windows `arrays` (ids ascending), each
    window of `arrays` predicted exactly once per round. `steps`: score the first `steps` steps of
    truth and predictions only, FDE then at step `steps` of the path (a separately predicted goal
    belongs to the full horizon and is not used); None: the whole future, FDE on the goals where
    the file has them (the paper's metric)."""
    ade, fde = [], []
    for r in sorted(rounds):
        arrays_r = rounds[r]
        if len(arrays_r.window_ids) != len(arrays):
            raise ValueError(f"{source}: round {r} predicts {len(arrays_r.window_ids)} windows, "
                             f"the table has {len(arrays)} test windows")
        at = rows_of(arrays_r.window_ids, arrays.window_id, source)  # prediction row per window
        samples, truth, goals = arrays_r.samples[at], arrays.future, arrays_r.goals
        goals = None if goals is None else goals[at]
        if steps is not None:
            samples, truth, goals = truncate(samples, steps), truncate(truth, steps), None
        if samples.shape[2] != truth.shape[1]:
            raise ValueError(f"{source}: {samples.shape[2]} predicted steps, {truth.shape[1]} true")
        errors = window_errors(samples, truth, goals)
        ade.append(errors.ade)
        fde.append(errors.fde)
    return Errors(np.stack(ade), np.stack(fde))


def deterministic_errors(paths: np.ndarray, truth: np.ndarray) -> Errors:
    """One path per window (N, T, 2) against the truth (N, T, 2), as one round of K = 1."""
    errors = window_errors(paths[:, None], truth)
    return Errors(errors.ade[None], errors.fde[None])


def endpoint_spread(endpoints: np.ndarray) -> np.ndarray:
    """(N,) how far a window's K predicted endpoints (N, K, 2) lie from their mean: the root mean
    square distance (pixels)."""
    centred = endpoints - endpoints.mean(axis=1, keepdims=True)
    return np.sqrt((centred ** 2).sum(axis=-1).mean(axis=1))


def endpoints_of(rounds: Mapping[int, PredictionArrays], windows: WindowArrays,
                 source: str) -> dict[str, Any]:
    """The first round's K endpoints per window (the goals where the file has them, else each
    path's last point): quartiles over windows of their spread (`endpoint_spread`) and of their
    mean distance from the last observed position."""
    first = rounds[min(rounds)]
    at = rows_of(first.window_ids, windows.window_id, source)
    ends = first.samples[at][:, :, -1] if first.goals is None else first.goals[at]  # (N, K, 2)
    reach = np.linalg.norm(ends - windows.past[:, None, -1], axis=-1).mean(axis=1)
    return {"spread_px": quartiles(endpoint_spread(ends)), "reach_px": quartiles(reach)}


def by_motion(errors: Errors, net: np.ndarray) -> dict[str, Any]:
    """`errors.summary()` over the moving and the standing walkers (`STANDING_NET_PX`)."""
    standing = np.asarray(net) < STANDING_NET_PX
    return {"moving": errors.summary(~standing), "standing": errors.summary(standing)}


def goal_vs_path(errors: Errors) -> dict[str, Any]:
    """How the goal error relates to the path error per window (first round): the median of FDE /
    ADE over windows with ADE > 0 and the Pearson correlation of FDE and ADE."""
    ade, fde = errors.ade[0], errors.fde[0]
    positive = ade > 0
    ratio = float(np.median(fde[positive] / ade[positive])) if positive.any() else None
    spread = len(ade) > 1 and ade.std() > 0 and fde.std() > 0
    return {"median_window_fde_over_ade": ratio,
            "pearson_fde_ade": float(np.corrcoef(ade, fde)[0, 1]) if spread else None}


# ---------------------------------------------------------------------------------------------
# Leak check


def window_spans(table: pd.DataFrame) -> pd.DataFrame:
    """One row per window of a window table: scene_id (the video), track_id, split and the first
    and last raw frame it covers (observed and future)."""
    frames = table.groupby("window_id", sort=True)["frame"]
    first = table.groupby("window_id", sort=True)[["scene_id", "track_id", "split"]].first()
    return first.assign(first_frame=frames.min(), last_frame=frames.max()).reset_index()


def overlapping_windows(test: pd.DataFrame, other: pd.DataFrame, same_track: bool) -> int:
    """How many windows of `test` (`window_spans` rows) share frames of their video (and, with
    `same_track`, their track) with at least one window of `other`; closed frame intervals."""
    keys = ["scene_id", "track_id"] if same_track else ["scene_id"]
    pairs = test.reset_index(drop=True).reset_index(names="test_row").merge(
        other[keys + ["first_frame", "last_frame"]], on=keys, suffixes=("", "_other"))
    hit = ((pairs["first_frame"] <= pairs["last_frame_other"])
           & (pairs["first_frame_other"] <= pairs["last_frame"]))
    return int(pairs.loc[hit, "test_row"].nunique())


def leak_check(tables: Mapping[str, pd.DataFrame]) -> dict[str, Any]:
    """For each table's test windows, against the train and val windows of that table
    (`same_table`) and of every table together (`any_table`): test videos that are also train / val
    videos, and test windows sharing frames of a track (`track_windows`) or of a video
    (`time_span_windows`) with a train / val window. Every count is 0 without a leak; `total` sums
    the `any_table` counts (which include the same table's)."""
    spans = {name: window_spans(table) for name, table in tables.items()}
    fitted = {name: s.loc[s["split"].isin(TRAIN_VAL)] for name, s in spans.items()}
    every_fitted = pd.concat(list(fitted.values()), ignore_index=True)

    def counts(test: pd.DataFrame, other: pd.DataFrame) -> dict[str, int]:
        return {"videos": len(set(test["scene_id"]) & set(other["scene_id"])),
                "track_windows": overlapping_windows(test, other, same_track=True),
                "time_span_windows": overlapping_windows(test, other, same_track=False)}

    result: dict[str, Any] = {"tables": {}}
    for name, s in spans.items():
        test = s.loc[s["split"] == TEST]
        result["tables"][name] = {"test_windows": len(test),
                                  "same_table": counts(test, fitted[name]),
                                  "any_table": counts(test, every_fitted)}
    result["total"] = sum(v for row in result["tables"].values() for v in row["any_table"].values())
    test_videos = set().union(*(set(s.loc[s["split"] == TEST, "scene_id"]) for s in spans.values()))
    result["test_videos"] = len(test_videos)
    result["train_val_videos"] = int(every_fitted["scene_id"].nunique())
    return result


# ---------------------------------------------------------------------------------------------
# Y-net's training


def training_curves(history: Path | None, not_run_reason: str | None = None) -> dict[str, Any]:
    """A training `history.csv` (epoch, train_loss, val_ade, val_fde, ...) as lists, with the epoch
    of the lowest validation ADE; {"trained": false, "reason"} where there is none."""
    if history is None or not Path(history).is_file():
        reason = not_run_reason or f"no training history ({history})"
        return {"trained": False, "reason": reason}
    frame = pd.read_csv(history)
    best = int(frame.loc[frame["val_ade"].idxmin(), "epoch"]) if len(frame) else None
    return {"trained": True, "epochs": len(frame), "best_epoch": best,
            **{key: [float(v) for v in frame[key]] for key in ("train_loss", "val_ade", "val_fde")
               if key in frame}}


# ---------------------------------------------------------------------------------------------
# The record


@dataclass(frozen=True)
class HorizonInputs:
    """What one horizon's analysis reads: its test windows and, per model, its stored rounds."""

    t_f: int
    arrays: WindowArrays  # the horizon table's test windows (ids ascending)
    sources: np.ndarray  # (N,) each window's source
    predictions: Mapping[str, tuple[Mapping[int, PredictionArrays], WindowArrays]]
    """model -> (rounds, the test windows they predict): Y-net's 30-s point predicts the release
    table's windows, every other file its horizon table's."""
    not_run: Mapping[str, str]  # model -> why its file holds no predictions


def scored_windows(table: pd.DataFrame, n_past: int) -> tuple[WindowArrays, np.ndarray]:
    """The test windows of a window table as arrays (ids ascending) and each one's source."""
    test = table.loc[table["split"] == TEST]
    arrays = to_arrays(test, n_past)
    sources = test.groupby("window_id", sort=True)["source"].first().to_numpy(str)
    return arrays, sources


def read_horizon(t_f: int, table: pd.DataFrame, folder: Path, n_past: int,
                 subject_file: Path | None = None, subject_table: pd.DataFrame | None = None
                 ) -> tuple[HorizonInputs, dict[str, dict[str, Any]]]:
    """One horizon's test windows (of `table`) and every stored predictions file of `folder`
    (`<model>.parquet`), with `subject_file` as the subject's predictions of `subject_table`'s
    windows where it exists (Y-net's 30-s point is scored on the release windows); and each file's
    metadata, by model."""
    arrays, sources = scored_windows(table, n_past)
    files = {p.stem: (p, arrays) for p in sorted(Path(folder).glob("*.parquet"))}
    if subject_file is not None and Path(subject_file).is_file():
        files[SUBJECT] = (subject_file, scored_windows(subject_table, n_past)[0])
    predictions, not_run, metadata = {}, {}, {}
    for model, (path, windows) in files.items():
        rounds, metadata[model] = read_prediction_rounds(path)
        if NOT_RUN in metadata[model]:
            not_run[model] = metadata[model][NOT_RUN]
        else:
            predictions[model] = (rounds, windows)
    return HorizonInputs(t_f, arrays, sources, predictions, not_run), metadata


@dataclass(frozen=True)
class SubjectRuns:
    """The subject's training curves per horizon and, per horizon it was scored at, the model file
    and its stored predictions' metadata (the sampling to rerun it with), or why there is none."""

    curves: dict[int, dict[str, Any]]
    models: dict[int, tuple[Path, dict[str, Any]] | str]


def subject_runs(horizons: Sequence[int], metadata: Mapping[int, Mapping[str, dict]],
                 models: Mapping[int, Path], histories: Mapping[int, Path]) -> SubjectRuns:
    """Where the subject was scored at t_f (`metadata[t_f]` has its file, not a not-run one) and
    its model file `models[t_f]` exists: that file and its training history `histories[t_f]`;
    elsewhere why not (the not-run file's reason)."""
    curves, found = {}, {}
    for t in horizons:
        meta = metadata.get(t, {}).get(SUBJECT)
        reason = (f"no stored {SUBJECT} predictions at t_f = {t} s" if meta is None
                  else meta.get(NOT_RUN))
        if reason is None and t not in models:
            reason = f"no {SUBJECT} model given for t_f = {t} s"
        elif reason is None and not Path(models[t]).is_file():
            reason = f"no {SUBJECT} model file {models[t]}"
        curves[t] = training_curves(None if reason else histories.get(t), reason)
        found[t] = reason if reason else (models[t], dict(meta))
    return SubjectRuns(curves, found)


def horizon_record(inputs: HorizonInputs, per_window: Collection[str] = ()) -> dict[str, Any]:
    """Data, references and every stored model's scores at one horizon, on its own windows; for
    the models of `per_window` also each window's ADE and FDE (first round, windows in id order)."""
    arrays, seconds = inputs.arrays, float(inputs.t_f)
    net = net_displacements(arrays.past, arrays.future)
    straight = deterministic_errors(straight_to_goal(arrays.past, arrays.future), arrays.future)
    models: dict[str, Any] = {}
    for model, (rounds, windows) in sorted(inputs.predictions.items()):
        errors = score_rounds(rounds, windows, source=f"tf{inputs.t_f}/{model}")
        own_net = net_displacements(windows.past, windows.future)
        models[model] = {**errors.summary(), "by_motion": by_motion(errors, own_net),
                         "goal_vs_path": goal_vs_path(errors),
                         "endpoints": endpoints_of(rounds, windows, f"tf{inputs.t_f}/{model}")}
        if model in per_window:
            models[model]["per_window"] = {"ade": errors.ade[0].tolist(),
                                           "fde": errors.fde[0].tolist()}
    for model, reason in sorted(inputs.not_run.items()):
        models[model] = {"not_run": reason}
    return {"data": data_summary(arrays, inputs.sources, seconds),
            "straight_to_goal": {**straight.summary(), "by_motion": by_motion(straight, net)},
            "models": models}


def one_population(arrays: WindowArrays, horizons: Sequence[int],
                   predictions: Mapping[str, Mapping[int, PredictionArrays]],
                   own: Mapping[int, Mapping[str, Errors | str]]) -> dict[str, Any]:
    """The windows `arrays` of the longest horizon, truncated at every horizon t of `horizons`:
    their data, the straight line to the true position at t, the longest horizon's stored
    `predictions` (model -> rounds) scored over their first t steps, and `own[t]` (model ->
    `Errors` of predictions of t steps made on the truncated windows, or why there are none)."""
    longest = arrays.future.shape[1]
    result: dict[str, Any] = {
        "horizon": longest, "windows": len(arrays),
        "longest_predictions_truncated": (f"the {longest}-s models' stored predictions scored over "
                                          "their first t steps (best of K; FDE at step t)"),
        "own_horizon_models": f"each horizon's own model run on the {longest}-s test windows cut "
                              "at t (best of K; FDE on its goals)",
        "per_horizon": {}}
    for t_f in horizons:
        if t_f > longest:
            continue
        cut = truncated_arrays(arrays, t_f)
        straight = deterministic_errors(straight_to_goal(cut.past, cut.future), cut.future)
        net = net_displacements(cut.past, cut.future)
        result["per_horizon"][f"tf{t_f}"] = {
            "speed_px_s": quartiles(speeds(cut.past, cut.future, float(t_f))),
            "net_displacement_px": quartiles(net),
            "standing_share": standing_share(net),
            "straight_to_goal": straight.summary(),
            "longest_predictions_truncated": {
                model: score_rounds(rounds, arrays, steps=t_f,
                                    source=f"tf{longest}/{model}").summary()
                for model, rounds in sorted(predictions.items())},
            "own_horizon_models": {
                model: (value.summary() if isinstance(value, Errors) else {"not_run": value})
                for model, value in sorted(own.get(t_f, {}).items())},
        }
    return result


def analyse(horizons: Sequence[int], per_horizon: Sequence[HorizonInputs],
            tables: Mapping[str, pd.DataFrame], curves: Mapping[int, dict[str, Any]],
            own: Mapping[int, Mapping[str, Errors | str]],
            per_window: Mapping[int, Collection[str]] | None = None) -> dict[str, Any]:
    """The stage's record: per horizon (`horizon_record`; `per_window`: t_f -> the models whose
    per-window errors it keeps), one population (the longest horizon's test windows,
    `one_population`), the leak check over `tables` (name -> window table), Y-net's training
    `curves` (t_f -> `training_curves`) and the definitions used."""
    per_window = per_window or {}
    by_t = {inputs.t_f: inputs for inputs in per_horizon}
    longest = by_t[max(horizons)]
    stored = {model: rounds for model, (rounds, _) in longest.predictions.items()}
    return {
        "horizons": list(horizons),
        "split": TEST,
        "unit": "px",
        "definitions": {"standing_net_px": STANDING_NET_PX, "slow_speed_px_s": SLOW_SPEED_PX_S},
        "per_horizon": {f"tf{t}": horizon_record(by_t[t], per_window.get(t, ())) for t in horizons},
        "one_population": one_population(longest.arrays, horizons, stored, own),
        "leak_check": leak_check(tables),
        "ynet_training": {f"tf{t}": curves[t] for t in horizons if t in curves},
    }
