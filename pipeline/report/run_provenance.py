"""Where our numbers came from (the page's "Provenance"): the commit and whether code or
params.yaml differ from it, what dvc.lock records (the params the stages ran with, their outputs,
the raw data's hashes), the manifests' checksums, the SDD annotations' origins, the machine, and
the stages' times. Where the paper's numbers came from is `pipeline.report.provenance`.
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import platform
import re
import subprocess
import sys
from collections import Counter
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import yaml

from pipeline.data.checksums import sha256_file
from pipeline.splits import TEST_VIDEOS, TRAIN_VIDEOS, split_of
from pipeline.report.common import video_sort_key
from pipeline.report.lookups import Absent, MetricsStore, is_number


def porcelain_paths(lines: Iterable[str]) -> list[str]:
    """The paths of `git status --porcelain` lines ("XY path" or "XY old -> new": the new one)."""
    return [line[3:].split(" -> ")[-1].strip('"') for line in lines if len(line) > 3]


def read_lock(lock_path: Path) -> Mapping[str, Any] | Absent:
    """dvc.lock parsed once (about a second of YAML at this size) for everything the page takes
    from it, or why it cannot be."""
    if not lock_path.exists():
        return Absent(f"{lock_path.as_posix()} missing (no stage has run)")
    try:
        return yaml.safe_load(lock_path.read_text()) or {}
    except (OSError, yaml.YAMLError) as e:
        return Absent(f"{lock_path.as_posix()} unreadable: {e}", "invalid")


def lock_stages(lock: Mapping[str, Any] | Absent) -> Iterable[Mapping[str, Any]]:
    return [] if isinstance(lock, Absent) else (lock.get("stages") or {}).values()


def lock_outputs(lock: Mapping[str, Any] | Absent) -> list[str]:
    """Every output path dvc.lock records (nothing if it is missing or unreadable)."""
    return [str(out["path"]) for stage in lock_stages(lock) for out in stage.get("outs") or []
            if "path" in out]


def is_output(path: str, outputs: Iterable[str]) -> bool:
    """`path` (a file or, untracked, a folder ending in "/") is dvc.lock or lies in an output, or
    is an output's temporary file or staging folder (`.<name>.tmp<pid>...`, `pipeline.io`)."""
    path = path.rstrip("/")
    staged = re.match(r"^(.*/)?\.([^/]+?)\.tmp\d+[^/]*$", path)
    if staged:
        path = (staged[1] or "") + staged[2]
    return path == "dvc.lock" or any(path == out.rstrip("/") or path.startswith(out.rstrip("/") + "/")
                                     or out.startswith(path + "/") for out in outputs)


def classify_changes(paths: Iterable[str], outputs: Iterable[str]) -> dict[str, Any]:
    """Changed paths split into code, params.yaml and pipeline outputs: only the first two mean
    the numbers may not come from the commit (outputs change whenever a stage runs)."""
    outputs = list(outputs)
    paths = list(paths)
    code = [p for p in paths if p != "params.yaml" and not is_output(p, outputs)]
    return {"code_changes": code, "params_changed": "params.yaml" in paths,
            "output_changes": sum(1 for p in paths if p != "params.yaml" and is_output(p, outputs))}


def git_state(repo: Path, outputs: Iterable[str] = ()) -> dict[str, Any]:
    """Commit, and whether code or params.yaml differ from it, read-only (no index refresh), or
    why it is unknown. `outputs`: paths that only the pipeline writes (never make it "dirty")."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "--no-optional-locks", "-C", str(repo), *args], check=True,
                              capture_output=True, text=True, timeout=30).stdout
    try:
        commit = git("rev-parse", "HEAD").strip()
        changes = classify_changes(porcelain_paths(git("status", "--porcelain").splitlines()), outputs)
    except (OSError, subprocess.SubprocessError) as e:
        return {"error": f"git state unknown: {e.__class__.__name__}: {str(e).strip()[:200]}",
                "commit": None, "dirty": None, "code_changes": [], "params_changed": None,
                "output_changes": 0}
    return {"error": None, "commit": commit,
            "dirty": bool(changes["code_changes"]) or changes["params_changed"], **changes}


def machine() -> dict[str, Any]:
    """Where this report (and, on one machine, the stages) ran."""
    cpu = platform.processor() or ""
    try:
        names = re.findall(r"^model name\s*:\s*(.+)$", Path("/proc/cpuinfo").read_text(), re.M)
        cpu = names[0] if names else cpu
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return {"cpu": cpu or "unknown", "cores": os.cpu_count(), "usable_cores": usable,
            "platform": platform.platform(), "python": sys.version.split()[0],
            "packages": {name: package_version(name) for name in ("torch", "numpy", "pandas", "dvc")}}


def package_version(name: str) -> str:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def manifest_checksums(folder: Path) -> list[dict[str, Any]]:
    """Each manifest's own SHA-256 (it pins every raw file's SHA-256) and how many files it lists."""
    if not folder.is_dir():
        return []
    return [{"name": p.name, "sha256": sha256_file(p),
             "files": sum(1 for line in p.read_text().splitlines() if line.strip())}
            for p in sorted(folder.glob("*.sha256"))]


def sdd_sources(store: MetricsStore, val_videos: Iterable[str]) -> dict[str, Any]:
    """Where the SDD raw annotations came from (stage `tracks`' `sdd_sources.json`): videos per
    origin, the files of your copy the manifest does not pin (with their SHA-256), and per video
    whether the horizon benchmark's windows are raw or cut from chained release windows (stage
    `horizon_windows` cuts raw windows on every TrajNet video with raw annotations, chains on the
    others; raw videos outside the split give none)."""
    record = store.record("sdd_sources.json")
    if isinstance(record, Absent):
        return {"absent": record}
    if not isinstance(record, dict):
        return {"absent": Absent(f"{store.where('sdd_sources.json')}: not a mapping", "invalid")}

    def part(key: str) -> dict:
        return record[key] if isinstance(record.get(key), dict) else {}

    videos, images, copy = part("videos"), part("reference_images"), part("copy")
    by_video = sorted(videos.items(), key=lambda item: video_sort_key(item[0]))
    fingerprinted = ([{"file": v.get("file", name), "sha256": v.get("sha256", "n/a")}
                      for name, v in by_video if isinstance(v, dict) and not v.get("pinned")]
                     + [{"file": rel, "sha256": i.get("sha256", "n/a")} for rel, i in sorted(images.items())
                        if isinstance(i, dict) and not i.get("pinned")])
    trajnet = TRAIN_VIDEOS | TEST_VIDEOS
    rows = []
    for name in sorted(trajnet | set(videos), key=video_sort_key):
        entry = videos.get(name)
        rows.append({"video": name, "split": split_of(name, set(val_videos)) or "outside the split",
                     "origin": entry.get("origin", "n/a") if isinstance(entry, dict) else "none",
                     "horizon": ("none (outside the TrajNet split)" if name not in trajnet
                                 else "raw" if entry is not None else "release-chained")})
    return {"absent": None, "provided": bool(copy.get("provided")), "path": copy.get("path", ""),
            "n_videos": len(videos),
            "origins": dict(sorted(Counter(str(v.get("origin", "n/a")) for _, v in by_video
                                           if isinstance(v, dict)).items())),
            "fingerprinted": fingerprinted, "rows": rows,
            "n_raw": sum(r["horizon"] == "raw" for r in rows),
            "n_chained": sum(r["horizon"] == "release-chained" for r in rows)}


def raw_data_hashes(lock: Mapping[str, Any] | Absent) -> list[dict[str, Any]] | Absent:
    """The md5 DVC recorded for each data/raw/<source> output."""
    if isinstance(lock, Absent):
        return lock
    found = {}
    for stage in lock_stages(lock):
        for out in stage.get("outs") or []:
            if str(out.get("path", "")).startswith("data/raw/"):
                found[out["path"]] = {"path": out["path"], "md5": out.get("md5"),
                                      "files": out.get("nfiles"), "size": out.get("size")}
    return [found[k] for k in sorted(found)]


def stage_timings(store: MetricsStore) -> dict[str, Any]:
    """Every top-level `*seconds*` number of the metrics files, one row per file, one column per key."""
    rows = []
    for rel, record in sorted(store.files.items()):
        if isinstance(record, dict):
            times = {k: float(v) for k, v in record.items() if "seconds" in k and is_number(v)}
            if times:
                rows.append({"file": store.where(rel), "seconds": times})
    keys = sorted({k for row in rows for k in row["seconds"]})
    return {"keys": keys, "rows": rows}


def stage_profile(path: Path | None) -> dict[str, Any] | Absent:
    """Where the pipeline's time goes: the stages `tools/timed_repro.py` clocked (`make repro`),
    longest first, each with its share of their sum, and the last run's record."""
    if path is None or not path.exists():
        return Absent("no stage times yet: `make repro` (tools/timed_repro.py) writes "
                      f"{'reports/stage_times.json' if path is None else path.as_posix()}")
    try:
        record = json.loads(path.read_text())
        stages = {str(name): float(entry["seconds"]) for name, entry in record["stages"].items()}
        if not stages:
            return Absent(f"{path.as_posix()}: no stage clocked yet (`make repro` fills it)")
        last_run = {"jobs": 1, **record["last_run"]}  # runs before --jobs ran one stage at a time
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
        return Absent(f"{path.as_posix()} unreadable: {e.__class__.__name__}: {e}", "invalid")
    total = sum(stages.values())
    rows = [{"stage": name, "seconds": seconds, "share": seconds / total if total else 0.0,
             "run_started": record["stages"][name].get("run_started")}
            for name, seconds in sorted(stages.items(), key=lambda item: -item[1])]
    return {"rows": rows, "total": total, "last_run": last_run}


def lock_params(lock: Mapping[str, Any] | Absent) -> dict[str, Any]:
    """The params.yaml values the stages ran with, as dvc.lock records them (each stage its keys),
    merged into one nested mapping: what the numbers on the page were computed with."""
    merged: dict[str, Any] = {}
    for stage in lock_stages(lock):
        for key, value in ((stage.get("params") or {}).get("params.yaml") or {}).items():
            node = merged
            *parents, leaf = str(key).split(".")
            for part in parents:
                node = node.setdefault(part, {})
            node[leaf] = value
    return merged


def profiles(params: Mapping, store: MetricsStore) -> dict[str, list[str]]:
    """Every `profile` value -> where it is set: the params in dvc.lock (any depth) and the
    metrics files."""
    found = []

    def walk(node: Any, where: str) -> None:
        if isinstance(node, dict):
            for key, value in node.items():
                path = f"{where}.{key}" if where else str(key)
                if key == "profile" and isinstance(value, str):
                    found.append((f"dvc.lock params: {path}", value))
                else:
                    walk(value, path)
    walk(params, "")
    found += [(store.where(rel), record["profile"]) for rel, record in sorted(store.files.items())
              if isinstance(record, dict) and isinstance(record.get("profile"), str)]
    grouped: dict[str, list[str]] = {}
    for where, value in found:
        grouped.setdefault(value, []).append(where)
    return grouped
