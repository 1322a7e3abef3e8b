"""Wall time of stage `score_predictions` on the real stored long-term predictions: every
`data/predictions/long_term/<table>/<model>.parquet` scored as the stage scores it
(`pipeline.harness.stored_scores.score_tables`, the same params), without writing the record.
Issue 24's target: under a minute on 2 cores.

    OMP_NUM_THREADS=1 python bench/bench_score_predictions.py [--root .] [--params FILE] \
        [--repeats 3] [--profile 15]

`--root`: the repository holding `data/` (e.g. the main checkout, from a worktree); `--params`:
its `params.yaml` unless given. `--profile N` also prints the N functions with the most time of their own (cProfile) in
one more run. The machine is usually shared: times are an upper bound; the load average is printed.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's pipeline

from pipeline.config import (ScorePredictionsParams, WindowParams, load_section,  # noqa: E402
                             read_params)
from pipeline.harness.stored_scores import (long_term_benchmark_spec, read_scales,  # noqa: E402
                                            score_tables, sdd_label_masks)

# The stage's inputs, relative to the repository (as dvc.yaml's score_predictions names them).
PREDICTIONS = "data/predictions/long_term"
HORIZON_WINDOWS = "data/horizon_windows"
RELEASE_WINDOWS = "data/windows/release_tf30.parquet"
LABELS = "data/labels"
SCALES = "data/raw/sdd/estimated_scales.yaml"


def score_everything(root: Path, params_file: Path) -> dict:
    """What the stage computes from `root`'s data and `params_file` (masks and scales read anew)."""
    params = read_params(params_file)
    windows = load_section(WindowParams, "windows", params)
    settings = load_section(ScorePredictionsParams, "score_predictions", params)
    masks, scales = sdd_label_masks(root / LABELS, settings.forbidden_classes), read_scales(root / SCALES)
    paths = {f"tf{h}": root / HORIZON_WINDOWS / f"tf{h}.parquet" for h in windows.horizons}
    paths[Path(RELEASE_WINDOWS).stem] = root / RELEASE_WINDOWS
    tables = {name: long_term_benchmark_spec(path, windows.n_past, masks, scales, root / SCALES)
              for name, path in paths.items()}
    return score_tables(tables, root / PREDICTIONS, settings)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path("."))
    parser.add_argument("--params", type=Path, help="default: <root>/params.yaml")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--profile", type=int, default=0, metavar="N")
    args = parser.parse_args()
    params_file = args.params or args.root / "params.yaml"
    print(f"load average {os.getloadavg()[0]:.2f}; {os.cpu_count()} cores; "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    times, record = [], {}
    for _ in range(args.repeats):
        start = time.perf_counter()
        record = score_everything(args.root, params_file)
        times.append(time.perf_counter() - start)
    models = [m for table in record["tables"].values() for m in table["models"].values()]
    scored = [m for m in models if "metrics" in m]
    rows = sum(m["rounds"] * m["n_windows"] * m["k"] * m["t"] for m in scored)
    print(f"{len(record['tables'])} window tables, {len(scored)} predictions files scored "
          f"({rows:,} predicted positions), {len(models) - len(scored)} not run")
    print(f"wall time, median of {args.repeats}: {statistics.median(times):.2f} s "
          f"(runs: {', '.join(f'{t:.2f}' for t in times)})")
    if args.profile:
        profile = cProfile.Profile()
        profile.runcall(score_everything, args.root, params_file)
        pstats.Stats(profile).sort_stats("tottime").print_stats(args.profile)


if __name__ == "__main__":
    main()
