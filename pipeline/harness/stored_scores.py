"""Every metric of `pipeline.harness.scoring` over stored predictions (`pipeline.harness.predictions`):
one predictions file, the window table its ids refer to, and what its benchmark needs besides
(a `Benchmark`: unit, truth columns, metres per unit, scene masks) -> one JSON-able record. Nothing
here runs a model. The long-term benchmarks are described here (SDD's horizon and release tables:
`long_term_benchmark_spec`; inD: `ind_benchmark_spec`), the short-term ones in
`pipeline.harness.stored_short_term`; stages `score_predictions` and `score_short_term_predictions`
write the records (`metrics/beyond/{long_term,ind,short_term}.json`).

Per model and benchmark, each stored round is scored on its own, then every metric is given as
mean and (population) std over the rounds, and per scene:

- `ade`, `fde` (best of K, independent minima: the paper's numbers, FDE on Y-net's sampled goals)
  and `ade_joint`, `fde_joint` (both of the sample with the lowest ADE), in the benchmark's unit;
- `ade_best_endpoint`: ADE of the sample whose endpoint is closest to the true one (PECNet);
- `ade_sgan_sequence`, `fde_sgan_sequence`: S-GAN's protocol (`scoring.sequence_joint_min`): one
  best sample per sequence, the windows of a scene that start at the same frame
  (`scoring.sgan_sequences`; for ETH/UCY exactly S-GAN's sequences, for SDD and inD S-GAN's rule
  applied to these windows). A number of a set of windows, not a mean over them: per round over
  all windows, per scene over the scene's windows;
- `ade_one_sample`, `fde_one_sample` (`scoring.one_sample_ade_fde`): per window the mean over the
  K samples of each sample's ADE / FDE (FDE on Y-net's goals), the expected error of one sample
  drawn at random: the model's K = 1 score from its stored K, nothing sampled again;
- `miss_rate`: share of windows whose best endpoint is further than `miss_threshold_m` metres
  (converted per scene with its metres per unit: SDD's per-video scales, inD's per recording;
  1 where the unit is metres);
- `kde_nll`: NLL of the truth under a Gaussian KDE of the K samples, per step clipped at
  `log_pdf_floor`, averaged over steps (a density per unit^2: pixels^2 or metres^2), and
  `kde_nll_per_step`; `kde_degenerate_share`: steps whose samples have no 2-D spread (scored at
  the floor);
- `off_limits_share`: share of predicted positions (inside a scene's mask) on a forbidden class
  (`Benchmark.masks`: SDD's and inD's hand labels, classes `forbidden_classes`; ETH/UCY's not-road),
  beside the ground truth's (`ground_truth.off_limits_share`); null where no window has a mask;
- `collision_rate`: share of a window's K samples that come closer than `collision_threshold_m`
  metres to the same sample of another agent at a shared raw frame, beside the ground truth's,
  with the share of windows that share any frame with another agent (`copresent_share`). Where a
  benchmark cuts a window at every frame (ETH/UCY: `Benchmark.same_start_collisions`), only windows
  that start at the same frame are compared, one sequence as SGAN's loader groups its agents:
  otherwise each neighbour would meet a window in up to 2 n_f - 1 overlapping windows, each with
  its own independent samples, and the rate would grow with the overlap instead of the model.

Predictions are compared with the window table by window id, never by position; a file whose ids
are not in its table (or not in the benchmark's split), whose benchmark, unit or truth columns are
not the benchmark's, or whose steps differ from the table's future is an error naming the file. A
file that says why nothing was predicted (`not_run_reason`) is listed with its reason, not scored.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pandas as pd
import yaml

from pipeline.config import ScorePredictionsParams
from pipeline.data.labels import read_index, read_label_map
from pipeline.data.window_table import conform
from pipeline.harness import scoring
from pipeline.harness.predictions import (IND_BENCHMARK, NOT_RUN, PredictionArrays,
                                          long_term_benchmark, read_prediction_rounds)
from pipeline.io import IntermediateError, index_value, read_json_index

UNIT = "px"  # the long-term SDD benchmark's unit: original image pixels
PATH_METRICS = ("ade", "fde", "ade_joint", "fde_joint", "ade_best_endpoint", "miss_rate",
                "kde_nll", "kde_degenerate_share")  # from the paths alone
SCENE_METRICS = ("off_limits_share", "collision_rate")  # from the paths in their scenes
SEQUENCE_METRICS = (scoring.ADE_SGAN_SEQUENCE, scoring.FDE_SGAN_SEQUENCE)  # one per set of windows
ONE_SAMPLE_METRICS = (scoring.ADE_ONE_SAMPLE, scoring.FDE_ONE_SAMPLE)  # K = 1 from the K samples
WINDOW_METRICS = PATH_METRICS + SCENE_METRICS + ONE_SAMPLE_METRICS  # one value per window, averaged
# Every model metric, in the order a record lists them (the later additions last).
METRICS = PATH_METRICS + SCENE_METRICS + SEQUENCE_METRICS + ONE_SAMPLE_METRICS
TRUTH_METRICS = ("off_limits_share", "collision_rate", "copresent_share")  # of the ground truth


# ---------------------------------------------------------------------------------------------
# Inputs: the windows' futures


@dataclass(frozen=True)
class WindowTruth:
    """The future of every window of a window table, windows in ascending window_id order."""

    path: Path  # the window table read
    window_ids: np.ndarray  # (N,) int64, ascending
    future: np.ndarray  # (N, T, 2) float64, in the benchmark's unit (the truth columns)
    frames: np.ndarray  # (N, T) int64, raw frame of each future step
    first_frame: np.ndarray  # (N,) int64, raw frame of the first observed step
    scenes: np.ndarray  # (N,) str, the table's scene_id ('<scene>_<video>' for SDD)
    tracks: np.ndarray  # (N,) int64, the raw track ids (one agent per scene and track)
    t_f: int  # the table's t_f (seconds; the short-term tables hold n_f, the future steps)

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
                           self.first_frame[at], self.scenes[at], self.tracks[at], self.t_f)


def read_window_truth(path: Path, n_past: int, columns: Sequence[str] = ("x", "y"),
                      split: str | None = None) -> WindowTruth:
    """The future steps (those after the first `n_past`) of every window of the window table at
    `path` (`pipeline.data.window_table`), positions from `columns` (e.g. ETH/UCY's metres `x_m`,
    `y_m`), only the windows of `split` where given (ids of other splits are then "not in" the
    table); an IntermediateError naming the table if it lacks a column, its windows differ in
    length, hold no future step or several horizons, or none is of `split`."""
    path = Path(path)
    try:
        raw = pd.read_parquet(path)
        missing = [c for c in columns if c not in raw.columns]
        if missing:
            raise ValueError(f"no truth column(s) {missing}")
        x, y = columns
        table = conform(raw.assign(x=raw[x], y=raw[y]))
    except (OSError, ValueError) as e:
        raise IntermediateError(f"{path}: not a window table: {e}") from e
    if split is not None:
        table = table.loc[table["split"] == split].reset_index(drop=True)
    sizes = table.groupby("window_id", sort=True).size()  # (N,)
    if len(sizes) == 0:
        raise IntermediateError(f"{path}: no windows" + (f" of split {split!r}" if split else ""))
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
                       frames[:, 0], first["scene_id"].to_numpy(str),
                       first["track_id"].to_numpy(np.int64), int(horizons[0]))


# ---------------------------------------------------------------------------------------------
# Inputs: scales and scene masks


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


@dataclass
class SceneMasks:
    """A benchmark's class masks, one per scene that has one, and how a position in the benchmark's
    unit lands on them: through `to_pixels` (unit -> original image pixels of the scene; none for
    a benchmark in pixels), then at `scale` mask pixels per original pixel
    (`scoring.mask_pixels`). A mask is read on first use."""

    source: str  # where the masks come from, for the record
    forbidden: tuple[int, ...]  # class values a pedestrian cannot stand on
    forbidden_names: tuple[str, ...]  # their names, for the record
    names: frozenset[str]  # the scenes that have a mask
    read: Callable[[str], np.ndarray]  # scene -> (H, W) class values
    scale: float = 1.0
    to_pixels: Callable[[np.ndarray, str], np.ndarray] | None = None
    masks: dict[str, np.ndarray] = field(default_factory=dict)  # read so far

    def mask(self, name: str) -> np.ndarray:
        if name not in self.masks:
            self.masks[name] = self.read(name)
        return self.masks[name]

    def share(self, positions: np.ndarray, scenes: np.ndarray) -> np.ndarray:
        """(N,) share of a window's positions (N, ..., 2) inside its scene's mask that lie on a
        forbidden class (`scoring.forbidden_share`); NaN where the scene has no mask or no
        position lies inside it."""
        share = np.full(len(positions), np.nan)
        rows = np.flatnonzero(np.isin(scenes, sorted(self.names)))
        if not len(rows):
            return share
        names, index = np.unique(scenes[rows], return_inverse=True)
        index = index.reshape(-1)
        points = positions[rows]
        if self.to_pixels is not None:
            points = np.array(points, dtype=np.float64)
            for i, name in enumerate(names):
                points[index == i] = self.to_pixels(points[index == i], str(name))
        status = scoring.scene_compliance(points, index, [self.mask(str(n)) for n in names],
                                          self.forbidden, self.scale)
        share[rows] = scoring.forbidden_share(status)
        return share

    def coverage(self, scenes: np.ndarray) -> dict[str, Any]:
        """Which of the windows (their `scenes` (N,)) had a mask, for the record."""
        held = sorted(set(np.unique(scenes).tolist()))
        with_mask = [s for s in held if s in self.names]
        return {"source": self.source, "forbidden_classes": list(self.forbidden_names),
                "scenes_with_mask": with_mask,
                "scenes_without_mask": [s for s in held if s not in self.names],
                "windows_with_mask": int(np.isin(scenes, with_mask).sum()),
                "n_windows": int(len(scenes))}


def sdd_label_masks(labels_dir: Path, forbidden_classes: Sequence[str]) -> SceneMasks:
    """SDD's hand-labelled class masks (`data/labels`, at the original image resolution, every
    video the index lists), each checked against the index's size when read."""
    labels_dir = Path(labels_dir)
    sizes = read_index(labels_dir)["videos"]  # name -> {height, width, ...}

    def read(name: str) -> np.ndarray:
        mask = read_label_map(labels_dir, name)
        size = (sizes[name]["height"], sizes[name]["width"])
        if mask.shape != size:
            raise IntermediateError(f"{labels_dir}/maps/{name}.png is {mask.shape}, "
                                    f"index.json says {size}")
        return mask

    return SceneMasks(f"hand labels {labels_dir.as_posix()}",
                      scoring.class_values(forbidden_classes), tuple(forbidden_classes),
                      frozenset(sizes), read)


# ---------------------------------------------------------------------------------------------
# Benchmarks


@dataclass
class Benchmark:
    """How the predictions files of one window table are scored: what their metadata must say
    (`name`, `unit`, `truth_columns`, `split`), where the truth is (`table`, `n_past`), metres per
    unit per scene (`metres_per_unit`; None: the unit is metres) and the scenes' masks (`masks`,
    or why there are none: `masks_absent`). The table is read on first use (`truth`): a benchmark
    whose files all say why nothing was predicted (inD not provided) never reads it."""

    name: str  # the metadata `benchmark` its files give
    table: Path
    unit: str  # px | m
    n_past: int
    truth_columns: tuple[str, str] = ("x", "y")
    split: str | None = None  # the windows its files may predict (None: every window)
    metres_per_unit: Mapping[str, float] | None = None
    scales_source: str = "the unit is metres"  # for the record
    masks: SceneMasks | None = None
    masks_absent: str | None = None
    same_start_collisions: bool = False  # collisions only between windows starting together
    read_truth: WindowTruth | None = None  # cached

    def truth(self) -> WindowTruth:
        if self.read_truth is None:
            self.read_truth = read_window_truth(self.table, self.n_past, self.truth_columns,
                                                self.split)
        return self.read_truth

    def to_metres(self, scenes: np.ndarray, source: Path) -> np.ndarray:
        """(N,) metres per unit of each window's scene; an IntermediateError naming `source` (the
        predictions file) for a scene without a scale."""
        if self.metres_per_unit is None:
            return np.ones(len(scenes))
        missing = sorted(set(scenes.tolist()) - set(self.metres_per_unit))
        if missing:
            raise IntermediateError(f"{source}: no metres per {self.unit} for scene(s) "
                                    f"{missing[:5]} ({self.scales_source})")
        return np.array([self.metres_per_unit[s] for s in scenes.tolist()], dtype=np.float64)

    def describe(self) -> dict[str, Any]:
        """What the record says about the benchmark (and, once read, its windows)."""
        out = {"benchmark": self.name, "window_table": Path(self.table).as_posix(),
               "unit": self.unit, "truth_columns": list(self.truth_columns), "split": self.split,
               "metres_per_unit": self.scales_source,
               "collision_partners": ("windows of another track starting at the same frame"
                                      if self.same_start_collisions else
                                      "windows of another track sharing a raw frame")}
        if self.read_truth is not None:
            truth = self.read_truth
            out.update(n_windows=len(truth.window_ids), n_future=int(truth.future.shape[1]),
                       t_f=truth.t_f)
            out["scene_masks"] = (self.masks.coverage(truth.scenes) if self.masks is not None
                                  else {"absent": self.masks_absent})
        return out


def long_term_benchmark_spec(table: Path, n_past: int, masks: SceneMasks,
                             scales: Mapping[str, float], scales_path: Path) -> Benchmark:
    """A long-term SDD window table (`pipeline.harness.predictions.long_term_benchmark`): original
    pixels, every window, the hand labels and SDD's estimated scales."""
    return Benchmark(long_term_benchmark(table), Path(table), UNIT, n_past,
                     metres_per_unit=scales, scales_source=f"per video, {Path(scales_path)}",
                     masks=masks)


def ind_benchmark_spec(ind_dir: Path, forbidden_classes: Sequence[str]) -> Benchmark:
    """inD (stage `ind_windows`' folder): the t_f = `horizon` table's test windows in pixels of each
    recording's background, metres per pixel orthoPxToMeter x `background_scale` per recording,
    the hand-labelled masks the index names (`labels`, in `ynet.segmentation.CLASS_NAMES` values)
    where there are any. inD not provided: no scales and no masks, the index's reason why."""
    ind_dir = Path(ind_dir)
    path = ind_dir / "index.json"
    index = read_json_index(path)
    horizon = index_value(index, "horizon", int, path)
    tables = index_value(index, "tables", dict, path)
    table = ind_dir / index_value(tables, str(horizon), str, path, "tables.")
    n_past = index_value(index, "n_past", int, path)
    if not index_value(index, "provided", bool, path):
        reason = index_value(index, "reason", str, path)
        return Benchmark(IND_BENCHMARK, table, UNIT, n_past, split="test", metres_per_unit={},
                         scales_source=f"inD not provided: {reason}",
                         masks_absent=f"inD not provided: {reason}")
    background = index_value(index, "background_scale", float, path)
    scenes = index_value(index, "scenes", dict, path)
    scales, labelled = {}, {}
    for name in scenes:
        entry = index_value(scenes, name, dict, path, "scenes.")
        where = f"scenes.{name}."
        scales[name] = index_value(entry, "ortho_px_to_meter", float, path, where) * background
        if not 0 < scales[name] < float("inf"):
            raise IntermediateError(f"{path}: {where}ortho_px_to_meter: expected a positive "
                                    f"scale, got {entry['ortho_px_to_meter']}")
        labels = index_value(entry, "labels", str | None, path, where)
        if labels is not None:
            labelled[name] = (ind_dir / labels, (index_value(entry, "height", int, path, where),
                                                 index_value(entry, "width", int, path, where)))

    def read(name: str) -> np.ndarray:
        mask_path, size = labelled[name]
        mask = cv2.imread(str(mask_path), cv2.IMREAD_UNCHANGED)
        if mask is None or mask.shape != size:
            raise IntermediateError(f"{mask_path}: expected a {size} mask (H, W), got "
                                    f"{None if mask is None else mask.shape}")
        return mask

    masks = (SceneMasks(f"hand labels {ind_dir.as_posix()}/labels",
                        scoring.class_values(forbidden_classes), tuple(forbidden_classes),
                        frozenset(labelled), read) if labelled else None)
    return Benchmark(IND_BENCHMARK, table, UNIT, n_past, split="test", metres_per_unit=scales,
                     scales_source=f"per recording, orthoPxToMeter x {background:g} ({path})",
                     masks=masks, masks_absent=None if labelled else
                     "no hand-labelled inD mask (data.ind.labels not set)")


# ---------------------------------------------------------------------------------------------
# One round, one file


@dataclass(frozen=True)
class SceneInputs:
    """The windows of one predictions file in their scenes: everything but the predictions."""

    truth: WindowTruth
    metres_per_unit: np.ndarray  # (N,)
    masks: SceneMasks | None
    same_start: bool = False  # collisions only between windows starting at the same frame


def off_limits_share(positions: np.ndarray, inputs: SceneInputs) -> np.ndarray:
    """(N,) share of positions (N, ..., 2) inside their scene's mask that lie on a forbidden
    class; NaN where there is no mask."""
    if inputs.masks is None:
        return np.full(len(positions), np.nan)
    return inputs.masks.share(positions, inputs.truth.scenes)


def collisions(samples: np.ndarray, inputs: SceneInputs, threshold_m: float
               ) -> scoring.Collisions:
    """`scoring.collisions` of samples (N, K, T, 2) in metres (each window scaled by its scene's
    metres per unit), between windows of different tracks in one scene sharing a raw frame; with
    `inputs.same_start`, only between those whose first future frame (hence start) is the same."""
    to_m, truth = inputs.metres_per_unit, inputs.truth
    groups = truth.scenes
    if inputs.same_start:
        groups = np.array([f"{scene}@{frame}" for scene, frame
                           in zip(truth.scenes.tolist(), truth.frames[:, 0].tolist())])
    return scoring.collisions(samples * to_m[:, None, None, None],
                              truth.future * to_m[:, None, None], groups, truth.frames,
                              threshold_m, agents=truth.tracks)


def score_round(arrays: PredictionArrays, inputs: SceneInputs, params: ScorePredictionsParams
                ) -> tuple[dict[str, np.ndarray], np.ndarray, scoring.Collisions]:
    """Per window (N,): every metric of `WINDOW_METRICS` for one round; the NLL per window and step
    (N, T); and the collisions (whose ground-truth part is the same every round)."""
    future, to_m = inputs.truth.future, inputs.metres_per_unit
    paths, nll = scoring.trajectory_scores(arrays.samples, future, params.miss_threshold_m / to_m,
                                           goals=arrays.goals, log_pdf_floor=params.log_pdf_floor)
    hits = collisions(arrays.samples, inputs, params.collision_threshold_m)
    per_window = {**{k: paths[k] for k in ("ade", "fde", "ade_joint", "fde_joint",
                                           "ade_best_endpoint")},
                  "miss_rate": paths["miss"], "kde_nll": paths["kde_nll"],
                  "kde_degenerate_share": paths["kde_degenerate"],
                  "off_limits_share": off_limits_share(arrays.samples, inputs),
                  "collision_rate": hits.pred_share,
                  **scoring.one_sample_ade_fde(arrays.samples, future, arrays.goals)}
    return per_window, nll, hits


def over_rounds(values: Sequence[float | None]) -> dict[str, float] | None:
    """{"mean", "std"} (population std: 0 for one round) of the rounds' values; None where no
    round has one (e.g. no window inside the masks)."""
    held = np.array([v for v in values if v is not None], dtype=np.float64)
    return {"mean": float(held.mean()), "std": float(held.std())} if len(held) else None


def sequence_round(arrays: PredictionArrays, truth: WindowTruth) -> dict[str, Any]:
    """One round's `SEQUENCE_METRICS` (`scoring.sgan_sequence_scores`): {"all": {name: value},
    "per_scene": {scene: {name: value}}}, sequences by scene and first frame."""
    sequences = scoring.sgan_sequences(truth.scenes, truth.first_frame)  # (N,)
    return scoring.sgan_sequence_scores(arrays.samples, truth.future, sequences, truth.scenes,
                                        goals=arrays.goals)


def summarise_rounds(rounds: list[dict[str, Any]], scenes: np.ndarray,
                     sequence_rounds: list[dict[str, Any]]) -> dict[str, Any]:
    """`scoring.aggregate` of each round's per-window metrics (`WINDOW_METRICS`), with each
    round's `sequence_round` (`SEQUENCE_METRICS`), summarised over the rounds:
    {"metrics": {name: {mean, std, per_round}}, "per_scene": {scene: {"n_windows",
    "metrics": {name: {mean, std}}}}}."""
    means = [scoring.aggregate(r, scenes) for r in rounds]
    per_round = {name: [m["window_mean"][name] for m in means] for name in WINDOW_METRICS}
    per_round.update({name: [s["all"][name] for s in sequence_rounds]
                      for name in SEQUENCE_METRICS})
    metrics = {name: {**(over_rounds(per_round[name]) or {}), "per_round": per_round[name]}
               for name in METRICS}

    def scene_rounds(scene: str, name: str) -> list[float | None]:
        if name in SEQUENCE_METRICS:
            return [s["per_scene"][scene][name] for s in sequence_rounds]
        return [m["per_scene"][scene][name] for m in means]

    per_scene = {scene: {"n_windows": entry["n_windows"],
                         "metrics": {name: over_rounds(scene_rounds(scene, name))
                                     for name in METRICS}}
                 for scene, entry in means[0]["per_scene"].items()}
    return {"metrics": metrics, "per_scene": per_scene}


def check_file(path: Path, metadata: Mapping[str, Any], benchmark: Benchmark) -> None:
    """An IntermediateError naming `path` unless its metadata says it holds predictions of
    `benchmark`: its name, unit, and (where the metadata gives them) truth columns and split."""
    if metadata.get("benchmark") != benchmark.name:
        raise IntermediateError(f"{path}: benchmark {metadata.get('benchmark')!r}, but it is "
                                f"scored against {benchmark.table} ({benchmark.name!r})")
    if metadata.get("unit") != benchmark.unit:
        raise IntermediateError(f"{path}: unit {metadata.get('unit')!r}, expected "
                                f"{benchmark.unit!r}")
    columns = metadata.get("truth_columns")
    if columns is not None and list(columns) != list(benchmark.truth_columns):
        raise IntermediateError(f"{path}: truth columns {columns!r}, but {benchmark.name} is "
                                f"scored on {list(benchmark.truth_columns)}")
    split = metadata.get("split")
    if benchmark.split is not None and split is not None and split != benchmark.split:
        raise IntermediateError(f"{path}: split {split!r}, but {benchmark.name} scores the "
                                f"{benchmark.split!r} windows")


def read_file(path: Path) -> tuple[dict[int, PredictionArrays], dict[str, Any]]:
    """`read_prediction_rounds`, its errors naming the file."""
    try:
        return read_prediction_rounds(path)
    except (OSError, ValueError) as e:  # pyarrow's errors are OSError or ValueError
        raise IntermediateError(e if str(e).startswith(str(path)) else f"{path}: {e}") from e


def score_file(path: Path, benchmark: Benchmark, params: ScorePredictionsParams
               ) -> dict[str, Any]:
    """The record of one predictions file scored against the windows of its benchmark (see the
    module docstring), or {"file", "model", "not_run_reason"} for a file with no predictions."""
    path = Path(path)
    by_round, metadata = read_file(path)
    check_file(path, metadata, benchmark)
    head = {"file": path.as_posix(), "model": metadata["model"]}
    if NOT_RUN in metadata:
        return {**head, NOT_RUN: metadata[NOT_RUN]}
    truth = benchmark.truth()
    first = by_round[0]
    n, k, t, _ = first.samples.shape
    windows = truth.take(first.window_ids, path)
    if t != windows.future.shape[1]:
        raise IntermediateError(f"{path}: {t} predicted steps, but the windows of {truth.path} "
                                f"have {windows.future.shape[1]} future steps")
    inputs = SceneInputs(windows, benchmark.to_metres(windows.scenes, path), benchmark.masks,
                         benchmark.same_start_collisions)
    rounds, sequence_rounds, nll_steps, hits = [], [], [], None
    for arrays in by_round.values():
        per_window, nll, hits = score_round(arrays, inputs, params)
        rounds.append(per_window)
        sequence_rounds.append(sequence_round(arrays, windows))
        nll_steps.append(nll.mean(axis=0))  # (T,) mean over windows
    steps = np.stack(nll_steps)  # (R, T)
    truth_values = {"off_limits_share": off_limits_share(windows.future, inputs),
                    "collision_rate": hits.truth, "copresent_share": hits.copresent}
    truth_means = scoring.aggregate(truth_values, windows.scenes)
    summary = summarise_rounds(rounds, windows.scenes, sequence_rounds)
    for scene, entry in summary["per_scene"].items():
        entry["ground_truth"] = {name: truth_means["per_scene"][scene][name]
                                 for name in TRUTH_METRICS}
    return {**head, "rounds": len(by_round), "seeds": metadata["seeds"], "k": k, "t": t,
            "n_windows": n, "n_scenes": truth_means["n_scenes"], "metrics": summary["metrics"],
            "kde_nll_per_step": {"mean": steps.mean(axis=0).tolist(),
                                 "std": steps.std(axis=0).tolist()},
            "ground_truth": truth_means["window_mean"], "per_scene": summary["per_scene"]}


# ---------------------------------------------------------------------------------------------
# Every file of a benchmark, every benchmark


def prediction_files(folder: Path) -> list[Path]:
    """The predictions files of one benchmark (`<folder>/<model>.parquet`), sorted; an
    IntermediateError naming the folder when there is none."""
    files = sorted(Path(folder).glob("*.parquet"))
    if not files:
        raise IntermediateError(f"{folder}: no predictions file (<model>.parquet) to score")
    return files


def score_models(folder: Path, benchmark: Benchmark, params: ScorePredictionsParams
                 ) -> dict[str, Any]:
    """{model: `score_file`} of every `<folder>/<model>.parquet`."""
    return {path.stem: score_file(path, benchmark, params) for path in prediction_files(folder)}


def score_tables(tables: Mapping[str, Benchmark], predictions: Path,
                 params: ScorePredictionsParams) -> dict[str, Any]:
    """The long-term SDD record: every predictions file `<predictions>/<name>/<model>.parquet` of
    every window table `tables` {name: its `long_term_benchmark_spec`}, scored (`score_file`), with
    the thresholds used and the seconds it took (`score_seconds`):
    {"unit", "thresholds", "tables": {name: {"window_table", "t_f", "models"}}, "score_seconds"}."""
    start = time.perf_counter()
    scored = {}
    for name, benchmark in tables.items():
        truth = benchmark.truth()
        scored[name] = {"window_table": Path(benchmark.table).as_posix(), "t_f": truth.t_f,
                        "models": score_models(Path(predictions) / name, benchmark, params)}
    return {"unit": UNIT, "thresholds": dataclasses.asdict(params), "tables": scored,
            "score_seconds": time.perf_counter() - start}


def score_benchmarks(benchmarks: Mapping[str, tuple[Benchmark, Path]],
                     params: ScorePredictionsParams) -> dict[str, Any]:
    """The record of benchmarks each with its own unit (short-term, inD): every predictions file
    of each benchmark's folder {name: (benchmark, folder)}, scored (`score_file`):
    {"thresholds", "benchmarks": {name: {`Benchmark.describe`..., "models": {model: record}}},
    "score_seconds"}."""
    start = time.perf_counter()
    scored = {}
    for name, (benchmark, folder) in benchmarks.items():
        models = score_models(folder, benchmark, params)
        scored[name] = {**benchmark.describe(), "models": models}
    return {"thresholds": dataclasses.asdict(params), "benchmarks": scored,
            "score_seconds": time.perf_counter() - start}
