"""Stage `fetch@<source>`: copy one raw data source into `data/raw/<source>/`, verified.

Locations are tried in the order `params.yaml` lists them; a location "has" a source when every
file of the source's manifest can be read there and hashes to the manifest's SHA-256. Files are
staged in a temporary folder beside the output and renamed into place only when all of them
verified, so a failed fetch never leaves a half-written `data/raw/<source>/`.
"""

from __future__ import annotations

import argparse
import hashlib
import shutil
import sys
import tempfile
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from tqdm import tqdm

from pipeline.checksums import CHUNK, read_manifest
from pipeline.params import load_section

SOURCES = ("sdd", "ynet-release", "sgan", "trajnet-sdd", "ethucy-scenes")


@dataclass
class FetchParams:
    sources: list[str] = field(default_factory=lambda: list(SOURCES))
    """Sources to fetch; one `fetch@<source>` stage each."""
    locations: list[str] = field(default_factory=lambda: ["../shared/data"])
    """Ordered bases to try: a local folder or an http(s) URL; `<base>/<source>/` holds the source."""
    timeout_s: float = 60.0
    """Per-request timeout for http(s) locations."""

    def __post_init__(self):
        unknown = sorted(set(self.sources) - set(SOURCES))
        if unknown:
            raise ValueError(f"unknown source(s) {unknown}; known: {list(SOURCES)}")
        if not self.locations:
            raise ValueError("locations: at least one location is needed")
        for location in self.locations:
            if is_url(location) is None:
                raise ValueError(f"location {location!r}: not a folder path or an http(s) URL")


class FetchError(RuntimeError):
    """No location holds a complete, verified copy of a source."""


def is_url(location: str) -> bool | None:
    """True for http(s) URLs, False for local paths, None for other schemes (rejected)."""
    scheme = urllib.parse.urlparse(location).scheme
    if scheme in ("http", "https"):
        return True
    if scheme in ("", "file") or len(scheme) == 1:  # "C:" on Windows counts as a path
        return False
    return None


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
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
        try:
            problems = fetch_from(base, source, manifest, staging, params.timeout_s)
            if not problems:
                if out.exists():
                    shutil.rmtree(out)
                staging.rename(out)
                return base
        finally:
            if staging.exists():
                shutil.rmtree(staging)
        shown = "\n      ".join(problems[:10])
        more = f"\n      ... and {len(problems) - 10} more" if len(problems) > 10 else ""
        tried.append(f"  {base}: {len(problems)} of {len(manifest)} files failed\n      {shown}{more}")
    raise FetchError(
        f"source '{source}': no location holds all {len(manifest)} files of {manifest_path} "
        "with matching SHA-256. Locations tried (params.yaml fetch.locations):\n" + "\n".join(tried)
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", required=True, choices=SOURCES)
    parser.add_argument("--manifest", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    params = load_section(FetchParams, "fetch")
    try:
        used = fetch_source(args.source, args.manifest, args.out, params)
    except FetchError as e:
        sys.exit(f"fetch: {e}")
    print(f"fetch: {args.source}: {args.out} verified, from {used}")


if __name__ == "__main__":
    main()
