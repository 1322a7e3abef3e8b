"""SHA-256 manifests: the project's record of what every raw file must hash to.

A manifest (`manifests/<source>.sha256`) has `sha256sum`'s format: `<hex>  <path relative to the
source root>` per line. Pickles are loaded only through `load_verified_pickle`, because unpickling
runs code.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path, PurePosixPath
from typing import Any, BinaryIO

import pandas as pd

_LINE = re.compile(r"^(?P<sha>[0-9a-f]{64}) [ *](?P<path>.+)$")
CHUNK = 1 << 20


class ChecksumError(ValueError):
    """A file does not match its manifest, or a manifest is malformed."""


def sha256_stream(stream: BinaryIO) -> str:
    digest = hashlib.sha256()
    for chunk in iter(lambda: stream.read(CHUNK), b""):
        digest.update(chunk)
    return digest.hexdigest()


def sha256_file(path: Path | str) -> str:
    with open(path, "rb") as f:
        return sha256_stream(f)


def read_manifest(path: Path | str) -> dict[str, str]:
    """Relative path -> expected SHA-256, in file order; rejects paths that leave the root."""
    path = Path(path)
    manifest: dict[str, str] = {}
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.strip():
            continue
        match = _LINE.match(line)
        if not match:
            raise ChecksumError(f"{path}:{number}: not a '<sha256>  <path>' line: {line!r}")
        rel = match["path"].removeprefix("./")
        parts = PurePosixPath(rel).parts
        if PurePosixPath(rel).is_absolute() or ".." in parts:
            raise ChecksumError(f"{path}:{number}: path leaves the source root: {rel!r}")
        if rel in manifest:
            raise ChecksumError(f"{path}:{number}: {rel!r} listed twice")
        manifest[rel] = match["sha"]
    if not manifest:
        raise ChecksumError(f"{path}: empty manifest")
    return manifest


def verify_file(path: Path, expected_sha: str) -> None:
    actual = sha256_file(path)
    if actual != expected_sha:
        raise ChecksumError(f"{path}: SHA-256 {actual} does not match the manifest's {expected_sha}")


def load_verified_pickle(root: Path | str, rel: str, manifest: dict[str, str]) -> Any:
    """Unpickle `root/rel` (a pandas pickle) only after its checksum matched the manifest."""
    if rel not in manifest:
        raise ChecksumError(f"{rel}: not in the manifest, refusing to unpickle it")
    path = Path(root) / rel
    verify_file(path, manifest[rel])
    return pd.read_pickle(path)
