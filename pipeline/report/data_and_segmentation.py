"""The contents of the data and segmentation sections: window counts per horizon and split, the
release chains' bias, windows per video, the segmentation scores, and the segmentation figures
copied beside the page as compact JPEGs.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import cv2

from pipeline.report.common import FigureSlot, relative_difference, video_sort_key
from pipeline.report.lookups import Absent, MetricsStore, as_measured, is_number, lookup


def horizon_keys(mapping: Mapping) -> list[str]:
    """'tf5', 'tf10', ... in numeric order."""
    return sorted((k for k in mapping if re.fullmatch(r"tf\d+", k)), key=lambda k: int(k[2:]))


def window_count_rows(windows: Any, horizon_windows: Any) -> list[dict[str, Any]]:
    """Per horizon: raw windows per split (and outside it), release-chain windows per split."""
    raw = windows.get("raw", {}) if isinstance(windows, dict) else {}
    chain = horizon_windows if isinstance(horizon_windows, dict) else {}
    keys = sorted(set(horizon_keys(raw)) | set(horizon_keys(chain)), key=lambda k: int(k[2:]))
    rows = []
    for key in keys:
        r = raw.get(key, {})
        c = chain.get(key, {})
        rows.append({"t_f": int(key[2:]),
                     "raw": {s: r.get(s) for s in ("train", "val", "test", "outside_split")},
                     "chain": {s: c.get(s, {}).get("release_chain") for s in ("train", "val", "test")}})
    return rows


def chain_bias_rows(record: Any) -> list[dict[str, Any]]:
    """Per horizon: CV errors on raw windows vs release-style chains, and the relative bias."""
    if not isinstance(record, dict):
        return []
    rows = []
    for key in horizon_keys(record):
        entry = record[key]
        raw, chain = entry.get("raw", {}), entry.get("release_chain", {})
        bias = (relative_difference(chain["cv_ade"], raw["cv_ade"])
                if is_number(chain.get("cv_ade")) and is_number(raw.get("cv_ade")) else None)
        rows.append({"t_f": int(key[2:]), "raw": raw, "chain": chain,
                     "kept_fraction": entry.get("kept_fraction"), "ade_bias": bias})
    return rows


def scene_count_rows(per_scene: Any) -> tuple[list[str], list[dict[str, Any]]]:
    """Windows per video: columns '<source> t_f', rows videos with their counts."""
    if not isinstance(per_scene, dict):
        return [], []
    columns, counts = [], {}
    for source in sorted(per_scene):
        for key in horizon_keys(per_scene[source]):
            column = f"{source} {key[2:]} s"
            columns.append(column)
            for split, videos in per_scene[source][key].items():
                for video, n in videos.items():
                    counts.setdefault(video, {"split": split})[column] = n
    rows = [{"video": v, **counts[v]} for v in sorted(counts, key=video_sort_key)]
    return columns, rows


def segmentation_scores(store: MetricsStore) -> dict[str, Any]:
    """mIoU and per-class IoU (no paper counterpart: the paper prints no segmentation score)."""
    record = store.record("segmentation.json")
    if isinstance(record, Absent):
        return {"absent": record, "miou": record, "classes": [], "extra": [], "no_classes": None}
    where = store.where("segmentation.json")
    miou = lookup(store, "segmentation.json", ("miou",))
    per_class = record.get("iou", record.get("per_class_iou"))
    classes = ([(name, as_measured(v, record.get("rounds"),
                                   f"{where}: per_class_iou.{name}"))
                for name, v in per_class.items()] if isinstance(per_class, dict) else [])
    extra = [(k, v) for k, v in record.items()
             if is_number(v) and k not in ("miou", "rounds") and "seconds" not in k]  # times: provenance
    return {"absent": None, "miou": miou, "classes": classes, "extra": extra,
            "no_classes": None if classes else f"{where} has no per-class IoU (key `iou`)"}


def segmentation_gallery(folder: Path, videos: Iterable[str], slot) -> dict[str, Any]:
    """Figures of `folder` (one subfolder per kind, e.g. predictions) per test video.

    Each is copied beside the page as a compact JPEG (`slot(name)` says where), so the committed
    report stays small and still opens without the stage outputs.
    """
    if not folder.is_dir():
        return {"absent": f"stage not yet run: {folder.as_posix()} missing (the segmentation stages "
                          "draw these figures)", "kinds": [], "rows": [], "other": []}
    kinds = sorted({p.parent for p in folder.rglob("*.png")}, key=lambda p: p.as_posix())
    kind_names = [k.relative_to(folder).as_posix() if k != folder else folder.name for k in kinds]
    rows, used = [], set()
    for video in sorted(videos, key=video_sort_key):
        pattern = re.compile(rf"^{re.escape(video)}(?!\d)")
        images = []
        for kind, kind_name in zip(kinds, kind_names):
            match = sorted(p for p in kind.glob("*.png") if pattern.match(p.stem))
            images.append(compact_copy(match[0], slot(f"segmentation_{kind_name}_{video}.jpg"))
                          if match else None)
            used.update(match[:1])
        if any(images):
            rows.append({"video": video, "images": images})
    other = [compact_copy(p, slot(f"segmentation_{p.stem}.jpg")) for p in sorted(folder.rglob("*.png"))
             if p not in used and p.parent == folder]
    return {"absent": None, "kinds": kind_names, "rows": rows, "other": other}


GALLERY_MAX_WIDTH = 1200
GALLERY_JPEG_QUALITY = 80


def compact_copy(image_path: Path, slot: "FigureSlot") -> str:
    """`image_path` as a JPEG at most GALLERY_MAX_WIDTH wide at `slot.path`; its <img> src."""
    image = cv2.imread(str(image_path), cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError(f"{image_path}: not a readable image")
    if image.shape[1] > GALLERY_MAX_WIDTH:
        scale = GALLERY_MAX_WIDTH / image.shape[1]
        image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    slot.path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(slot.path), image, [cv2.IMWRITE_JPEG_QUALITY, GALLERY_JPEG_QUALITY]):
        raise OSError(f"could not write {slot.path}")
    return slot.src
