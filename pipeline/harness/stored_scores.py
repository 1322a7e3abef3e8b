"""Every metric of `pipeline.harness.scoring` over stored predictions (`pipeline.harness.predictions`):
one predictions file, the window table its ids refer to, and what its benchmark needs besides
(a `pipeline.benchmarks.base.ScoredTable`, which each benchmark module makes: unit, truth columns,
metres per unit, scene masks) -> one JSON-able record. Nothing here runs a model. Stages
`score_predictions` and `score_short_term_predictions` write the records
(`metrics/beyond/{long_term,ind,short_term}.json`).

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
  (`ScoredTable.masks`: SDD's and inD's hand labels, classes `forbidden_classes`; ETH/UCY's not-road),
  beside the ground truth's (`ground_truth.off_limits_share`); null where no window has a mask;
- `collision_rate`: share of a window's K samples that come closer than `collision_threshold_m`
  metres to the same sample of another agent at a shared raw frame, beside the ground truth's,
  with the share of windows that share any frame with another agent (`copresent_share`). Where a
  benchmark cuts a window at every frame (ETH/UCY: `ScoredTable.same_start_collisions`), only windows
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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TYPE_CHECKING

import numpy as np

from pipeline.benchmarks.base import SceneMasks, ScoredTable, WindowTruth
from pipeline.benchmarks.registry import short_term
from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.benchmarks.short_term import ScoringSources
from pipeline.harness import scoring
from pipeline.harness.predictions import NOT_RUN, PredictionArrays, read_prediction_rounds
from pipeline.io import IntermediateError

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.score_predictions import ScorePredictionsParams

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
# One round, one file


@dataclass(frozen=True)
class SceneInputs:
    """The windows of one predictions file in their scenes: everything but the predictions."""

    truth: WindowTruth
    metres_per_unit: np.ndarray  # (N,)
    masks: SceneMasks | None
    same_start: bool = False  # collisions only between windows starting at the same frame


def forbidden_shares(masks: SceneMasks, positions: np.ndarray, scenes: np.ndarray) -> np.ndarray:
    """(N,) share of a window's positions (N, ..., 2) inside its scene's mask that lie on a
    forbidden class (`scoring.forbidden_share`); NaN where the scene has no mask or no position
    lies inside it."""
    share = np.full(len(positions), np.nan)
    rows = np.flatnonzero(np.isin(scenes, sorted(masks.names)))
    if not len(rows):
        return share
    names, index = np.unique(scenes[rows], return_inverse=True)
    index = index.reshape(-1)
    points = positions[rows]
    if masks.to_pixels is not None:
        points = np.array(points, dtype=np.float64)
        for i, name in enumerate(names):
            points[index == i] = masks.to_pixels(points[index == i], str(name))
    status = scoring.scene_compliance(points, index, [masks.mask(str(n)) for n in names],
                                      masks.forbidden, masks.scale)
    share[rows] = scoring.forbidden_share(status)
    return share


def off_limits_share(positions: np.ndarray, inputs: SceneInputs) -> np.ndarray:
    """(N,) share of positions (N, ..., 2) inside their scene's mask that lie on a forbidden
    class; NaN where there is no mask."""
    if inputs.masks is None:
        return np.full(len(positions), np.nan)
    return forbidden_shares(inputs.masks, positions, inputs.truth.scenes)


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


def check_file(path: Path, metadata: Mapping[str, Any], benchmark: ScoredTable) -> None:
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


def score_file(path: Path, benchmark: ScoredTable, params: ScorePredictionsParams
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


def score_models(folder: Path, benchmark: ScoredTable, params: ScorePredictionsParams
                 ) -> dict[str, Any]:
    """{model: `score_file`} of every `<folder>/<model>.parquet`."""
    return {path.stem: score_file(path, benchmark, params) for path in prediction_files(folder)}


def score_tables(tables: Mapping[str, ScoredTable], predictions: Path,
                 params: ScorePredictionsParams) -> dict[str, Any]:
    """The long-term SDD record: every predictions file `<predictions>/<name>/<model>.parquet` of
    every window table `tables` {name: its `SddLongTerm.scored_table`}, scored (`score_file`), with
    the thresholds used and the seconds it took (`score_seconds`):
    {"unit", "thresholds", "tables": {name: {"window_table", "t_f", "models"}}, "score_seconds"}."""
    start = time.perf_counter()
    scored = {}
    for name, benchmark in tables.items():
        truth = benchmark.truth()
        scored[name] = {"window_table": Path(benchmark.table).as_posix(), "t_f": truth.t_f,
                        "models": score_models(Path(predictions) / name, benchmark, params)}
    return {"unit": SDD_LONG_TERM.unit, "thresholds": dataclasses.asdict(params), "tables": scored,
            "score_seconds": time.perf_counter() - start}


def score_benchmarks(benchmarks: Mapping[str, tuple[ScoredTable, Path]],
                     params: ScorePredictionsParams) -> dict[str, Any]:
    """The record of benchmarks each with its own unit (short-term, inD): every predictions file
    of each benchmark's folder {name: (benchmark, folder)}, scored (`score_file`):
    {"thresholds", "benchmarks": {name: {`ScoredTable.describe`..., "models": {model: record}}},
    "score_seconds"}."""
    start = time.perf_counter()
    scored = {}
    for name, (benchmark, folder) in benchmarks.items():
        models = score_models(folder, benchmark, params)
        scored[name] = {**benchmark.describe(), "models": models}
    return {"thresholds": dataclasses.asdict(params), "benchmarks": scored,
            "score_seconds": time.perf_counter() - start}


def short_term_tables(windows: Path, predictions: Path, datasets: Sequence[str], n_past: int,
                      sdd_masks: SceneMasks, scales: Mapping[str, float], scales_path: Path
                      ) -> dict[str, tuple[ScoredTable, Path]]:
    """{dataset: (its benchmark's ScoredTable, its predictions folder `<predictions>/<dataset>`)}:
    what `score_benchmarks` scores for the short-term record. Each benchmark takes what it reads
    from `ScoringSources` (TrajNet SDD: SDD's scales and hand labels; ETH/UCY: the road maps, read
    once, only if a fold is asked for)."""
    sources = ScoringSources(windows, n_past, sdd_masks, scales, scales_path)
    return {dataset: (short_term(dataset).scored_table(sources), Path(predictions) / dataset)
            for dataset in datasets}
