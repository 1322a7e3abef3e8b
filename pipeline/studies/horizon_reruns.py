"""Each horizon's own Y-net on other windows than its test set (stage `horizon_analysis`).

`horizon_analysis` scores every horizon on one population, the longest horizon's test windows
truncated at t: this runs the Y-net trained for t on those truncated windows, with the sampling
its own evaluation stored (the options and first seed in its predictions file's metadata), one
round. The model's settings come from its checkpoint (`ynet_scoring.load_model`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, TYPE_CHECKING

import numpy as np

from pipeline.data.labels import image_sizes
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.window_table import WindowArrays
from pipeline.studies.horizon_analysis import SUBJECT, Errors, truncated_arrays
from pipeline.harness.metrics import window_errors
from pipeline.runners.ynet_scoring import Sampling, load_for_scoring, predict_samplings
from ynet.sampling import SamplingOptions

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.eval import EvalParams


def stored_sampling(metadata: dict[str, Any]) -> Sampling:
    """The first round's sampling of a stored Y-net predictions file: its `sampling` options and
    first seed."""
    if "sampling" not in metadata or not metadata.get("seeds"):
        raise ValueError(f"predictions of {metadata.get('model')} on {metadata.get('benchmark')} "
                         "record no sampling options or seeds")
    return Sampling(SamplingOptions(**metadata["sampling"]), int(metadata["seeds"][0]))


def ynet_paths(checkpoint: Path, windows: WindowArrays, semantic_maps: dict[str, np.ndarray],
               sizes: dict[str, tuple[int, int]], sampling: Sampling, params: EvalParams,
               threads: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(paths (N, K, n_f, 2), goals (N, K, 2)) in original pixels of the Y-net at `checkpoint` on
    `windows` (rows in their order; n_f must be the model's horizon), one sampling, on the CPU with
    `threads` torch threads."""
    model, settings, scenes = load_for_scoring(checkpoint, windows, semantic_maps, sizes, threads)
    if model.config.pred_len != windows.future.shape[1]:
        raise ValueError(f"{checkpoint}: a Y-net of {model.config.pred_len} steps cannot score "
                         f"windows of {windows.future.shape[1]} future steps")
    params = replace(params, threads=threads)
    (sampled,), _ = predict_samplings(model, scenes, settings, [sampling], params, len(windows),
                                      f"{checkpoint.parent.name} on {len(windows)} windows")
    return sampled.paths, sampled.goals


def own_horizon_ynet(windows: WindowArrays, horizons: list[int],
                     models: dict[int, tuple[Path, dict[str, Any]] | str], semantic_maps: Path,
                     sdd: Path, params: EvalParams, threads: int = 1) -> dict[int, dict[str, Any]]:
    """{t_f: {SUBJECT: `Errors` | why not}}: the Y-net of each horizon t_f (`models[t_f]`: its
    model file and its stored predictions' metadata, or why there is none) on `windows` truncated
    at t_f, best of K with FDE on its goals, one round."""
    found = {t: models.get(t, f"no {SUBJECT} model at t_f = {t} s") for t in horizons}
    own: dict[int, dict[str, Any]] = {t: {SUBJECT: m} for t, m in found.items()
                                      if isinstance(m, str)}
    to_run = {t: m for t, m in found.items() if not isinstance(m, str)}
    if not to_run:  # nothing to run: the maps and images are not read
        return own
    maps = load_semantic_maps(semantic_maps)
    sizes = image_sizes(sdd, set(windows.scene_id))
    for t, (path, metadata) in to_run.items():
        cut = truncated_arrays(windows, t)
        paths, goals = ynet_paths(path, cut, maps, sizes, stored_sampling(metadata), params,
                                  threads)
        errors = window_errors(paths, cut.future, goals)
        own[t] = {SUBJECT: Errors(errors.ade[None], errors.fde[None])}
    return dict(sorted(own.items()))
