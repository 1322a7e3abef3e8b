"""Which SDD `annotations.txt` each video is parsed from, and where it came from (stages `tracks`
and `audit`, which must parse the same files).

Raw annotations can lie in two places:
- the fetched mirror `data/raw/sdd` (stage `fetch@sdd`): only files `manifests/sdd.sha256` pins,
  verified when fetched; it has annotations for 23 of SDD's 60 videos;
- optionally your own copy of the official Stanford Drone Dataset (`data.sdd.path`), laid out
  `annotations/<scene>/video<k>/{annotations.txt,reference.jpg}`; anything else in it (`video.mov`,
  `videos/`, stray files) is ignored.

A file of the copy whose path (relative to the copy, as in the manifest) is pinned must hash to the
pin, else `SourceError` names the file, both hashes and what to do. A pinned `annotations.txt` that
matches holds the mirror's bytes: the video is parsed once, from the mirror (origin
`ORIGIN_IDENTICAL`). An unpinned one is parsed from the copy and its SHA-256 recorded
(`ORIGIN_COPY`). The copy's `reference.jpg` files are checked or fingerprinted the same way, but the
images used downstream still come from the mirror.

Videos are listed in the order of their relative paths, the order `find_annotation_files` gives on
one root: with no copy the tracks table is the mirror's, row for row.
"""

from __future__ import annotations

import hashlib
from collections import Counter
from dataclasses import dataclass, replace
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING

from tqdm import tqdm

from pipeline.data.checksums import CHUNK
from pipeline.data.tracks import find_annotation_files

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.data import SddParams

ORIGIN_FETCHED = "fetched"  # the mirror's file, verified by fetch@sdd
ORIGIN_IDENTICAL = "fetched; your copy identical"  # the copy holds the same (pinned) bytes
ORIGIN_COPY = "your copy (fingerprinted)"  # not pinned: parsed from the copy, SHA-256 recorded
ORIGINS = (ORIGIN_FETCHED, ORIGIN_IDENTICAL, ORIGIN_COPY)

ANNOTATIONS_GLOB = "annotations/*/*/annotations.txt"
REFERENCE_GLOB = "annotations/*/video*/reference.jpg"


class SourceError(ValueError):
    """The SDD copy (or the mirror beside it) cannot be used as it is; the message says why."""


@dataclass(frozen=True)
class VideoSource:
    """The `annotations.txt` one video is parsed from."""

    scene: str
    video: int
    rel: str
    """Path relative to the SDD root, as the manifest writes it."""
    path: Path
    """The file parsed: the mirror's, or the copy's when the manifest does not pin it."""
    origin: str
    """One of `ORIGINS`."""
    sha256: str
    pinned: bool

    @property
    def scene_id(self) -> str:
        return f"{self.scene}_{self.video}"


@dataclass(frozen=True)
class ImageSource:
    """One `reference.jpg` of the copy: checked against its pin, or fingerprinted."""

    rel: str
    sha256: str
    pinned: bool


def copy_root(params: SddParams) -> Path | None:
    """The copy's folder (`~` expanded; a relative path counts from the working directory, the
    repository root under dvc), or None when `data.sdd.path` is empty."""
    return Path(params.path).expanduser() if params.provided else None


def hash_files(paths: list[Path], desc: str) -> list[str]:
    """SHA-256 of each file, read in chunks, with one progress bar over all their bytes."""
    hashes = []
    with tqdm(total=sum(p.stat().st_size for p in paths), unit="B", unit_scale=True, desc=desc,
              disable=None) as bar:
        for path in paths:
            digest = hashlib.sha256()
            with open(path, "rb") as f:
                for chunk in iter(lambda: f.read(CHUNK), b""):
                    digest.update(chunk)
                    bar.update(len(chunk))
            hashes.append(digest.hexdigest())
    return hashes


def is_pinned(path: Path, rel: str, sha256: str, manifest: dict[str, str]) -> bool:
    """Whether the manifest pins `rel`; a SourceError when it does and `sha256` differs."""
    expected = manifest.get(rel)
    if expected is None:
        return False
    if sha256 != expected:
        raise SourceError(
            f"{path}: SHA-256 {sha256} differs from the manifest's {expected} for {rel}: this file "
            "of your SDD copy (data.sdd.path) is not the published one. Replace it with the "
            "official download's file (the fetched mirror, data/raw/sdd, holds the pinned bytes) "
            "or remove it from the copy, then run `dvc repro -f tracks`")
    return True


def fetched_videos(fetched_root: Path, manifest: dict[str, str]) -> list[VideoSource]:
    """Every video of the fetched mirror, with the SHA-256 its manifest pins (fetch verified it)."""
    videos = []
    for scene, video, path in find_annotation_files(fetched_root):
        rel = path.relative_to(fetched_root).as_posix()
        if rel not in manifest:
            raise SourceError(f"{path}: not in the manifest, yet in the fetched mirror (which holds "
                              "only what fetch@sdd verified): run `dvc repro -f fetch@sdd`")
        videos.append(VideoSource(scene, video, rel, path, ORIGIN_FETCHED, manifest[rel], True))
    return videos


def check_copy_folder(root: Path) -> None:
    """A SourceError naming `root` unless it holds `annotations/<scene>/video<k>/annotations.txt`."""
    if not root.is_dir():
        raise SourceError(f"data.sdd.path: {root} is not a folder; it must be your copy of the "
                          "Stanford Drone Dataset, the folder holding annotations/<scene>/video<k>/"
                          "annotations.txt (or empty for the fetched mirror only)")
    if not any(root.glob(ANNOTATIONS_GLOB)):
        raise SourceError(f"data.sdd.path: {root} holds no annotations/<scene>/video<k>/"
                          "annotations.txt; point it at the folder of the official download that "
                          "holds annotations/ (not at annotations/ itself)")


def choose_videos(fetched_root: Path, manifest: dict[str, str],
                  copy: Path | None) -> list[VideoSource]:
    """The `annotations.txt` each video is parsed from: the mirror's, and the copy's where the
    manifest does not pin them (pinned ones must match it). Ordered by relative path."""
    chosen = {(v.scene, v.video): v for v in fetched_videos(fetched_root, manifest)}
    if copy is not None:
        check_copy_folder(copy)
        found = find_annotation_files(copy)
        hashes = hash_files([path for *_, path in found], "hash your SDD annotations")
        for (scene, video, path), sha256 in zip(found, hashes, strict=True):
            rel = path.relative_to(copy).as_posix()
            known = chosen.get((scene, video))
            if known is not None and known.rel != rel:
                raise SourceError(f"{path}: video {scene}_{video} again (also {known.path}); "
                                  "keep one folder per video")
            if is_pinned(path, rel, sha256, manifest):
                if known is None:
                    raise SourceError(f"{path}: pinned by the manifest but missing from the fetched "
                                      f"mirror {fetched_root}: run `dvc repro -f fetch@sdd`")
                chosen[scene, video] = replace(known, origin=ORIGIN_IDENTICAL)
            else:
                chosen[scene, video] = VideoSource(scene, video, rel, path, ORIGIN_COPY, sha256, False)
    return sorted(chosen.values(), key=lambda v: PurePosixPath(v.rel))


def annotation_files(videos: list[VideoSource]) -> list[tuple[str, int, Path]]:
    """(scene, video, file) of each chosen video, what `pipeline.data.tracks.tracks_from_files` parses."""
    return [(v.scene, v.video, v.path) for v in videos]


def copy_images(copy: Path | None, manifest: dict[str, str]) -> list[ImageSource]:
    """The copy's `reference.jpg` files: pinned ones checked (SourceError on a mismatch), the
    others fingerprinted. None without a copy."""
    if copy is None:
        return []
    paths = sorted(copy.glob(REFERENCE_GLOB))
    images = []
    for path, sha256 in zip(paths, hash_files(paths, "hash your SDD reference images"), strict=True):
        rel = path.relative_to(copy).as_posix()
        images.append(ImageSource(rel, sha256, is_pinned(path, rel, sha256, manifest)))
    return images


def sources_record(params: SddParams, videos: list[VideoSource], images: list[ImageSource],
                   rows: dict[str, int]) -> dict:
    """What stage `tracks` writes to `metrics/sdd_sources.json`: the copy (path as given), each
    video's origin, SHA-256, pin and track rows, each reference image of the copy, and totals."""
    per_origin = Counter(v.origin for v in videos)
    return {
        "copy": {"provided": params.provided, "path": params.path},
        "videos": {v.scene_id: {"origin": v.origin, "file": v.rel, "sha256": v.sha256,
                                "pinned": v.pinned, "rows": int(rows.get(v.scene_id, 0))}
                   for v in videos},
        "reference_images": {i.rel: {"sha256": i.sha256, "pinned": i.pinned} for i in images},
        "totals": {
            "videos": len(videos), "rows": int(sum(rows.values())),
            "per_origin": {origin: per_origin[origin] for origin in ORIGINS if per_origin[origin]},
            "reference_images": {"pinned": sum(i.pinned for i in images),
                                 "fingerprinted": sum(not i.pinned for i in images)},
        },
    }
