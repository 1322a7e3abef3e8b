"""SDD annotations: `annotations.txt` files parsed into one table of tracks (stage `tracks`; which
files, `pipeline.data.sdd_sources`).

Input rows are `track xmin ymin xmax ymax frame lost occluded generated "label"` at 30 FPS.
Output: one row per annotation (none dropped unless `compat.drop_first_row` asks for the
authors' quirk), positions as box centres in original pixels. A malformed line, or rows that
cannot all be true (`contradiction`: one track with two boxes in one frame, a box whose max is not
beyond its min, one track under two labels), stops the stage with the file and line numbers.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

RAW_COLUMNS = ["track_id", "xmin", "ymin", "xmax", "ymax", "frame", "lost", "occluded",
               "generated", "label"]
LABELS = ("Pedestrian", "Biker", "Skater", "Cart", "Car", "Bus")
TRACK_COLUMNS = {
    "scene_id": "string", "scene": "string", "video": "int64", "track_id": "int64",
    "frame": "int64", "x": "float64", "y": "float64", "label": "string", "lost": "int8",
    "occluded": "int8", "generated": "int8",
}
_VALID_LINE = re.compile(
    r'^\d+ -?\d+ -?\d+ -?\d+ -?\d+ \d+ [01] [01] [01] "(' + "|".join(LABELS) + r')"$'
)
_VIDEO_DIR = re.compile(r"^video(\d+)$")
INT64_MAX = 2**63 - 1


class AnnotationError(ValueError):
    """A malformed annotations.txt; the message names the file and line."""


def first_bad_line(path: Path) -> str:
    """Describe the first line of `path` that is not a valid annotation (slow path, errors only)."""
    with open(path, encoding="utf-8", errors="replace") as f:
        for number, line in enumerate(f, start=1):
            stripped = line.rstrip("\n").rstrip("\r")
            if not _VALID_LINE.match(stripped):
                return f"{path}:{number}: malformed annotation line {stripped[:120]!r}"
            if any(abs(int(field)) > INT64_MAX for field in stripped.split(" ")[:-1]):
                return f"{path}:{number}: a number beyond 64-bit integers {stripped[:120]!r}"
            if not line.endswith("\n"):
                return f"{path}:{number}: file ends mid-line (truncated?) {stripped[:120]!r}"
    return f"{path}: unreadable annotations"


def parse_annotations(path: Path) -> pd.DataFrame:
    """One annotations.txt -> DataFrame of RAW_COLUMNS; AnnotationError on any malformed line."""
    if path.stat().st_size == 0:
        raise AnnotationError(f"{path}: empty file")
    int_columns = {c: "int64" for c in RAW_COLUMNS[:-1]}
    try:
        table = pd.read_csv(path, sep=" ", header=None, names=RAW_COLUMNS, dtype=int_columns,
                            quotechar='"', engine="c", na_filter=False)
    except (ValueError, OverflowError, pd.errors.ParserError) as e:
        raise AnnotationError(first_bad_line(path)) from e
    bad = (
        ~table["label"].isin(LABELS)
        | ~table[["lost", "occluded", "generated"]].isin([0, 1]).all(axis=1)
        | (table["frame"] < 0) | (table["track_id"] < 0)
    )
    with open(path, "rb") as f:
        f.seek(-1, os.SEEK_END)
        truncated = f.read(1) != b"\n"
    if bad.any() or truncated:
        raise AnnotationError(first_bad_line(path))
    problem = contradiction(table)
    if problem:
        raise AnnotationError(f"{path}:{problem}")
    return table


def contradiction(table: pd.DataFrame) -> str | None:
    """The first thing in one file's rows (RAW_COLUMNS, row i = line i + 1) that cannot be true,
    as "<line(s)>: what", or None."""
    line = pd.Series(np.arange(1, len(table) + 1), index=table.index)
    empty = (table["xmax"] <= table["xmin"]) | (table["ymax"] <= table["ymin"])
    if empty.any():
        row = table[empty].iloc[0]
        return (f"{line[empty].iloc[0]}: impossible box of track {row.track_id} in frame "
                f"{row.frame}: x {row.xmin}..{row.xmax}, y {row.ymin}..{row.ymax} (max must exceed min)")
    twice = table.duplicated(["track_id", "frame"], keep=False)
    if twice.any():
        first = table[twice].iloc[0]
        same = twice & (table["track_id"] == first.track_id) & (table["frame"] == first.frame)
        lines = ", ".join(str(n) for n in line[same])
        boxes = table.loc[same, ["xmin", "ymin", "xmax", "ymax"]].drop_duplicates()
        what = "two different boxes" if len(boxes) > 1 else "the same box twice"
        return f"{lines}: track {first.track_id} has {what} in frame {first.frame}"
    labels = table.groupby("track_id")["label"].transform("first")
    relabelled = table["label"] != labels
    if relabelled.any():
        row = table[relabelled].iloc[0]
        first_line = line[(table["track_id"] == row.track_id)].iloc[0]
        return (f"{line[relabelled].iloc[0]}: track {row.track_id} is labelled {row.label!r} here "
                f"but {labels[relabelled].iloc[0]!r} on line {first_line}")
    return None


def video_tracks(table: pd.DataFrame, scene: str, video: int, drop_first_row: bool) -> pd.DataFrame:
    """Raw annotation rows of one video -> TRACK_COLUMNS rows (box centres)."""
    if drop_first_row:
        table = table.iloc[1:]
    return pd.DataFrame({
        "scene_id": f"{scene}_{video}",
        "scene": scene,
        "video": video,
        "track_id": table["track_id"].to_numpy(),
        "frame": table["frame"].to_numpy(),
        "x": (table["xmin"].to_numpy() + table["xmax"].to_numpy()) / 2.0,
        "y": (table["ymin"].to_numpy() + table["ymax"].to_numpy()) / 2.0,
        "label": table["label"].to_numpy(),
        "lost": table["lost"].to_numpy(np.int8),
        "occluded": table["occluded"].to_numpy(np.int8),
        "generated": table["generated"].to_numpy(np.int8),
    }).astype(TRACK_COLUMNS)


def find_annotation_files(sdd_root: Path) -> list[tuple[str, int, Path]]:
    """(scene, video, path) of every annotations.txt under `<sdd_root>/annotations/<scene>/video<k>/`."""
    found = []
    for path in sorted((sdd_root / "annotations").glob("*/*/annotations.txt")):
        match = _VIDEO_DIR.match(path.parent.name)
        if not match:
            raise AnnotationError(f"{path}: folder {path.parent.name!r} is not 'video<k>'")
        found.append((path.parent.parent.name, int(match[1]), path))
    if not found:
        raise AnnotationError(f"{sdd_root}/annotations: no */video*/annotations.txt found")
    return found


def tracks_from_files(files: list[tuple[str, int, Path]], drop_first_row: bool = False) -> pd.DataFrame:
    """(scene, video, annotations.txt) of each video, in order -> one TRACK_COLUMNS table."""
    parts = []
    for scene, video, path in tqdm(files, desc="parse", disable=None):
        parts.append(video_tracks(parse_annotations(path), scene, video, drop_first_row))
    return pd.concat(parts, ignore_index=True)


def build_tracks(sdd_root: Path, drop_first_row: bool = False) -> pd.DataFrame:
    """Every annotations.txt under one SDD root, parsed (`find_annotation_files` order)."""
    return tracks_from_files(find_annotation_files(sdd_root), drop_first_row)
