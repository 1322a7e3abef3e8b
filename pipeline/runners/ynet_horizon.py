"""Y-net at the other prediction horizons (paper Figure 4): what the `train_ynet_horizon` and
`evaluate_ynet_horizon` stages share.

The t_f = 30 s point is the main Y-net (`train_ynet` / `evaluate_ynet` on the release windows,
which equal `data/horizon_windows/tf30.parquet`); the horizon stages cover the other horizons on
the horizon tables. Waypoints are scaled with the horizon as `train_ynet` does. Which horizons are
trained, for how many epochs, and how many evaluation rounds come from `ynet_horizons.<profile>`
(`pipeline.config.ynet_horizons.HorizonParams`): a horizon outside that list still gets a metrics file saying why
it was not run, so the report explains the gap instead of leaving it blank.

The training stage's metrics file is the record below with `trained: true`, `waypoints` and the
training summary of `ynet_training.train` (`TRAINING_HEADER` first), or the not-run record; the
scoring stage's file is {t_f, profile, trained, n_windows, rounds, waypoints, main, eval_seconds,
<training summary>}, the layout the report reads.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from pipeline.data.window_table import WindowArrays, to_arrays

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.ynet_horizons import HorizonParams

TRAINING_HEADER = ("t_f", "profile", "trained", "waypoints")
"""Keys of the training stage's record that are not `ynet_training.train`'s summary."""


def not_run_record(horizon: int, profile: str, params: HorizonParams) -> dict:
    reason = (f"Y-net is not trained at t_f = {horizon} s in the {profile} profile "
              f"(it trains {', '.join(map(str, params.horizons)) or 'no horizon'} s here)")
    if params.why_subset:
        reason += f": {params.why_subset}"
    return {"t_f": horizon, "profile": profile, "trained": False, "not_run_reason": reason}


def horizon_splits(table_path: Path, n_past: int, horizon: int) -> dict[str, WindowArrays]:
    """The train / val / test windows of a horizon table; fails unless they predict `horizon`
    steps (1 FPS: one step per second)."""
    table = pd.read_parquet(table_path)
    splits = {split: to_arrays(table[table["split"] == split], n_past)
              for split in ("train", "val", "test")}
    n_future = splits["train"].future.shape[1]
    if n_future != horizon:
        raise ValueError(f"{table_path}: windows predict {n_future} steps, not t_f = {horizon}")
    return splits


def training_summary(record: dict) -> dict:
    """`ynet_training.train`'s summary, out of the training stage's record."""
    return {key: value for key, value in record.items() if key not in TRAINING_HEADER}
