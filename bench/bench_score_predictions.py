"""Wall time of the stored-prediction scoring on the real files, as the stages score them, without
writing a record: `long_term` (stage `score_predictions`: every
`data/predictions/long_term/<table>/<model>.parquet`, `stored_scores.score_tables`) and
`short_term` (stage `score_short_term_predictions`: every
`data/predictions/short_term/<dataset>/<model>.parquet`, `stored_scores.score_benchmarks`), the
same params. A part whose predictions folder does not exist yet is named with the stage that
makes it, the other part still timed. Issue 24's target: under a minute on 2 cores.

    OMP_NUM_THREADS=1 python -m bench.bench_score_predictions [--root .] [--params FILE] \
        [--part long_term|short_term|all] [--repeats 3] [--profile 15] [--smoke]

`--root`: the repository holding `data/` (e.g. the main checkout, from a worktree); `--params`:
its `params.yaml` unless given. `--profile N` also prints the N functions with the most time of
their own (cProfile) in one more run of each part. The machine is usually shared: times are an
upper bound; the load average is printed.

`--smoke`: both parts on a tiny synthetic project written to a temporary folder (two videos, a
few windows of 2 + 3 steps, two models; short-term: the SDD table only), one run (seconds: the
code path, not a measurement).
"""

from __future__ import annotations

import cProfile
import json
import os
import pstats
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import yaml

from bench import common
from pipeline.benchmarks.sdd_long_term import (SDD_LONG_TERM, read_scales,
                                               sdd_label_masks)
from pipeline.benchmarks.trajnet_sdd import TRAJNET_SDD
from pipeline.config.loading import load_section, read_params
from pipeline.config.score_predictions import ScorePredictionsParams
from pipeline.config.short_term import ShortTermParams
from pipeline.config.windows import WindowParams
from pipeline.data.window_table import conform
from pipeline.dataset_list import SHORT_TERM_DATASETS
from pipeline.harness.predictions import (concat_rounds, predictions_table,
                                          write_predictions)
from pipeline.harness.stored_scores import (score_benchmarks, score_tables,
                                            short_term_tables)
from pipeline.io import write_parquet
from ynet.segmentation import CLASS_NAMES

# The stages' inputs, relative to the repository (as dvc.yaml names them).
PREDICTIONS = {"long_term": "data/predictions/long_term",
               "short_term": "data/predictions/short_term"}
HORIZON_WINDOWS = "data/horizon_windows"
RELEASE_WINDOWS = "data/windows/release_tf30.parquet"
SHORT_TERM_WINDOWS = "data/short_term"
LABELS = "data/labels"
SCALES = "data/raw/sdd/estimated_scales.yaml"
STAGES = {"long_term": "score_predictions", "short_term": "score_short_term_predictions"}


def score_long_term(root: Path, params_file: Path) -> dict:
    """What stage score_predictions computes for long-term SDD (masks and scales read anew)."""
    params = read_params(params_file)
    windows = load_section(WindowParams, "windows", params)
    settings = load_section(ScorePredictionsParams, "score_predictions", params)
    masks, scales = sdd_label_masks(root / LABELS, settings.forbidden_classes), read_scales(root / SCALES)
    paths = {f"tf{h}": root / HORIZON_WINDOWS / f"tf{h}.parquet" for h in windows.horizons}
    paths[Path(RELEASE_WINDOWS).stem] = root / RELEASE_WINDOWS
    tables = {name: SDD_LONG_TERM.scored_table(path, windows.n_past, masks, scales, root / SCALES)
              for name, path in paths.items()}
    return score_tables(tables, root / PREDICTIONS["long_term"], settings)


def score_short_term(root: Path, params_file: Path,
                     datasets: list[str] = SHORT_TERM_DATASETS) -> dict:
    """What stage score_short_term_predictions computes (maps, masks and scales read anew)."""
    params = read_params(params_file)
    settings = load_section(ScorePredictionsParams, "score_predictions", params)
    n_past = load_section(ShortTermParams, "short_term", params).n_past
    benchmarks = short_term_tables(root / SHORT_TERM_WINDOWS, root / PREDICTIONS["short_term"],
                                   datasets, n_past,
                                   sdd_label_masks(root / LABELS, settings.forbidden_classes),
                                   read_scales(root / SCALES), root / SCALES)
    return score_benchmarks(benchmarks, settings)


PARTS: dict[str, tuple[Callable[[Path, Path], dict], str]] = {
    "long_term": (score_long_term, "tables"), "short_term": (score_short_term, "benchmarks")}


# ---------------------------------------------------------------------------------------------
# --smoke: a tiny project of the stages' layout

SMOKE_VIDEOS = {"gates_2": 0.04, "hyang_0": 0.03}  # video: metres per pixel
SMOKE_PAST, SMOKE_FUTURE, SMOKE_WINDOWS, SMOKE_K = 2, 3, 8, 4


def smoke_table(split: str, t_f: int, rng: np.random.Generator) -> pd.DataFrame:
    """SMOKE_WINDOWS straight walks over the two videos (inside their 100 x 100 px masks), some
    sharing frames."""
    rows = []
    for w in range(SMOKE_WINDOWS):
        start, velocity = rng.uniform(20, 60, 2), rng.uniform(-4, 4, 2)
        for step in range(SMOKE_PAST + SMOKE_FUTURE):
            x, y = start + velocity * step
            rows.append({"window_id": w, "scene_id": list(SMOKE_VIDEOS)[w % 2], "track_id": w,
                         "step": step, "frame": 30 * (step + w // 4), "x": x, "y": y,
                         "split": split, "t_f": t_f, "source": "raw"})
    return conform(pd.DataFrame(rows))


def smoke_predictions(table: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    """Two rounds of SMOKE_K samples: each window's future truth plus noise."""
    future = table[table["step"] >= SMOKE_PAST].sort_values(["window_id", "step"])
    truth = future[["x", "y"]].to_numpy().reshape(SMOKE_WINDOWS, 1, SMOKE_FUTURE, 2)
    ids = np.arange(SMOKE_WINDOWS)
    return concat_rounds([predictions_table(ids, truth + rng.normal(0, 3, (len(ids), SMOKE_K,
                                                                          SMOKE_FUTURE, 2)), round=r)
                          for r in range(2)])


def write_smoke_project(root: Path, params_file: Path) -> Path:
    """Window tables, hand labels, scales, params (`params_file`'s scoring thresholds) and two
    models' predictions files for both parts, in the stages' layout under `root`; returns its
    params file."""
    rng = np.random.default_rng(0)
    (root / LABELS / "maps").mkdir(parents=True)
    for name in SMOKE_VIDEOS:
        mask = rng.integers(1, len(CLASS_NAMES), (100, 100)).astype(np.uint8)
        cv2.imwrite(str(root / LABELS / "maps" / f"{name}.png"), mask)
    (root / LABELS / "index.json").write_text(json.dumps({
        "classes": list(CLASS_NAMES), "pad_class": 0,
        "videos": {name: {"split": "test", "height": 100, "width": 100} for name in SMOKE_VIDEOS}}))
    (root / SCALES).parent.mkdir(parents=True)
    (root / SCALES).write_text(yaml.safe_dump({
        name.split("_")[0]: {f"video{name.split('_')[1]}": {"scale": scale, "certainty": 1.0}}
        for name, scale in SMOKE_VIDEOS.items()}))
    params = root / "params.yaml"
    params.write_text(yaml.safe_dump({
        "windows": {"n_past": SMOKE_PAST, "horizons": [SMOKE_FUTURE]},
        "short_term": {"n_past": SMOKE_PAST, "n_future": SMOKE_FUTURE},
        "score_predictions": read_params(params_file)["score_predictions"]}))
    long_term = {f"tf{SMOKE_FUTURE}": root / HORIZON_WINDOWS / f"tf{SMOKE_FUTURE}.parquet",
                 Path(RELEASE_WINDOWS).stem: root / RELEASE_WINDOWS}
    for name, path in long_term.items():
        table = smoke_table("test", SMOKE_FUTURE, rng)
        write_parquet(table, path)
        for model in ("noisy_a", "noisy_b"):
            write_predictions(smoke_predictions(table, rng),
                              root / PREDICTIONS["long_term"] / name / f"{model}.parquet",
                              {**SDD_LONG_TERM.prediction_metadata(model, path), "seeds": [0, 1]})
    path = TRAJNET_SDD.table(root / SHORT_TERM_WINDOWS)
    table = smoke_table("test", SMOKE_FUTURE, rng)
    write_parquet(table, path)
    for model in ("noisy_a", "noisy_b"):
        write_predictions(smoke_predictions(table, rng),
                          root / PREDICTIONS["short_term"] / "sdd" / f"{model}.parquet",
                          {"model": model, "benchmark": TRAJNET_SDD.prediction_benchmark(),
                           "unit": "px", "seeds": [0, 1]})
    return params


# ---------------------------------------------------------------------------------------------


def bench_part(name: str, root: Path, params_file: Path, repeats: int, profile: int,
               score: Callable[[Path, Path], dict] | None = None) -> None:
    """Time part `name` (`score`: its scoring, default PARTS')."""
    default, key = PARTS[name]
    score = score or default
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
    parser = common.parser(__doc__)
    parser.add_argument("--root", type=Path, default=Path("."))
    parser.add_argument("--params", type=Path, help="default: <root>/params.yaml")
    parser.add_argument("--part", choices=(*PARTS, "all"), default="all")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--profile", type=int, default=0, metavar="N")
    args = parser.parse_args()
    parts = list(PARTS) if args.part == "all" else [args.part]
    print(f"load average {os.getloadavg()[0]:.2f}; {os.cpu_count()} cores; "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    if args.smoke:
        with tempfile.TemporaryDirectory() as folder:
            root = Path(folder)
            params_file = write_smoke_project(root, args.params or Path("params.yaml"))
            scorers = {"long_term": score_long_term,
                       "short_term": lambda r, p: score_short_term(r, p, ["sdd"])}
            for name in parts:
                bench_part(name, root, params_file, 1, args.profile, scorers[name])
        return
    params_file = args.params or args.root / "params.yaml"
    absent = common.missing({args.root / PREDICTIONS[name]: common.repro(STAGES[name])
                             for name in parts})
    for name in parts:
        if args.root / PREDICTIONS[name] not in absent:
            bench_part(name, args.root, params_file, args.repeats, args.profile)
    common.say_needs("bench_score_predictions", absent)
    if absent:
        raise SystemExit(common.NEEDS_PIPELINE)


if __name__ == "__main__":
    main()
