"""How long the `paper` profile's training stages take on a device, projected from measured rates.

Not a test. The work of each training stage is its paper epochs times what one epoch goes through
(Y-net: train windows x augmentations; segmentation: crops; S-GAN and PECNet: train windows); its
hours are that work divided by the rate a bench measured for it. Counts come only from the window
tables and the label index under `data/` (`window_counts`): where one is not there, its rows say
which file they need and give no hours, never a guessed number. Likewise a stage whose rate was not
measured (the ETH/UCY Y-nets: their maps differ from the SDD map the benches time) stays unknown.

Used by `bench/bench_profiles.py` and `bench/gpu_check.py`. A GPU check run where `data/` was not at
hand can be projected afterwards, here, with this checkout's tables:

    python -m bench.projection --rates gpu_check.json [--data data]
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import pandas as pd

from bench.bench_baselines import N_FUTURE, N_PAST
from pipeline.benchmarks.registry import short_term
from pipeline.config.baseline_seeds import BaselineSeedsParams
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.segmentation import SegmentationParams
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.windows import WindowParams
from pipeline.config.ynet import YnetSettings
from pipeline.config.ynet_horizons import HorizonParams
from pipeline.config.ynet_seeds import YnetSeedsParams
from pipeline.runners import baselines

RELEASE_TABLE = "windows/release_tf30.parquet"
LABEL_INDEX = "labels/index.json"

# The keys of the measured rates a projection reads (`project`'s `rates`).
YNET_SDD = "ynet_sdd"  # paper Y-net training samples/s on an SDD-sized map (bench_profiles)
YNET_ETHUCY = "ynet_ethucy"  # ETH/UCY-sized maps at resize 0.667 (bench/gpu_check.py)
SEGMENTATION = "segmentation"  # paper U-Net training crops/s (bench/stage_rates.py)
SGAN, PECNET = "sgan", "pecnet"  # paper training: train windows x epochs per second
BASELINE_STEPS = (N_PAST, N_FUTURE)  # the baselines' rates are timed on windows of these steps


def tflops_per_s(flops: float, seconds: float) -> float:
    """Achieved TFLOP/s: `flops` floating-point operations done in `seconds`."""
    if seconds <= 0:
        raise ValueError(f"seconds must be positive, got {seconds}")
    return flops / seconds / 1e12


def stage_hours(work: float, rate: float) -> float:
    """Hours to get through `work` units (samples, crops, windows) at `rate` units per second."""
    if rate <= 0:
        raise ValueError(f"rate must be positive, got {rate}")
    return work / rate / 3600


@dataclass(frozen=True)
class Count:
    """A count read from a file under data/ (`source`), or None with `source` the file it needs."""

    value: int | None
    source: str


def train_windows(table: Path) -> int | None:
    """Distinct train windows of a window table (one row per window and step), None if absent."""
    if not table.exists():
        return None
    frame = pd.read_parquet(table, columns=["window_id", "split"])
    return int(frame.loc[frame["split"] == "train", "window_id"].nunique())


def train_videos(index: Path) -> int | None:
    """The label index's train videos (what stage `segmentation` trains on), None if absent."""
    if not index.exists():
        return None
    videos = json.loads(index.read_text())["videos"]
    return sum(1 for v in videos.values() if v["split"] == "train")


def count_keys(params: dict) -> dict[str, str]:
    """Each count a paper projection needs -> its file, relative to the data folder."""
    keys = {"release_tf30": RELEASE_TABLE, "segmentation_videos": LABEL_INDEX}
    for horizon in sorted({*load_section(WindowParams, "windows", params).horizons,
                           *paper(HorizonParams, "ynet_horizons", params).horizons}):
        keys[f"horizon_tf{horizon}"] = f"horizon_windows/tf{horizon}.parquet"
    for dataset in short_term_datasets(params):
        keys[f"short_term_{dataset}"] = ("short_term/sdd_trajnet.parquet" if dataset == "sdd"
                                         else f"short_term/ethucy_{dataset}.parquet")
    return keys


def window_counts(data: Path, params: dict) -> dict[str, Count]:
    """Every count of `count_keys`, read from `data`; a missing file gives Count(None, "needs ...")."""
    counts = {}
    for key, relative in count_keys(params).items():
        path = Path(data) / relative
        value = train_videos(path) if relative == LABEL_INDEX else train_windows(path)
        counts[key] = Count(value, str(path) if value is not None else f"needs {path}")
    return counts


def paper(cls, section: str, params: dict):
    """Section `section`'s `paper` entry as `cls`, whatever profile params.yaml selects."""
    return load_profile(cls, section, {**params, "profile": "paper"})


def short_term_datasets(params: dict) -> list[str]:
    """The short-term datasets: SDD, then the ETH/UCY folds."""
    return ["sdd", *load_section(ShortTermParams, "short_term", params).ethucy_folds]


@dataclass(frozen=True)
class Run:
    """One training run: `epochs` epochs of `per_epoch` units each (None: unknown, see `source`)."""

    label: str
    epochs: int
    per_epoch: int | None
    source: str


@dataclass(frozen=True)
class StagePlan:
    """The runs of one training stage (a DVC stage and its foreach items) and the rate they run at."""

    stage: str
    unit: str
    rate: str
    runs: list[Run] = field(default_factory=list)
    note: str = ""


def _run(label: str, epochs: int, count: Count, factor: int = 1) -> Run:
    per_epoch = None if count.value is None else count.value * factor
    return Run(label, epochs, per_epoch, count.source)


def paper_stages(params: dict, counts: dict[str, Count]) -> list[StagePlan]:
    """Every training stage of the `paper` profile, from params.yaml's paper sections and `counts`
    (`window_counts`)."""
    ynet = paper(YnetSettings, "ynet", params)
    samples = "samples (windows x augmentations)"
    main = _run("t_f 30", ynet.epochs, counts["release_tf30"], ynet.augmentations)
    horizons = paper(HorizonParams, "ynet_horizons", params)
    seeds = paper(YnetSeedsParams, "ynet_seeds", params).seeds
    stages = [
        StagePlan("train_ynet", samples, YNET_SDD, [main]),
        StagePlan("train_ynet_horizon", samples, YNET_SDD,
                  [_run(f"t_f {h}", horizons.epochs[h], counts[f"horizon_tf{h}"], ynet.augmentations)
                   for h in horizons.horizons],
                  "at the 30-s model's rate (the heads and targets have n_f maps: not re-measured)"),
        StagePlan("train_ynet_seed", samples, YNET_SDD, [replace(main, label=f"seed {s}") for s in seeds]),
    ]
    short = paper(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    runs, resize = {"sdd": [], "ethucy": []}, {}
    for dataset in short.ynet_datasets:
        benchmark = short_term(dataset)
        settings = benchmark.ynet_settings(ynet, short, windows.n_future, semantic_classes=1)
        resize[benchmark.settings_key] = settings.resize
        count, factor = counts[f"short_term_{dataset}"], settings.augmentations
        if settings.steps_per_epoch and count.value is not None:  # the first steps of each epoch
            count = Count(min(count.value * factor, settings.steps_per_epoch * settings.batch_size),
                          count.source)
            factor = 1
        runs[benchmark.settings_key].append(_run(dataset, settings.epochs, count, factor))
    stages += [
        StagePlan("train_short_term_ynet (sdd)", samples, YNET_SDD, runs["sdd"],
                  f"at the long-term model's rate (SDD maps at resize {resize.get('sdd')} against "
                  f"{ynet.resize}; n_f {windows.n_future}, one waypoint)"),
        StagePlan("train_short_term_ynet (ETH/UCY)", samples, YNET_ETHUCY, runs["ethucy"],
                  f"ETH/UCY maps at resize {resize.get('ethucy')}: bench/gpu_check.py's "
                  "ETH/UCY-sized synthetic map"),
    ]
    segmentation = paper(SegmentationParams, "segmentation", params)
    stages.append(StagePlan("segmentation", "crops", SEGMENTATION,
                            [_run("U-Net", segmentation.epochs, counts["segmentation_videos"],
                                  segmentation.crops_per_image)]))
    horizons_all = load_section(WindowParams, "windows", params).horizons
    extra = load_section(BaselineSeedsParams, "baseline_seeds", params).extra
    for name, key in (("sgan", SGAN), ("pecnet", PECNET)):
        epochs = paper(baselines.get(name).config_class, name, params).epochs
        long_term = [_run(f"t_f {h}", epochs, counts[f"horizon_tf{h}"]) for h in horizons_all]
        stages += [
            StagePlan(f"train_baseline ({name})", "train windows", key, long_term,
                      "validation after each epoch included in the rate"),
            StagePlan(f"train_baseline_seed ({name})", "train windows", key,
                      [replace(run, label=f"{run.label} seed {s}") for s in extra for run in long_term]),
            StagePlan(f"train_short_term_baseline ({name})", "train windows", key,
                      [_run(d, short_term(d).epochs(short, name), counts[f"short_term_{d}"])
                       for d in short_term_datasets(params)],
                      f"at the rate of {BASELINE_STEPS[0]} + {BASELINE_STEPS[1]}-step windows "
                      f"(these have {windows.n_past} + "
                      f"{windows.n_future})"),
        ]
    return stages


def needs_files(sources: list[str]) -> str:
    """"needs a/x, y; b/z" for sources "needs a/x", "needs a/y", "needs b/z" (each once, in order)."""
    folders: dict[str, list[str]] = {}
    for source in dict.fromkeys(sources):
        path = Path(source.removeprefix("needs "))
        folders.setdefault(str(path.parent), []).append(path.name)
    return "needs " + "; ".join(f"{folder}/{', '.join(names)}" for folder, names in folders.items())


def project(stages: list[StagePlan], rates: dict[str, float | None]) -> list[dict]:
    """Each stage's work (sum over its runs of epochs x units per epoch) and hours at its rate; both
    None, with `unknown` saying why, where a count or the rate is missing."""
    rows = []
    for plan in stages:
        missing = [run.source for run in plan.runs if run.per_epoch is None]
        work = None if missing else sum(run.epochs * run.per_epoch for run in plan.runs)
        rate = rates.get(plan.rate)
        unknown = []
        if missing:
            unknown.append(needs_files(missing))
        if rate is None:
            unknown.append(f"rate {plan.rate!r} not measured")
        hours = stage_hours(work, rate) if work is not None and rate is not None and plan.runs else None
        if not plan.runs:
            work, hours = 0, 0.0
        rows.append({"stage": plan.stage, "runs": len(plan.runs), "unit": plan.unit,
                     "rate_key": plan.rate, "rate": rate, "work": work, "hours": hours,
                     "unknown": "; ".join(unknown) if hours is None else "", "note": plan.note,
                     "epochs": sorted({run.epochs for run in plan.runs})})
    return rows


def total_hours(rows: list[dict]) -> tuple[float, int]:
    """The sum of the known hours, and how many rows are unknown."""
    known = [row["hours"] for row in rows if row["hours"] is not None]
    return math.fsum(known), len(rows) - len(known)


def projection_lines(rows: list[dict], device: str) -> list[str]:
    """The projection as printed: one line per stage, then the total of the known rows."""
    lines = [f"paper training stages on {device} (training steps at the measured rates; "
             "Y-net's per-epoch validation not included):"]
    for row in rows:
        epochs = "/".join(map(str, row["epochs"])) or "-"
        if row["hours"] is None:
            what = f"unknown: {row['unknown']}"
        else:
            what = f"{row['hours']:10.1f} h  ({row['work']:,} {row['unit']} at {row['rate']:.3g}/s)"
        note = f"  [{row['note']}]" if row["note"] else ""
        lines.append(f"  {row['stage']:38s} {row['runs']:3d} runs x {epochs:>7s} epochs  {what}{note}")
    hours, unknown = total_hours(rows)
    lines.append(f"  total of the known rows: {hours:,.1f} h ({hours / 24:.1f} days)"
                 + (f"; {unknown} row(s) unknown" if unknown else ""))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rates", type=Path, required=True,
                        help="a JSON file with a 'rates' mapping (what bench/gpu_check.py writes)")
    parser.add_argument("--data", type=Path, default=Path("data"))
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    args = parser.parse_args()
    measured = json.loads(args.rates.read_text())
    params = read_params(args.params)
    rows = project(paper_stages(params, window_counts(args.data, params)), measured["rates"])
    print("\n".join(projection_lines(rows, measured.get("device", str(args.rates)))))


if __name__ == "__main__":
    main()

