"""TrajNet SDD, the short-term SDD benchmark (paper Table 1): errors in original pixels.

`trajnet-sdd/{train,test}/<scene>_<video>.txt` hold fixed windows of 20 steps (`frame track x y`,
20 consecutive rows per window, raw 30 FPS frame numbers stepping by 12) in metres. Pixels =
metres / the video's ratio in `H_SDD.txt` (the `sdd_ratio_version` row); with version A the test
windows equal the authors' `test_trajnet.pkl`. Validation = whole train videos
(`sdd_val_videos`). The table keeps the metres beside the pixels (`x_m`, `y_m`).

Scoring stored predictions: metres per pixel are SDD's estimated scales per video, as for the
long-term benchmark (they agree with TrajNet's own `H_SDD.txt` ratios, the table's `x_m / x`, to
1e-4 relative on every test video); scene masks are the hand labels of `data/labels` at the
original resolution (they cover all 60 SDD videos, so every TrajNet test window). TrajNet's
windows meet each neighbour once, so collisions keep the long-term rule (any shared raw frame).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from pipeline.benchmarks.base import ScoredTable
from pipeline.benchmarks.short_term import (ScoringSources, ShortTermBenchmark, ShortTermInputError,
                                            number_windows, read_rows)
from pipeline.data.labels import image_sizes, sdd_scene_image
from pipeline.dataset_list import SDD
from pipeline.splits import TEST_VIDEOS, TRAIN_VIDEOS, split_of

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.short_term import ShortTermParams

SDD_RATIOS = "H_SDD.txt"  # metres per pixel of every SDD video, inside trajnet-sdd/


@dataclass(frozen=True)
class TrajnetSdd(ShortTermBenchmark):
    """TrajNet SDD: original pixels throughout (the baselines too: `ShortTermBenchmark.load`,
    `splits_in_unit`), the test truth as it is."""

    def scene_sizes(self, windows: Path, sdd: Path | None, scene_ids: set[str]
                    ) -> dict[str, tuple[int, int]]:
        """Each video's reference image size under the fetched SDD root `sdd`."""
        return image_sizes(sdd, scene_ids)

    def scene_images(self, windows: Path, sdd: Path | None, cameras: Path | None
                     ) -> Callable[[str], np.ndarray]:
        """SDD's `reference.jpg` under `sdd`."""
        return lambda scene_id: sdd_scene_image(sdd, scene_id)

    def scored_table(self, sources: ScoringSources) -> ScoredTable:
        """Its test windows as scoring sees them: original pixels, SDD's scales and hand labels."""
        return ScoredTable(self.prediction_benchmark(), self.table(sources.windows), self.unit,
                           sources.n_past, self.truth_columns, self.split,
                           metres_per_unit=sources.scales,
                           scales_source=f"per video, {Path(sources.scales_path)}",
                           masks=sources.sdd_masks)


RAW_SDD = "sdd"  # the fetched SDD (data/raw/sdd): reference images, hence the scenes' sizes
TRAJNET_SDD = TrajnetSdd("trajnet_sdd", "SDD short-term (TrajNet)", "px", label="SDD (TrajNet)",
                         paper_table="sdd_short", in_paper="Table 1, SDD short term (TrajNet)",
                         study_key=SDD, dataset=SDD, table_file="sdd_trajnet.parquet",
                         settings_key=SDD, summary_file="sdd.json", sizes_source=RAW_SDD,
                         images_source=RAW_SDD)


# ---------------------------------------------------------------------------------------------
# Building the table (stage `short_term_windows`)


def read_sdd_ratios(path: Path, version: str) -> dict[str, float]:
    """`<scene>_<video>` -> metres per pixel, from `H_SDD.txt` (tab-separated, one A and one B row)."""
    try:
        table = pd.read_csv(path, sep="\t")
    except (OSError, ValueError) as e:
        raise ShortTermInputError(f"{path}: cannot be read as a tab-separated table ({e})") from e
    missing = sorted({"File", "Version", "Ratio"} - set(table.columns))
    if missing:
        raise ShortTermInputError(f"{path}: lacks column(s) {missing}")
    rows = table.loc[table["Version"] == version]
    names = rows["File"].astype(str).str.removesuffix(".jpg")
    ratios = pd.to_numeric(rows["Ratio"], errors="coerce")
    if names.duplicated().any():
        raise ShortTermInputError(f"{path}: several version-{version} rows for "
                                  f"{sorted(names[names.duplicated()])}")
    bad = ~(ratios > 0)
    if bad.any():
        raise ShortTermInputError(f"{path}: no positive ratio for {sorted(names[bad])}")
    return dict(zip(names, ratios.astype(float)))


def fixed_windows(rows: np.ndarray, length: int, frame_step: int, path: Path) -> np.ndarray:
    """Rows (R, 4) of a TrajNet file -> (N, length, 4): consecutive blocks of one track each."""
    if len(rows) % length:
        raise ShortTermInputError(f"{path}: {len(rows)} rows are not whole windows of {length} "
                                  f"(TrajNet files hold fixed 20-step windows: n_past + n_future)")
    blocks = rows.reshape(-1, length, 4)
    one_track = (blocks[:, :, 1] == blocks[:, :1, 1]).all(axis=1)
    steady = (np.diff(blocks[:, :, 0], axis=1) == frame_step).all(axis=1)
    bad = np.flatnonzero(~(one_track & steady))
    if len(bad):
        first = bad[0] * length + 1
        raise ShortTermInputError(
            f"{path}: rows {first}-{first + length - 1} are not one track stepping {frame_step} "
            f"frames ({len(bad)} such window(s)); is n_past + n_future the files' window length?")
    return blocks


def sdd_trajnet_windows(root: Path, params: ShortTermParams) -> pd.DataFrame:
    """The TrajNet SDD windows, train / val / test, in pixels (and metres)."""
    ratios = read_sdd_ratios(root / SDD_RATIOS, params.sdd_ratio_version)
    val_videos = set(params.sdd_val_videos)
    parts = []
    for folder, allowed, videos in (("train", {"train", "val"}, TRAIN_VIDEOS),
                                    ("test", {"test"}, TEST_VIDEOS)):
        paths = sorted((root / folder).glob("*.txt"))
        if not paths:
            raise ShortTermInputError(f"{root / folder}: no TrajNet files")
        for path in paths:
            video = path.stem
            split = split_of(video, val_videos)
            if split not in allowed:
                raise ShortTermInputError(f"{path}: {video} is not a TrajNet {folder} video "
                                          f"(expected one of {sorted(videos)})")
            if video not in ratios:
                raise ShortTermInputError(f"{root / SDD_RATIOS}: no ratio for {video} ({path})")
            blocks = fixed_windows(read_rows(path, "frame track x y"), params.window_length,
                                   params.sdd_frame_step, path)  # (N, L, 4)
            n, length = blocks.shape[:2]
            metres = blocks[:, :, 2:].reshape(-1, 2)  # (N * L, 2)
            parts.append(pd.DataFrame({
                "scene_id": video,
                "track_id": blocks[:, :, 1].reshape(-1).astype(np.int64),
                "frame": blocks[:, :, 0].reshape(-1).astype(np.int64),
                "x": metres[:, 0] / ratios[video],
                "y": metres[:, 1] / ratios[video],
                "x_m": metres[:, 0],
                "y_m": metres[:, 1],
                "step": np.tile(np.arange(length), n),
                "window_key": len(parts) * 10**7 + np.repeat(np.arange(n), length),
                "split": split,
            }))
    missing = sorted(val_videos - {p["scene_id"].iloc[0] for p in parts})
    if missing:
        raise ShortTermInputError(f"{root / 'train'}: no file for validation video(s) {missing}")
    return number_windows(pd.concat(parts, ignore_index=True), params.n_future, "trajnet")

