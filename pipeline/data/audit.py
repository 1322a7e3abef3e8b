"""The data audit: our raw-cut t_f = 30 windows against the authors' released windows, per video
(stage `audit`).

For every video with raw annotations: windows ours / release / exact matches (same track, same
frames, same positions). A mismatch must be explained; the only known cause is the authors'
`read_csv(header=0)` quirk, so each mismatch is re-checked against windows cut with the other
`compat.drop_first_row` setting. An unexplained mismatch fails the stage.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from pipeline.splits import split_of

WindowKey = tuple[str, int, tuple[int, ...]]  # (scene_id, track_id, frames)


def window_index(windows: pd.DataFrame, id_column: str) -> dict[WindowKey, np.ndarray]:
    """(scene, track, frames) -> (L, 2) positions, for each window of a table."""
    windows = windows.sort_values([id_column, "step"], kind="stable")
    index = {}
    for _, window in windows.groupby(id_column, sort=False):
        key = (str(window["scene_id"].iat[0]), int(window["track_id"].iat[0]),
               tuple(window["frame"].tolist()))
        index[key] = window[["x", "y"]].to_numpy()
    return index


@dataclass
class VideoAudit:
    ours: int
    release: int
    exact_matches: int
    only_ours: list[WindowKey]
    only_release: list[WindowKey]
    position_differs: list[WindowKey]

    @property
    def mismatches(self) -> list[WindowKey]:
        return self.only_ours + self.only_release + self.position_differs


def compare_video(ours: dict[WindowKey, np.ndarray], release: dict[WindowKey, np.ndarray]) -> VideoAudit:
    shared = ours.keys() & release.keys()
    exact = {k for k in shared if np.array_equal(ours[k], release[k])}
    return VideoAudit(
        ours=len(ours), release=len(release), exact_matches=len(exact),
        only_ours=sorted(ours.keys() - release.keys()),
        only_release=sorted(release.keys() - ours.keys()),
        position_differs=sorted(shared - exact),
    )


def explain(mismatch: WindowKey, release: dict[WindowKey, np.ndarray],
            other_setting: dict[WindowKey, np.ndarray], other_value: bool) -> str | None:
    """Why one window differs, or None when no known cause accounts for it."""
    in_release = mismatch in release
    with_other = mismatch in other_setting and (
        not in_release or np.array_equal(other_setting[mismatch], release[mismatch]))
    if in_release == with_other:
        return (f"compat.drop_first_row={str(other_value).lower()} reproduces the release here: "
                "the authors' read_csv(header=0) dropped this file's first annotation")
    return None


def audit(raw_windows: pd.DataFrame, release_windows: pd.DataFrame, other_setting: pd.DataFrame,
          other_value: bool, videos: list[str], val_videos: set[str]) -> tuple[dict, list[str]]:
    """Per-video audit record and the list of unexplained mismatches."""
    ours_all = window_index(raw_windows, "window_id")
    release_all = window_index(release_windows, "window_id")
    other_all = window_index(other_setting, "window_key")
    per_video: dict[str, dict] = {}
    unexplained: list[str] = []
    for video in videos:
        if split_of(video, val_videos) is None:
            continue  # outside the TrajNet split: the release has no windows for it by design
        select = lambda index: {k: v for k, v in index.items() if k[0] == video}  # noqa: E731
        release = select(release_all)
        result = compare_video(select(ours_all), release)
        record = {"ours": result.ours, "release": result.release,
                  "exact_matches": result.exact_matches}
        explanations = []
        for key in result.mismatches:
            reason = explain(key, release, select(other_all), other_value)
            text = f"track {key[1]} frames {key[2][0]}-{key[2][-1]}"
            if reason is None:
                unexplained.append(f"{video} {text}")
                reason = "UNEXPLAINED"
            explanations.append(f"{text}: {reason}")
        if explanations:
            record["mismatches"] = explanations
        per_video[video] = record
    return per_video, unexplained
