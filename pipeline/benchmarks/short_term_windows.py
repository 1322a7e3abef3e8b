"""The `short_term_windows` folder: TrajNet SDD's table (`pipeline.benchmarks.trajnet_sdd`), one
table per ETH/UCY fold and the ETH/UCY scene maps (`pipeline.benchmarks.ethucy`), written together
(replaced atomically), with the counts the stage's metrics report.

Tables: the window-table schema (`pipeline.data.window_table`) plus the metres `x_m`, `y_m`;
`t_f` holds n_f, the horizon in steps, as at 1 FPS.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pipeline.benchmarks.ethucy import (ETHUCY_DIR, FOLDS, MAPS, ethucy_fold_windows,
                                        on_road_fraction, write_ethucy_maps)
from pipeline.benchmarks.trajnet_sdd import TRAJNET_SDD, sdd_trajnet_windows
from pipeline.data.windows import count_windows
from pipeline.io import atomic_dir

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.short_term import ShortTermParams


def build(trajnet_root: Path, sgan_root: Path, release_root: Path, scenes_root: Path, out: Path,
          params: ShortTermParams) -> dict:
    """Write every table and the ETH/UCY maps into `out` (replaced atomically); returns the stats."""
    sdd = sdd_trajnet_windows(trajnet_root, params)
    homographies: dict[str, np.ndarray] = {}
    ethucy, gaps = {}, {}
    for fold in params.ethucy_folds:
        ethucy[fold], gaps[fold] = ethucy_fold_windows(sgan_root, release_root / ETHUCY_DIR, fold,
                                                       params, homographies)
    with atomic_dir(out) as tmp:
        sdd.to_parquet(TRAJNET_SDD.table(tmp), index=False)
        for fold, table in ethucy.items():
            table.to_parquet(FOLDS[fold].table(tmp), index=False)
        maps_dir = tmp / MAPS
        maps_dir.mkdir()
        write_ethucy_maps(maps_dir, release_root, scenes_root, homographies, homographies,
                          params.ethucy_resize)
    return {
        "n_past": params.n_past, "n_future": params.n_future, "fps": params.fps,
        "t_f_seconds": params.n_future / params.fps,
        "sdd_trajnet": count_windows(sdd, ["split"]),
        "ethucy": {fold: count_windows(table, ["split"]) for fold, table in ethucy.items()},
        "ethucy_windows_over_frame_gaps": gaps,
        "ethucy_positions_on_road": on_road_fraction(ethucy, release_root),
    }
