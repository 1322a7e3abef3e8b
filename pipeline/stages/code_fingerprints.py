"""Stage `code_fingerprints`: the fingerprint of the code each stage runs, one file per stage.

For every stage module (`pipeline/stages/<stage>.py`) and registered-model file
(`pipeline/models/<name>.py`), writes `<out>/stages/<stage>.json` or `<out>/models/<name>.json`:
{module, files: {path: SHA-256 of its code}} over every project file the module reaches through its
imports (`pipeline.code_graph.fingerprint`; comments, blank lines and trailing spaces are not code). Each stage declares its file as its one code dep: an edit
re-runs exactly the stages whose code it touches (their file changes; the others' stay
byte-identical), and dvc.lock holds one code entry per stage. Deps: the `pipeline` and `ynet`
folders. Params: none.

    python -m pipeline.stages.code_fingerprints --out data/code_fingerprints
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.code_graph import REPO, entry_points, fingerprint
from pipeline.io import atomic_dir, write_json


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    points = entry_points(REPO)
    with atomic_dir(args.out, mode=0o755) as tmp:
        for name, module in points.items():
            write_json({"module": module, "files": fingerprint(module, REPO)}, tmp / f"{name}.json")
    print(f"code_fingerprints: {len(points)} modules fingerprinted into {args.out}")


if __name__ == "__main__":
    main()
