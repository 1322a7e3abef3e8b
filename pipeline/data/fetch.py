"""Fetching a raw data source into `data/raw/<source>/`, verified (stage `fetch@<source>`).

Locations are tried in the order `params.yaml` lists them; a location "has" a source when every
file of the source's manifest can be read there and hashes to the manifest's SHA-256. A location is
a mirror (`<base>/<source>/<rel>`, as `../shared/data`) or an upstream mapping that says where each
manifest path lies in the source's public repositories (`pipeline.config.fetch.UpstreamLocation`). Either
way nothing is trusted: a file that changed upstream fails its checksum like a corrupted one. Files
are staged in a temporary folder beside the output and renamed into place only when all of them
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

from pipeline.config.fetch import FetchParams, UpstreamLocation, is_url, join_address
from pipeline.data.checksums import CHUNK, read_manifest
from pipeline.io import atomic_dir


class FetchError(RuntimeError):
    """No location holds a complete, verified copy of a source."""


class _Incomplete(Exception):
    """One location lacks files of the source (or has them with other checksums)."""

    def __init__(self, problems: list[str]):
        super().__init__(f"{len(problems)} problem(s)")
        self.problems = problems


Location = str | UpstreamLocation


def location_label(location: Location) -> str:
    """How messages and the stage's log name a location: a mirror by its base, a mapping by name."""
    return location if isinstance(location, str) else location.name


def offers(location: Location, source: str) -> bool:
    """A mirror may hold any source; an upstream mapping only those it lists (so a source left out
    is reported as not offered there, not as a location missing every file)."""
    return isinstance(location, str) or source in location.sources


def file_address(location: Location, source: str, rel: str) -> str | None:
    """Where manifest path `rel` of `source` lies at `location` (a URL, its appended path quoted,
    or a local path); None when the location's mapping has no rule for it."""
    if isinstance(location, str):
        return join_address(location, f"{source}/{rel}")
    return location.sources[source].resolve(rel)


def open_address(address: str, timeout_s: float) -> BinaryIO:
    """A readable binary stream of a URL or local path; FileNotFoundError when it is absent."""
    if is_url(address):
        try:
            return urllib.request.urlopen(address, timeout=timeout_s)  # noqa: S310 (http(s) only)
        except urllib.error.HTTPError as e:
            raise FileNotFoundError(f"{address}: HTTP {e.code}") from e
        except urllib.error.URLError as e:
            raise FileNotFoundError(f"{address}: {e.reason}") from e
    return open(urllib.parse.urlparse(address).path if address.startswith("file:") else address, "rb")


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


def fetch_from(location: Location, source: str, manifest: dict[str, str], staging: Path,
               timeout_s: float) -> list[str]:
    """Copy every manifest file from one location into `staging`; the list of problems found."""
    problems: list[str] = []
    with tqdm(total=None, unit="B", unit_scale=True, desc=f"{source} <- {location_label(location)}",
              disable=None) as progress:
        for rel, expected in manifest.items():
            address = file_address(location, source, rel)
            if address is None:
                problems.append(f"unmapped {rel} (no rule of this location's map covers it)")
                continue
            try:
                stream = open_address(address, timeout_s)
            except (FileNotFoundError, IsADirectoryError, PermissionError) as e:
                problems.append(f"missing {rel} ({e})")
                continue
            actual = copy_verified(stream, staging / rel, progress)
            if actual != expected:
                problems.append(f"checksum mismatch {rel}: got {actual}, manifest {expected} "
                                f"(from {address})")
    return problems


def summarise(label: str, problems: list[str], total: int) -> str:
    """One location's entry in the FetchError message: its problems, the first ten in full."""
    shown = "\n      ".join(problems[:10])
    more = f"\n      ... and {len(problems) - 10} more" if len(problems) > 10 else ""
    return f"  {label}: {len(problems)} of {total} files failed\n      {shown}{more}"


def fetch_source(source: str, manifest_path: Path, out: Path, params: FetchParams) -> str:
    """Fetch `source` into `out` from the first location that has all of it; returns that location
    (a mirror's base, or an upstream mapping's name)."""
    manifest = read_manifest(manifest_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tried: list[str] = []
    for location in params.parsed_locations():
        label = location_label(location)
        if not offers(location, source):
            tried.append(f"  {label}: does not offer '{source}' (not among its sources)")
            continue
        try:
            with atomic_dir(out) as staging:  # replaces `out` only when every file verified
                problems = fetch_from(location, source, manifest, staging, params.timeout_s)
                if problems:
                    raise _Incomplete(problems)
            return label
        except _Incomplete as e:
            tried.append(summarise(label, e.problems, len(manifest)))
    raise FetchError(
        f"source '{source}': no location holds all {len(manifest)} files of {manifest_path} "
        "with matching SHA-256. Locations tried (params.yaml fetch.locations):\n" + "\n".join(tried)
    )
