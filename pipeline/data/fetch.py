"""Fetching a raw data source into `data/raw/<source>/`, verified (stage `fetch@<source>`).

Locations are tried in the order `params.yaml` lists them; a location "has" a source when every
file of the source's manifest can be read there and hashes to the manifest's SHA-256. Files are
staged in a temporary folder beside the output and renamed into place only when all of them
verified, so a failed fetch never leaves a half-written `data/raw/<source>/`.
"""

from __future__ import annotations

import hashlib
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path
from typing import BinaryIO

from tqdm import tqdm

from pipeline.config import FetchParams, is_url
from pipeline.data.checksums import CHUNK, read_manifest
from pipeline.io import atomic_dir





class FetchError(RuntimeError):
    """No location holds a complete, verified copy of a source."""


class _Incomplete(Exception):
    """One location lacks files of the source (or has them with other checksums)."""

    def __init__(self, problems: list[str]):
        super().__init__(f"{len(problems)} problem(s)")
        self.problems = problems




def open_remote(base: str, source: str, rel: str, timeout_s: float) -> BinaryIO:
    """A readable binary stream of `<base>/<source>/<rel>`; FileNotFoundError when absent."""
    if is_url(base):
        url = "/".join([base.rstrip("/"), urllib.parse.quote(source), urllib.parse.quote(rel)])
        try:
            return urllib.request.urlopen(url, timeout=timeout_s)  # noqa: S310 (http(s) only)
        except urllib.error.HTTPError as e:
            raise FileNotFoundError(f"{url}: HTTP {e.code}") from e
        except urllib.error.URLError as e:
            raise FileNotFoundError(f"{url}: {e.reason}") from e
    path = Path(urllib.parse.urlparse(base).path if base.startswith("file:") else base)
    return open(path / source / rel, "rb")


def copy_verified(stream: BinaryIO, target: Path, progress: tqdm) -> str:
    """Copy `stream` to `target`, returning the SHA-256 of what was written."""
    digest = hashlib.sha256()
    target.parent.mkdir(parents=True, exist_ok=True)
    with stream, open(target, "wb") as out:
        for chunk in iter(lambda: stream.read(CHUNK), b""):
            digest.update(chunk)
            out.write(chunk)
            progress.update(len(chunk))
    return digest.hexdigest()


def fetch_from(base: str, source: str, manifest: dict[str, str], staging: Path,
               timeout_s: float) -> list[str]:
    """Copy every manifest file from one location into `staging`; the list of problems found."""
    problems: list[str] = []
    with tqdm(total=None, unit="B", unit_scale=True, desc=f"{source} <- {base}",
              disable=None) as progress:
        for rel, expected in manifest.items():
            try:
                stream = open_remote(base, source, rel, timeout_s)
            except (FileNotFoundError, IsADirectoryError, PermissionError) as e:
                problems.append(f"missing {rel} ({e})")
                continue
            actual = copy_verified(stream, staging / rel, progress)
            if actual != expected:
                problems.append(f"checksum mismatch {rel}: got {actual}, manifest {expected}")
    return problems


def fetch_source(source: str, manifest_path: Path, out: Path, params: FetchParams) -> str:
    """Fetch `source` into `out` from the first location that has all of it; returns that location."""
    manifest = read_manifest(manifest_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tried: list[str] = []
    for base in params.locations:
        try:
            with atomic_dir(out) as staging:  # replaces `out` only when every file verified
                problems = fetch_from(base, source, manifest, staging, params.timeout_s)
                if problems:
                    raise _Incomplete(problems)
            return base
        except _Incomplete as e:
            problems = e.problems
        shown = "\n      ".join(problems[:10])
        more = f"\n      ... and {len(problems) - 10} more" if len(problems) > 10 else ""
        tried.append(f"  {base}: {len(problems)} of {len(manifest)} files failed\n      {shown}{more}")
    raise FetchError(
        f"source '{source}': no location holds all {len(manifest)} files of {manifest_path} "
        "with matching SHA-256. Locations tried (params.yaml fetch.locations):\n" + "\n".join(tried)
    )
