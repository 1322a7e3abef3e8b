"""Every metric of `pipeline.harness.scoring` over the stored long-term SDD predictions: one
predictions file (`pipeline.harness.predictions`), the window table its ids refer to, the
hand-labelled class masks and the videos' scales -> one JSON-able record (stage
`score_predictions`, `metrics/beyond/long_term.json`). Nothing here runs a model.

Per model and window table, each stored round is scored on its own, then every metric is given as
mean and (population) std over the rounds, and per scene:

- `ade`, `fde` (best of K, independent minima: the paper's numbers, FDE on Y-net's sampled goals)
  and `ade_joint`, `fde_joint` (both of the sample with the lowest ADE), pixels;
- `ade_best_endpoint`: ADE of the sample whose endpoint is closest to the true one (PECNet), pixels;
- `miss_rate`: share of windows whose best endpoint is further than `miss_threshold_m` metres
  (converted per video with its metres-per-pixel scale);
- `kde_nll`: NLL of the truth under a Gaussian KDE of the K samples, per step clipped at
  `log_pdf_floor`, averaged over steps (per unit^2 of pixels), and `kde_nll_per_step`;
  `kde_degenerate_share`: steps whose samples have no 2-D spread (scored at the floor);
- `off_limits_share`: share of predicted positions (inside the image) on a class in
  `forbidden_classes`, beside the ground truth's (`ground_truth.off_limits_share`);
- `collision_rate`: share of a window's K samples that come closer than `collision_threshold_m`
  metres to the same sample of another agent at a shared raw frame, beside the ground truth's,
  with the share of windows that share any frame with another agent (`copresent_share`).

Predictions are compared with the window table by window id, never by position; a file whose ids
are not in its table, whose benchmark names another table, or whose steps differ from the table's
future is an error naming the file. A file that says why nothing was predicted (`not_run_reason`)
is listed with its reason, not scored.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from pipeline.config import ScorePredictionsParams
from pipeline.data.labels import read_index, read_label_map
from pipeline.data.window_table import conform
from pipeline.harness import scoring
from pipeline.harness.predictions import (NOT_RUN, PredictionArrays, long_term_benchmark,
                                          read_prediction_rounds)
from pipeline.io import IntermediateError

UNIT = "px"  # the long-term SDD benchmark's unit: original image pixels
PATH_METRICS = ("ade", "fde", "ade_joint", "fde_joint", "ade_best_endpoint", "miss_rate",
                "kde_nll", "kde_degenerate_share")  # from the paths alone
SCENE_METRICS = ("off_limits_share", "collision_rate")  # from the paths in their scenes
METRICS = PATH_METRICS + SCENE_METRICS  # every model metric, in the order a record lists them
TRUTH_METRICS = ("off_limits_share", "collision_rate", "copresent_share")  # of the ground truth


# ---------------------------------------------------------------------------------------------
# Inputs: the windows' futures, the scenes' masks and scales


@dataclass(frozen=True)
class WindowTruth:
    """The future of every window of a window table, windows in ascending window_id order."""

    path: Path  # the window table read
    window_ids: np.ndarray  # (N,) int64, ascending
    future: np.ndarray  # (N, T, 2) float64, original image pixels
    frames: np.ndarray  # (N, T) int64, raw frame of each future step
    scenes: np.ndarray  # (N,) str, '<scene>_<video>'
    tracks: np.ndarray  # (N,) int64, the raw track ids (one agent per scene and track)
    t_f: int  # the table's horizon in seconds

    def take(self, window_ids: np.ndarray, source: Path) -> WindowTruth:
        """The windows `window_ids` (N',), in that order; an IntermediateError naming `source` (the
        predictions file asking) for ids the table does not hold."""
        at = np.searchsorted(self.window_ids, window_ids)  # (N',)
        found = at < len(self.window_ids)
        found[found] = self.window_ids[at[found]] == window_ids[found]
        if not found.all():
            missing = window_ids[~found]
            raise IntermediateError(f"{source}: {len(missing)} of {len(window_ids)} window id(s) "
                                    f"are not in {self.path}, e.g. {missing[:5].tolist()}")
        return WindowTruth(self.path, self.window_ids[at], self.future[at], self.frames[at],
                           self.scenes[at], self.tracks[at], self.t_f)


def read_window_truth(path: Path, n_past: int) -> WindowTruth:
    """The future steps (those after the first `n_past`) of every window of the window table at
    `path` (`pipeline.data.window_table`); an IntermediateError naming it if its windows differ
    in length, hold no future step or several horizons."""
    path = Path(path)
    try:
        table = conform(pd.read_parquet(path))
    except (OSError, ValueError) as e:
        raise IntermediateError(f"{path}: not a window table: {e}") from e
    sizes = table.groupby("window_id", sort=True).size()  # (N,)
    if len(sizes) == 0:
        raise IntermediateError(f"{path}: no windows")
    if sizes.nunique() > 1 or int(sizes.iloc[0]) <= n_past:
        raise IntermediateError(f"{path}: windows must all hold {n_past} observed steps and at "
                                f"least one future step, lengths {sorted(sizes.unique().tolist())}")
    horizons = table["t_f"].unique()
    if len(horizons) != 1:
        raise IntermediateError(f"{path}: one t_f per window table, found "
                                f"{sorted(horizons.tolist())}")
    n, length = len(sizes), int(sizes.iloc[0])
    xy = table[["x", "y"]].to_numpy(np.float64).reshape(n, length, 2)  # (N, L, 2)
    frames = table["frame"].to_numpy(np.int64).reshape(n, length)  # (N, L)
    first = table.iloc[::length]  # rows are sorted by window, step: each window's first step
    return WindowTruth(path, sizes.index.to_numpy(np.int64), xy[:, n_past:], frames[:, n_past:],
                       first["scene_id"].to_numpy(str), first["track_id"].to_numpy(np.int64),
                       int(horizons[0]))


def read_scales(path: Path) -> dict[str, float]:
    """{'<scene>_<k>': metres per original image pixel} from SDD's `estimated_scales.yaml`
    ({scene: {video<k>: {scale, certainty}}}); an IntermediateError naming the file and entry."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as e:
        raise IntermediateError(f"{path}: unreadable: {e}") from e
    scales = {}
    for scene, videos in (raw or {}).items():
        for video, entry in (videos or {}).items():
            scale = entry.get("scale") if isinstance(entry, dict) else None
            if not (str(video).startswith("video") and isinstance(scale, int | float)
                    and scale > 0):
                raise IntermediateError(f"{path}: {scene}.{video}: expected video<k> with a "
                                        f"positive scale, got {entry!r}")
            scales[f"{scene}_{str(video)[len('video'):]}"] = float(scale)
    return scales


class SceneMaps:
    """The hand-labelled class masks (`data/labels`, at the original image resolution) and the
    metres per pixel of the SDD videos; a mask is read on first use."""

    def __init__(self, labels_dir: Path, scales_path: Path):
        self.labels_dir = Path(labels_dir)
        self.sizes = read_index(self.labels_dir)["videos"]  # name -> {height, width, ...}
        self.scales_path = Path(scales_path)
        self.scales = read_scales(scales_path)
        self.masks: dict[str, np.ndarray] = {}  # read so far

    def mask(self, name: str) -> np.ndarray:
        """(H, W) class values of video `name`, checked against the index's size."""
        if name in self.masks:
            return self.masks[name]
        if name not in self.sizes:
            raise IntermediateError(f"{self.labels_dir}/index.json has no video {name!r}")
        mask = read_label_map(self.labels_dir, name)
        size = (self.sizes[name]["height"], self.sizes[name]["width"])
        if mask.shape != size:
            raise IntermediateError(f"{self.labels_dir}/maps/{name}.png is {mask.shape}, "
                                    f"index.json says {size}")
        self.masks[name] = mask
        return mask

    def metres_per_pixel(self, names: Sequence[str]) -> np.ndarray:
        """(len(names),) the scale of each video named."""
        missing = sorted(set(names) - set(self.scales))
        if missing:
            raise IntermediateError(f"{self.scales_path} has no scale for {missing}")
        return np.array([self.scales[name] for name in names], dtype=np.float64)


# ---------------------------------------------------------------------------------------------
# One round, one file


@dataclass(frozen=True)
class SceneInputs:
    """The windows of one predictions file in their scenes: everything but the predictions."""

    truth: WindowTruth
    scene_index: np.ndarray  # (N,) int, index into masks
    masks: list[np.ndarray]  # per scene (H, W)
    metres_per_pixel: np.ndarray  # (N,)
    forbidden: tuple[int, ...]  # class values a pedestrian cannot stand on


def scene_inputs(truth: WindowTruth, maps: SceneMaps, params: ScorePredictionsParams
                 ) -> SceneInputs:
    names, index = np.unique(truth.scenes, return_inverse=True)
    return SceneInputs(truth, index.reshape(-1), [maps.mask(str(n)) for n in names],
                       maps.metres_per_pixel(truth.scenes.tolist()),
                       scoring.class_values(params.forbidden_classes))


def off_limits_share(positions: np.ndarray, inputs: SceneInputs) -> np.ndarray:
    """(N,) share of positions (N, ..., 2) inside the image that lie on a forbidden class."""
    status = scoring.scene_compliance(positions, inputs.scene_index, inputs.masks,
                                      inputs.forbidden)
    return scoring.forbidden_share(status)


def collisions(samples: np.ndarray, inputs: SceneInputs, threshold_m: float
               ) -> scoring.Collisions:
    """`scoring.collisions` of samples (N, K, T, 2) in metres (each window scaled by its video's
    metres per pixel), between windows of different tracks in one video sharing a raw frame."""
    to_m, truth = inputs.metres_per_pixel, inputs.truth
    return scoring.collisions(samples * to_m[:, None, None, None],
                              truth.future * to_m[:, None, None], truth.scenes, truth.frames,
                              threshold_m, agents=truth.tracks)


def score_round(arrays: PredictionArrays, inputs: SceneInputs, params: ScorePredictionsParams
                ) -> tuple[dict[str, np.ndarray], np.ndarray, scoring.Collisions]:
    """Per window (N,): every metric of `METRICS` for one round; the NLL per window and step
    (N, T); and the collisions (whose ground-truth part is the same every round)."""
    future, to_m = inputs.truth.future, inputs.metres_per_pixel
    paths, nll = scoring.trajectory_scores(arrays.samples, future, params.miss_threshold_m / to_m,
                                           goals=arrays.goals, log_pdf_floor=params.log_pdf_floor)
    hits = collisions(arrays.samples, inputs, params.collision_threshold_m)
    per_window = {**{k: paths[k] for k in ("ade", "fde", "ade_joint", "fde_joint",
                                           "ade_best_endpoint")},
                  "miss_rate": paths["miss"], "kde_nll": paths["kde_nll"],
                  "kde_degenerate_share": paths["kde_degenerate"],
                  "off_limits_share": off_limits_share(arrays.samples, inputs),
                  "collision_rate": hits.pred_share}
    return per_window, nll, hits


def over_rounds(values: Sequence[float | None]) -> dict[str, float] | None:
    """{"mean", "std"} (population std: 0 for one round) of the rounds' values; None where no
    round has one (e.g. no window inside the masks)."""
    held = np.array([v for v in values if v is not None], dtype=np.float64)
    return {"mean": float(held.mean()), "std": float(held.std())} if len(held) else None


def summarise_rounds(rounds: list[dict[str, Any]], scenes: np.ndarray) -> dict[str, Any]:
    """`scoring.aggregate` of each round's per-window metrics, summarised over the rounds:
    {"metrics": {name: {mean, std, per_round}}, "per_scene": {scene: {"n_windows",
    "metrics": {name: {mean, std}}}}}."""
    means = [scoring.aggregate(r, scenes) for r in rounds]
    metrics = {name: {**(over_rounds([m["window_mean"][name] for m in means]) or {}),
                      "per_round": [m["window_mean"][name] for m in means]}
               for name in METRICS}
    per_scene = {scene: {"n_windows": entry["n_windows"],
                         "metrics": {name: over_rounds([m["per_scene"][scene][name]
                                                        for m in means]) for name in METRICS}}
                 for scene, entry in means[0]["per_scene"].items()}
    return {"metrics": metrics, "per_scene": per_scene}


def check_file(path: Path, metadata: Mapping[str, Any], table: Path) -> None:
    """An IntermediateError naming `path` unless it holds pixel predictions on `table`'s windows."""
    wanted = long_term_benchmark(table)
    if metadata.get("benchmark") != wanted:
        raise IntermediateError(f"{path}: benchmark {metadata.get('benchmark')!r}, but it is "
                                f"scored against {table} ({wanted!r})")
    if metadata.get("unit") != UNIT:
        raise IntermediateError(f"{path}: unit {metadata.get('unit')!r}, expected {UNIT!r}")


def score_file(path: Path, truth: WindowTruth, maps: SceneMaps, params: ScorePredictionsParams
               ) -> dict[str, Any]:
    """The record of one predictions file scored against the windows `truth` of its table (see the
    module docstring), or {"file", "model", "not_run_reason"} for a file with no predictions."""
    path = Path(path)
    try:
        by_round, metadata = read_prediction_rounds(path)
    except (OSError, ValueError) as e:  # pyarrow's errors are OSError or ValueError
        raise IntermediateError(e if str(e).startswith(str(path)) else f"{path}: {e}") from e
    check_file(path, metadata, truth.path)
    head = {"file": path.as_posix(), "model": metadata["model"]}
    if NOT_RUN in metadata:
        return {**head, NOT_RUN: metadata[NOT_RUN]}
    first = by_round[0]
    n, k, t, _ = first.samples.shape
    windows = truth.take(first.window_ids, path)
    if t != windows.future.shape[1]:
        raise IntermediateError(f"{path}: {t} predicted steps, but the windows of {truth.path} "
                                f"have {windows.future.shape[1]} future steps")
    inputs = scene_inputs(windows, maps, params)
    rounds, nll_steps, hits = [], [], None
    for arrays in by_round.values():
        per_window, nll, hits = score_round(arrays, inputs, params)
        rounds.append(per_window)
        nll_steps.append(nll.mean(axis=0))  # (T,) mean over windows
    steps = np.stack(nll_steps)  # (R, T)
    truth_values = {"off_limits_share": off_limits_share(windows.future, inputs),
                    "collision_rate": hits.truth, "copresent_share": hits.copresent}
    truth_means = scoring.aggregate(truth_values, windows.scenes)
    summary = summarise_rounds(rounds, windows.scenes)
    for scene, entry in summary["per_scene"].items():
        entry["ground_truth"] = {name: truth_means["per_scene"][scene][name]
                                 for name in TRUTH_METRICS}
    return {**head, "rounds": len(by_round), "seeds": metadata["seeds"], "k": k, "t": t,
            "n_windows": n, "n_scenes": truth_means["n_scenes"], "metrics": summary["metrics"],
            "kde_nll_per_step": {"mean": steps.mean(axis=0).tolist(),
                                 "std": steps.std(axis=0).tolist()},
            "ground_truth": truth_means["window_mean"], "per_scene": summary["per_scene"]}


# ---------------------------------------------------------------------------------------------
# Every table


def prediction_files(folder: Path) -> list[Path]:
    """The predictions files of one window table (`<folder>/<model>.parquet`), sorted; an
    IntermediateError naming the folder when there is none."""
    files = sorted(Path(folder).glob("*.parquet"))
    if not files:
        raise IntermediateError(f"{folder}: no predictions file (<model>.parquet) to score")
    return files


def score_tables(tables: Mapping[str, Path], predictions: Path, n_past: int, maps: SceneMaps,
                 params: ScorePredictionsParams) -> dict[str, Any]:
    """The whole record: every predictions file `<predictions>/<name>/<model>.parquet` of every
    window table `tables` {name: window table path}, scored (`score_file`), with the thresholds
    used and the seconds it took (`score_seconds`)."""
    start = time.perf_counter()
    scored = {}
    for name, table in tables.items():
        truth = read_window_truth(table, n_past)
        models = {path.stem: score_file(path, truth, maps, params)
                  for path in prediction_files(Path(predictions) / name)}
        scored[name] = {"window_table": Path(table).as_posix(), "t_f": truth.t_f,
                        "models": models}
    return {"unit": UNIT, "thresholds": dataclasses.asdict(params), "tables": scored,
            "score_seconds": time.perf_counter() - start}
