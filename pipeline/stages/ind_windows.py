"""Stage `ind_windows`: the inD long-term windows, cut from the user's own copy of inD.

inD is licence-restricted: the project never fetches or redistributes it. `data.ind.path` names the
user's copy; empty, the stage still succeeds and writes an explicit "not provided" record and empty
tables (`pipeline.benchmarks.ind`). The copy lies outside the repository, so after changing its files at
the same path run `dvc repro -f ind_windows`. Params: `data.ind`, `windows.n_past`,
`windows.target_fps`.

    python -m pipeline.stages.ind_windows --out data/ind --metrics metrics/ind_windows.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pipeline.benchmarks.ind import NOT_PROVIDED_REASON, IndError, build, write
from pipeline.config.data import DataParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.windows import WindowParams
from pipeline.data.labels import MaskError


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder of inD window tables")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON")
    args = parser.parse_args(argv)
    all_params = read_params()
    params = load_section(DataParams, "data", all_params).ind
    windows = load_section(WindowParams, "windows", all_params)
    try:
        result = build(params, windows)
    except (IndError, MaskError) as e:
        sys.exit(f"ind_windows: {e}")
    write(result, args.out, args.metrics)
    print("ind_windows:", json.dumps({k: result.metrics[k] for k in ("provided", "windows")}))
    if not params.provided:
        print(f"ind_windows: inD not provided: {NOT_PROVIDED_REASON}")


if __name__ == "__main__":
    main()
