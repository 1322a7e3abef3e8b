"""Atomic writes: every output file and folder of the pipeline is written through here.

A file is written to a temporary name beside its target (`.<name>.tmp<pid>`, same folder, so the
rename cannot cross file systems) and renamed over the target only once it is complete; a folder is
staged in a fresh temporary folder beside it and replaces it only when the block that fills it
succeeds. A crash or a stop request therefore never leaves a torn output for DVC to cache. A
process killed outright (SIGKILL: no `finally` runs) leaves its temporary file behind; the next
write of the same target removes it (`remove_dead_writers`), so a resumed run's folders end as an
uninterrupted run's.

The formats are the ones the stages have always written, so outputs stay byte-identical: JSON with
`indent` 2 (1 for the segmentation files) and a final newline, keys in insertion order unless
`sort_keys`; parquet without the index; `torch.save` archives named after the target file (or
`archive` when serialised in memory first, as the segmentation stage's files are).
"""

from __future__ import annotations

import glob
import io
import json
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd


def pid_alive(pid: int) -> bool:
    """Whether process `pid` exists (signal 0 checks without signalling)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def remove_dead_writers(path: Path) -> list[Path]:
    """Remove the temporary files and staging folders of `path` (`.<name>.tmp<pid>...`) whose
    writer no longer runs: what a killed process left. Returns what was removed."""
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.tmp(\d+)")
    removed = []
    for candidate in path.parent.glob(f".{glob.escape(path.name)}.tmp*"):
        match = pattern.match(candidate.name)
        if match and int(match[1]) != os.getpid() and not pid_alive(int(match[1])):
            if candidate.is_dir() and not candidate.is_symlink():
                shutil.rmtree(candidate)
            else:
                candidate.unlink(missing_ok=True)
            removed.append(candidate)
    return removed


@contextmanager
def atomic_path(path: Path, suffix: str = "", mode: int | None = None) -> Iterator[Path]:
    """A temporary path beside `path` (ending in `suffix`) to write to; renamed over `path` when the
    block succeeds (after a chmod to `mode`, if given), removed when it fails. Parent folders are
    created."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_dead_writers(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}{suffix}")
    try:
        yield tmp
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_with(path: Path, write: Callable[[Path], Any], suffix: str = "",
               mode: int | None = None) -> None:
    """`write(tmp)` writes the file at a temporary path, which then replaces `path`."""
    with atomic_path(path, suffix, mode) as tmp:
        write(tmp)


def write_bytes(path: Path, data: bytes) -> None:
    write_with(path, lambda tmp: tmp.write_bytes(data))


def write_text(path: Path, text: str, mode: int | None = None) -> None:
    write_with(path, lambda tmp: tmp.write_text(text), mode=mode)


def write_json(payload: Any, path: Path, *, indent: int = 2, sort_keys: bool = False) -> None:
    """`json.dumps(payload, indent=indent, sort_keys=sort_keys)` and a newline."""
    write_text(path, json.dumps(payload, indent=indent, sort_keys=sort_keys) + "\n")


def write_parquet(table: pd.DataFrame, path: Path) -> None:
    write_with(path, lambda tmp: table.to_parquet(tmp, index=False))


def write_csv(table: pd.DataFrame, path: Path) -> None:
    write_with(path, lambda tmp: table.to_csv(tmp, index=False))


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """`np.savez_compressed` of `arrays` (the temporary name keeps the `.npz` numpy insists on)."""
    write_with(path, lambda tmp: np.savez_compressed(tmp, **arrays), suffix=".npz")


def save_torch(payload: Any, path: Path, *, in_memory: bool = False) -> None:
    """`torch.save(payload)` (state_dicts and plain values only). The archive's root folder is named
    after the target (`best.pt` -> `.best.pt/`), or `archive/` with `in_memory` (serialised to a
    buffer first: the U-Net's checkpoints and exported models)."""
    import torch  # here, not at the top: most stages write no torch files

    if in_memory:
        buffer = io.BytesIO()
        torch.save(payload, buffer)
        write_bytes(path, buffer.getvalue())
    else:
        write_with(path, lambda tmp: torch.save(payload, tmp))


def copy_file(source: Path, path: Path) -> None:
    write_with(path, lambda tmp: shutil.copyfile(source, tmp))


@contextmanager
def atomic_dir(final: Path, mode: int | None = None) -> Iterator[Path]:
    """A fresh temporary directory beside `final` that replaces it only if the block succeeds (after
    a chmod to `mode`, if given: `mkdtemp` makes it 0700)."""
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    remove_dead_writers(final)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp{os.getpid()}.", dir=final.parent))
    try:
        yield tmp
        if mode is not None:
            tmp.chmod(mode)
        if final.exists():
            shutil.rmtree(final)
        os.replace(tmp, final)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
