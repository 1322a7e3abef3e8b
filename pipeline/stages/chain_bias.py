"""Stage `chain_bias`: how much does cutting horizons from chained release windows shift the numbers?

On the videos with raw annotations, per horizon: windows from the full raw pieces against windows
from release-style chains of the same pieces, their counts and constant-velocity ADE / FDE
(`pipeline.studies.chain_bias`). Params: `windows`.

    python -m pipeline.stages.chain_bias --tracks data/tracks/sdd.parquet --out metrics/chain_bias.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from pipeline.config.loading import load_section, read_params
from pipeline.config.windows import WindowParams
from pipeline.studies.chain_bias import chain_bias
from pipeline.io import write_json


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracks", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True, help="metrics JSON")
    args = parser.parse_args(argv)
    params = load_section(WindowParams, "windows", read_params())
    result = chain_bias(pd.read_parquet(args.tracks), params)
    write_json(result, args.out, sort_keys=True)
    for horizon, row in result.items():
        raw, chain = row["raw"], row["release_chain"]
        print(f"{horizon:>5}: raw {raw['windows']:4d} windows, CV ADE {raw.get('cv_ade', float('nan')):7.1f} | "
              f"chain {chain['windows']:4d}, CV ADE {chain.get('cv_ade', float('nan')):7.1f}")


if __name__ == "__main__":
    main()
