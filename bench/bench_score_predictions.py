"""Wall time of the stored-prediction scoring on the real files, as the stages score them, without
writing a record: `long_term` (stage `score_predictions`: every
`data/predictions/long_term/<table>/<model>.parquet`, `stored_scores.score_tables`) and
`short_term` (stage `score_short_term_predictions`: every
`data/predictions/short_term/<dataset>/<model>.parquet`, `stored_scores.score_benchmarks`), the
same params. A part whose predictions folder does not exist yet is skipped with a note. Issue 24's
target: under a minute on 2 cores.

    OMP_NUM_THREADS=1 python bench/bench_score_predictions.py [--root .] [--params FILE] \
        [--part long_term|short_term|all] [--repeats 3] [--profile 15]

`--root`: the repository holding `data/` (e.g. the main checkout, from a worktree); `--params`:
its `params.yaml` unless given. `--profile N` also prints the N functions with the most time of
their own (cProfile) in one more run of each part. The machine is usually shared: times are an
upper bound; the load average is printed.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's pipeline

from pipeline.config import (DATASETS, ScorePredictionsParams, ShortTermParams,  # noqa: E402
                             WindowParams, load_section, read_params)
from pipeline.harness.stored_scores import (long_term_benchmark_spec, read_scales,  # noqa: E402
                                            score_benchmarks, score_tables, sdd_label_masks)
from pipeline.harness.stored_short_term import short_term_benchmarks  # noqa: E402

# The stages' inputs, relative to the repository (as dvc.yaml names them).
PREDICTIONS = {"long_term": "data/predictions/long_term",
               "short_term": "data/predictions/short_term"}
HORIZON_WINDOWS = "data/horizon_windows"
RELEASE_WINDOWS = "data/windows/release_tf30.parquet"
SHORT_TERM_WINDOWS = "data/short_term"
LABELS = "data/labels"
SCALES = "data/raw/sdd/estimated_scales.yaml"


def score_long_term(root: Path, params_file: Path) -> dict:
    """What stage score_predictions computes for long-term SDD (masks and scales read anew)."""
    params = read_params(params_file)
    windows = load_section(WindowParams, "windows", params)
    settings = load_section(ScorePredictionsParams, "score_predictions", params)
    masks, scales = sdd_label_masks(root / LABELS, settings.forbidden_classes), read_scales(root / SCALES)
    paths = {f"tf{h}": root / HORIZON_WINDOWS / f"tf{h}.parquet" for h in windows.horizons}
    paths[Path(RELEASE_WINDOWS).stem] = root / RELEASE_WINDOWS
    tables = {name: long_term_benchmark_spec(path, windows.n_past, masks, scales, root / SCALES)
              for name, path in paths.items()}
    return score_tables(tables, root / PREDICTIONS["long_term"], settings)


def score_short_term(root: Path, params_file: Path) -> dict:
    """What stage score_short_term_predictions computes (maps, masks and scales read anew)."""
    params = read_params(params_file)
    settings = load_section(ScorePredictionsParams, "score_predictions", params)
    n_past = load_section(ShortTermParams, "short_term", params).n_past
    benchmarks = short_term_benchmarks(root / SHORT_TERM_WINDOWS, root / PREDICTIONS["short_term"],
                                       DATASETS, n_past,
                                       sdd_label_masks(root / LABELS, settings.forbidden_classes),
                                       read_scales(root / SCALES), root / SCALES)
    return score_benchmarks(benchmarks, settings)


PARTS: dict[str, tuple[Callable[[Path, Path], dict], str]] = {
    "long_term": (score_long_term, "tables"), "short_term": (score_short_term, "benchmarks")}


def bench_part(name: str, root: Path, params_file: Path, repeats: int, profile: int) -> None:
    score, key = PARTS[name]
    if not (root / PREDICTIONS[name]).is_dir():
        print(f"{name}: {root / PREDICTIONS[name]} does not exist yet: skipped")
        return
    times, record = [], {}
    for _ in range(repeats):
        start = time.perf_counter()
        record = score(root, params_file)
        times.append(time.perf_counter() - start)
    models = [m for node in record[key].values() for m in node["models"].values()]
    scored = [m for m in models if "metrics" in m]
    rows = sum(m["rounds"] * m["n_windows"] * m["k"] * m["t"] for m in scored)
    print(f"{name}: {len(record[key])} window tables, {len(scored)} predictions files scored "
          f"({rows:,} predicted positions), {len(models) - len(scored)} not run")
    print(f"{name}: wall time, median of {repeats}: {statistics.median(times):.2f} s "
          f"(runs: {', '.join(f'{t:.2f}' for t in times)})")
    if profile:
        profiler = cProfile.Profile()
        profiler.runcall(score, root, params_file)
        pstats.Stats(profiler).sort_stats("tottime").print_stats(profile)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path("."))
    parser.add_argument("--params", type=Path, help="default: <root>/params.yaml")
    parser.add_argument("--part", choices=(*PARTS, "all"), default="all")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--profile", type=int, default=0, metavar="N")
    args = parser.parse_args()
    params_file = args.params or args.root / "params.yaml"
    print(f"load average {os.getloadavg()[0]:.2f}; {os.cpu_count()} cores; "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    for name in PARTS if args.part == "all" else (args.part,):
        bench_part(name, args.root, params_file, args.repeats, args.profile)


if __name__ == "__main__":
    main()
