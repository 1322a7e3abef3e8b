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

What one stage writes for a later one to read (an `index.json`, an `.npz` of arrays) is read back
through here too, checked (`read_json_index`, `index_value`, `same_names`, `read_npz`,
`check_array`): a file edited by hand, torn, or left by an older version of the code stops the
reading stage with an `IntermediateError` naming the file and the key, instead of a KeyError deep
inside training.
"""

from __future__ import annotations

import functools
import glob
import io
import json
import os
import re
import shutil
import sys
import tempfile
import zipfile
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.config.loading import scalar_type_error


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


# ---------------------------------------------------------------------------------------------
# Reading back what a stage wrote


class IntermediateError(ValueError):
    """A file one stage wrote for a later one is not what the writer writes."""


def exit_on_bad_intermediate(main: Callable[..., None]) -> Callable[..., None]:
    """Decorate a stage's `main`: an IntermediateError becomes the one-line exit
    `<stage>: <file>: <what>` (the stage module's name, also when run as `python -m`)."""

    @functools.wraps(main)
    def wrapper(*args, **kwargs):
        try:
            return main(*args, **kwargs)
        except IntermediateError as e:
            spec = getattr(sys.modules.get(main.__module__), "__spec__", None)
            stage = (spec.name if spec else main.__module__).rsplit(".", 1)[-1]
            raise SystemExit(f"{stage}: {e}") from None

    return wrapper


def read_json_index(path: Path) -> dict:
    """The JSON object at `path`, or an IntermediateError naming the file."""
    try:
        value = json.loads(Path(path).read_text())
    except FileNotFoundError as e:
        raise IntermediateError(f"{path}: missing (re-run the stage that writes it)") from e
    except (OSError, ValueError) as e:  # unreadable, not UTF-8, not JSON
        raise IntermediateError(f"{path}: not readable as JSON ({e})") from e
    if not isinstance(value, dict):
        raise IntermediateError(f"{path}: expected a JSON object, got {type(value).__name__}")
    return value


def index_value(mapping: dict, key: str, kind: Any, path: Path, where: str = "",
                choices: Collection | None = None) -> Any:
    """`mapping[key]`, checked to be of `kind`: dict, list, or a scalar annotation as params take
    (bool, int, float, str, `X | None`; a bool is no number), and one of `choices` if given. The
    error names the file and the key path (`where` is the path of `mapping`, e.g. 'videos.gates_2.')."""
    if key not in mapping:
        raise IntermediateError(f"{path}: {where}{key}: missing")
    value = mapping[key]
    if kind in (dict, list):
        wrong = (None if isinstance(value, kind)
                 else f"expected {kind.__name__}, got {type(value).__name__}")
    else:
        wrong = scalar_type_error(kind, value)
    if wrong:
        raise IntermediateError(f"{path}: {where}{key}: {wrong}")
    if choices is not None and value not in choices:
        raise IntermediateError(f"{path}: {where}{key}: expected one of {list(choices)}, got {value!r}")
    return value


def positive_ints(values: list, n: int) -> bool:
    """Whether `values` are `n` positive integers (a size, a shape; a bool is no number)."""
    return len(values) == n and all(isinstance(v, int) and not isinstance(v, bool) and v > 0
                                    for v in values)


def same_names(listed: Collection[str], found: Collection[str], path: Path, index: Path) -> None:
    """What `index` lists is exactly what `path` holds (arrays of an archive, files of a folder):
    a name on one side only means the two were not written together."""
    absent = sorted(set(listed) - set(found))
    if absent:
        raise IntermediateError(f"{path}: no entry for {absent[:5]}, listed in {index}")
    unlisted = sorted(set(found) - set(listed))
    if unlisted:
        raise IntermediateError(f"{path}: {unlisted[:5]} not listed in {index}")


def read_npz(path: Path, listed: Collection[str], index: Path) -> dict[str, np.ndarray]:
    """Every array of the `.npz` a stage wrote at `path` (no pickles); its names must be those
    `index` lists."""
    try:
        with np.load(path, allow_pickle=False) as stored:
            same_names(listed, stored.files, path, index)
            return {name: stored[name] for name in stored.files}
    except IntermediateError:
        raise
    except FileNotFoundError as e:
        raise IntermediateError(f"{path}: missing (re-run the stage that writes it)") from e
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as e:  # torn, pickled, not an npz
        raise IntermediateError(f"{path}: not a readable npz archive ({e})") from e


def check_array(array: np.ndarray, dtype: Any, shape: tuple[int | None, ...], path: Path,
                name: str) -> np.ndarray:
    """`array` (`name` in `path`) if it has `dtype`, `shape` (None: any size on that axis) and,
    for floats, only finite values: a NaN in a map would turn every later loss into NaN."""
    if array.dtype != np.dtype(dtype):
        raise IntermediateError(f"{path}: {name}: dtype {array.dtype}, expected {np.dtype(dtype)}")
    if array.ndim != len(shape) or any(s is not None and a != s for a, s in zip(array.shape, shape)):
        expected = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
        raise IntermediateError(f"{path}: {name}: shape {array.shape}, expected {expected}")
    if array.dtype.kind == "f":
        bad = int(array.size - np.count_nonzero(np.isfinite(array)))
        if bad:
            raise IntermediateError(f"{path}: {name}: {bad} non-finite value(s)")
    return array
