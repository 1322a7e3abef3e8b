"""Stage `fetch@<source>`: copy one raw data source into `data/raw/<source>/`, verified.

Locations are tried in the order `fetch.locations` lists them (a mirror, or the `upstream` mapping
onto the sources' public repositories); the first that has every file of the source's manifest with
the manifest's SHA-256 wins (`pipeline.data.fetch`). A failed fetch leaves no half-written output.
Params: `fetch.locations`, `fetch.timeout_s`.

    python -m pipeline.stages.fetch --source sdd --manifest manifests/sdd.sha256 --out data/raw/sdd
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pipeline.config.fetch import FETCH_SOURCES, FetchParams
from pipeline.config.loading import load_section, read_params
from pipeline.data.fetch import FetchError, fetch_source


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", required=True, choices=FETCH_SOURCES)
    parser.add_argument("--manifest", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    params = load_section(FetchParams, "fetch", read_params())
    try:
        used = fetch_source(args.source, args.manifest, args.out, params)
    except FetchError as e:
        sys.exit(f"fetch: {e}")
    print(f"fetch: {args.source}: {args.out} verified, from {used}")


if __name__ == "__main__":
    main()
