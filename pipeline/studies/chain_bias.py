"""How much does cutting horizons from chained release windows shift the numbers? (stage `chain_bias`)

On the 23 videos with raw annotations (all of them, split or not: this is about the data source,
not the benchmark) build, for every horizon, (a) windows from the full raw pieces and (b) windows
from release-style chains of the same pieces (35-step windows cut without overlap, chained back,
so each piece's tail and every piece shorter than 35 steps are lost). Report the window counts and
the constant-velocity ADE / FDE on each, so a reader sees the bias of the `release_chain` source.
"""

from __future__ import annotations

import pandas as pd
from typing import TYPE_CHECKING

from pipeline.data.horizon_windows import chain_pieces
from pipeline.data.window_table import to_arrays
from pipeline.data.windows import cut_pieces, cut_windows
from pipeline.harness.metrics import ade_fde
from pipeline.models.constant_velocity import extrapolate

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.windows import WindowParams


def as_table(windows: pd.DataFrame) -> pd.DataFrame:
    """`cut_windows` rows -> a minimal window table (ids from the window keys)."""
    return windows.rename(columns={"window_key": "window_id"}).assign(split="all")


def constant_velocity_errors(windows: pd.DataFrame, n_past: int) -> dict[str, float | int]:
    """Constant-velocity ADE / FDE (pixels, one sample) on a `cut_windows` table."""
    if windows.empty:
        return {"windows": 0}
    arrays = to_arrays(as_table(windows), n_past)
    path = extrapolate(arrays.past, arrays.future.shape[1])[:, None]  # (N, 1, n_f, 2)
    scores = ade_fde(path, arrays.future)
    return {"windows": scores["n_windows"], "cv_ade": scores["ade"], "cv_fde": scores["fde"]}


def chain_bias(tracks: pd.DataFrame, params: WindowParams) -> dict[str, dict]:
    pieces = cut_pieces(tracks, params.label, params.stride)
    release_length = params.window_length(params.release_horizon)
    release_style = as_table(cut_windows(pieces, release_length))
    chained = chain_pieces(release_style, release_length, params.stride)
    result = {}
    for t_f in params.horizons:
        length = params.window_length(t_f)
        raw = constant_velocity_errors(cut_windows(pieces, length), params.n_past)
        chain = constant_velocity_errors(cut_windows(chained, length), params.n_past)
        result[f"tf{t_f}"] = {
            "raw": raw, "release_chain": chain,
            "kept_fraction": chain["windows"] / raw["windows"] if raw["windows"] else None,
        }
    return result
