"""How long the whole `paper` workload takes on 1, 4 and 8 GPUs: a projection, not a timing.

Not a test. `make repro` runs each stage as one task on a Dask cluster, a training stage on one GPU
(tools/parallel_repro.py). Here each run of each `paper` training stage (`bench/projection.py`'s
StagePlans: one DVC stage each) becomes a task of its hours at a rate of `--rates`, waiting for the
stages dvc.yaml makes it wait for where that matters for wall time: `segmentation` ->
`semantic_maps` -> the SDD Y-nets, and `train_ynet` -> `train_ynet_horizon@*` (their stage reads
data/ynet/model.pt whatever `ynet_horizons.paper.init_from_main` says). A greedy list scheduler,
longest task first among the ready ones, gives the wall time on G GPUs; the critical path is the
bound no number of GPUs beats. Stages without a rate (the scoring stages, the CPU data stages) are
left out and listed. The ETH/UCY Y-net rate, never measured, is the SDD rate scaled by the map
pixels their training samples see at their resizes (Y-net's FLOPs grow with the pixels).

    python -m bench.cluster_projection --rates bench/rates/h100-2026-11-24.json [--gpus 1 4 8]

`--smoke`: fixture counts, rates and map sizes, no data/ read: the code path in a second.
"""

from __future__ import annotations

import heapq
import json
import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from bench import common
from bench.projection import (YNET_ETHUCY, YNET_SDD, Count, StagePlan, count_keys,
                              paper, paper_stages, short_term_datasets, stage_hours, window_counts)
from pipeline.benchmarks.ethucy import FOLDS
from pipeline.config.loading import load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.ynet import YnetSettings
from ynet.heatmaps import padded_size

GPUS = (1, 4, 8)
SEMANTIC_MAPS = "semantic_maps"
# plan stage -> the plan stages all of whose runs it waits for (dvc.yaml's deps that cost GPU time)
NEEDS = {
    SEMANTIC_MAPS: ("segmentation",),
    "train_ynet": (SEMANTIC_MAPS,),
    "train_ynet_horizon": (SEMANTIC_MAPS, "train_ynet"),
    "train_ynet_seed": (SEMANTIC_MAPS,),
    "train_short_term_ynet (sdd)": (SEMANTIC_MAPS,),
}
LEFT_OUT_ALWAYS = ("the CPU data stages (windows, labels, short_term_windows, ...): no GPU, not timed",
                   "the scoring stages (evaluate_*, rpecnet_rollouts, evaluate_rpecnet, score_*): "
                   "no paper-profile rate measured")
ESTIMATED_FROM_FLOPS = "estimated from FLOPs"
SMOKE_PIXELS = (96_000, 184_000)  # SDD, ETH/UCY padded map pixels a training sample sees
SMOKE_RATES = {"rates": {YNET_SDD: 50.0, "segmentation": 20.0, "sgan": 350.0, "pecnet": 1600.0},
               "stage_seconds": {SEMANTIC_MAPS: 23}, "device": "smoke fixture rates"}


@dataclass(frozen=True)
class Task:
    """One DVC stage as one task on one GPU: `hours` long, started after every task of `needs`."""

    name: str
    hours: float
    needs: tuple[str, ...] = ()


@dataclass(frozen=True)
class Schedule:
    """Where and when each task ran on `gpus` GPUs: `placed` task -> (gpu, start hour)."""

    gpus: int
    makespan: float
    placed: dict[str, tuple[int, float]]
    busy: float

    @property
    def utilisation(self) -> float:
        """The share of the GPUs' hours up to the makespan spent on tasks."""
        return self.busy / (self.gpus * self.makespan) if self.makespan > 0 else 1.0


def check_graph(tasks: list[Task]) -> dict[str, Task]:
    """Tasks by name; a repeated name or a dependency on no task is an error, not a silent skip."""
    by_name = {}
    for task in tasks:
        if task.name in by_name:
            raise ValueError(f"two tasks named {task.name!r}")
        by_name[task.name] = task
    for task in tasks:
        unknown = [need for need in task.needs if need not in by_name]
        if unknown:
            raise ValueError(f"{task.name!r} needs unknown task(s) {unknown}")
    return by_name


def list_schedule(tasks: list[Task], gpus: int) -> Schedule:
    """Greedy list scheduling: whenever a GPU is free, it takes the longest task whose needs have all
    finished (ties: the first name); if none is ready it waits for the next task to finish.
    LPT order keeps the long Y-nets from starting last, behind a queue of short baselines."""
    if gpus < 1:
        raise ValueError(f"gpus must be at least 1, got {gpus}")
    by_name = check_graph(tasks)
    free = [(0.0, gpu) for gpu in range(gpus)]  # (free from, gpu), a heap
    finish: dict[str, float] = {}
    placed: dict[str, tuple[int, float]] = {}
    pending = set(by_name)
    while pending:
        now, gpu = heapq.heappop(free)
        ready = [name for name in pending
                 if all(need in finish and finish[need] <= now for need in by_name[name].needs)]
        if not ready:
            later = [end for end in finish.values() if end > now]
            if not later:
                raise ValueError(f"tasks that can never start (a cycle): {sorted(pending)}")
            heapq.heappush(free, (min(later), gpu))
            continue
        name = min(ready, key=lambda n: (-by_name[n].hours, n))
        pending.remove(name)
        placed[name] = (gpu, now)
        finish[name] = now + by_name[name].hours
        heapq.heappush(free, (finish[name], gpu))
    return Schedule(gpus, max(finish.values(), default=0.0), placed,
                    math.fsum(task.hours for task in tasks))


def critical_path(tasks: list[Task]) -> tuple[float, list[str]]:
    """The longest chain of needs (hours, its tasks first to last): no number of GPUs finishes
    sooner."""
    by_name = check_graph(tasks)
    longest: dict[str, tuple[float, list[str]]] = {}

    def chain(name: str, seen: tuple[str, ...] = ()) -> tuple[float, list[str]]:
        if name in seen:
            raise ValueError(f"a cycle through {name!r}")
        if name not in longest:
            before = max((chain(need, (*seen, name)) for need in by_name[name].needs),
                         default=(0.0, []), key=lambda found: found[0])
            longest[name] = (before[0] + by_name[name].hours, [*before[1], name])
        return longest[name]

    return max((chain(name) for name in by_name), default=(0.0, []), key=lambda found: found[0])


def plan_tasks(stages: list[StagePlan], rates: dict[str, float | None],
               stage_seconds: dict[str, float]) -> tuple[list[Task], list[str]]:
    """One task per run of each plan at its rate, plus `semantic_maps` (its measured seconds, else 0 h),
    with the needs of `NEEDS`; and the runs left out (no count or no rate), each saying why."""
    runs: dict[str, list[tuple[str, float]]] = {}
    left_out = []
    for plan in stages:
        rate = rates.get(plan.rate)
        for run in plan.runs:
            name = f"{plan.stage} [{run.label}]"
            if rate is None or run.per_epoch is None:
                left_out.append(f"{name}: " + (f"no rate {plan.rate!r}" if rate is None else run.source))
                continue
            runs.setdefault(plan.stage, []).append((name, stage_hours(run.epochs * run.per_epoch, rate)))
    runs[SEMANTIC_MAPS] = [(SEMANTIC_MAPS, stage_seconds.get(SEMANTIC_MAPS, 0) / 3600)]
    tasks = []
    for stage, named in runs.items():
        needs = tuple(name for upstream in NEEDS.get(stage, ()) for name, _ in runs.get(upstream, []))
        tasks += [Task(name, hours, needs) for name, hours in named]
    return tasks, left_out


def padded_pixels(height: int, width: int, resize: float) -> int:
    """Pixels of the map Y-net runs on for a (height, width) scene image at `resize` (padded to 32s)."""
    padded_h, padded_w = padded_size(round(height * resize), round(width * resize))
    return padded_h * padded_w


def mean_sample_pixels(windows_per_scene: dict[str, int], sizes: dict[str, tuple[int, int]],
                       resize: float) -> float:
    """The map pixels of an average training sample: each scene's padded pixels, weighted by its
    train windows (a quarter turn does not change a map's pixels)."""
    total = sum(windows_per_scene.values())
    if total == 0:
        raise ValueError("no train windows")
    return sum(n * padded_pixels(*sizes[scene], resize) for scene, n in windows_per_scene.items()) / total


def scaled_rate(rate: float, pixels_measured: float, pixels_target: float) -> float:
    """A Y-net rate measured on maps of `pixels_measured` moved to maps of `pixels_target`: its
    convolutions' FLOPs, and so its time per sample, grow with the pixels."""
    return rate * pixels_measured / pixels_target


def train_windows_per_scene(tables: list[Path]) -> dict[str, int]:
    """Distinct train windows per scene over `tables`."""
    counts: dict[str, int] = {}
    for table in tables:
        frame = pd.read_parquet(table, columns=["window_id", "scene_id", "split"])
        train = frame[frame["split"] == "train"].drop_duplicates("window_id")
        for scene, n in train["scene_id"].value_counts().items():
            counts[scene] = counts.get(scene, 0) + int(n)
    return counts


def map_pixels(data: Path, params: dict) -> tuple[float, float] | str:
    """(SDD, ETH/UCY) mean map pixels per training sample at the paper resizes, from the window
    tables and the scene images under `data`; or the file that is missing."""
    from pipeline.data.labels import image_sizes  # cv2: only where the real maps are read

    sdd_table = data / "windows/release_tf30.parquet"
    ethucy_index = data / "short_term/ethucy_semantic/index.json"
    folds = [data / f"short_term/ethucy_{fold}.parquet"
             for fold in short_term_datasets(params) if fold != "sdd"]
    for path in (sdd_table, ethucy_index, *folds):
        if not path.exists():
            return f"needs {path}"
    ynet = paper(YnetSettings, "ynet", params)
    short = paper(ShortTermModelsParams, "short_term_models", params)
    n_future = load_section(ShortTermParams, "short_term", params).n_future
    ethucy_resize = FOLDS["eth"].ynet_settings(ynet, short, n_future, semantic_classes=1).resize
    sdd_windows = train_windows_per_scene([sdd_table])
    scenes = json.loads(ethucy_index.read_text())["scenes"]
    ethucy_sizes = {scene: tuple(entry["image_hw"]) for scene, entry in scenes.items()}
    return (mean_sample_pixels(sdd_windows, image_sizes(data / "raw/sdd", sdd_windows), ynet.resize),
            mean_sample_pixels(train_windows_per_scene(folds), ethucy_sizes, ethucy_resize))


def with_ethucy_estimate(measured: dict, pixels: tuple[float, float] | str) -> dict:
    """`measured` with an ETH/UCY Y-net rate (and its source) estimated from the SDD one where it has
    none; where that cannot be estimated, its source says why."""
    rates, sources = dict(measured["rates"]), dict(measured.get("sources", {}))
    if rates.get(YNET_ETHUCY) is not None:
        return measured
    if rates.get(YNET_SDD) is None or isinstance(pixels, str):
        sources[YNET_ETHUCY] = f"not estimated: {pixels if isinstance(pixels, str) else 'no SDD rate'}"
        return {**measured, "sources": sources}
    sdd, ethucy = pixels
    rates[YNET_ETHUCY] = scaled_rate(rates[YNET_SDD], sdd, ethucy)
    sources[YNET_ETHUCY] = (f"{ESTIMATED_FROM_FLOPS}: {YNET_SDD} x {sdd:,.0f} / {ethucy:,.0f} padded map "
                            "pixels per training sample (SDD at ynet.paper.resize, ETH/UCY at "
                            "short_term_models.paper.ynet_ethucy.resize, weighted by train windows)")
    return {**measured, "rates": rates, "sources": sources}


def projection_table(schedules: list[Schedule]) -> list[str]:
    """G, wall hours, days, speed-up over the first schedule, utilisation: one line each."""
    base = schedules[0].makespan
    lines = [f"{'GPUs':>5s} {'wall h':>9s} {'days':>7s} {'speed-up':>9s} {'utilisation':>12s}"]
    for s in schedules:
        speedup = base / s.makespan if s.makespan > 0 else 1.0
        lines.append(f"{s.gpus:5d} {s.makespan:9.1f} {s.makespan / 24:7.2f} {speedup:8.2f}x "
                     f"{s.utilisation:11.0%}")
    return lines


def report_lines(tasks: list[Task], gpus: list[int], measured: dict, left_out: list[str]) -> list[str]:
    """The projection as printed: the table, the critical path, where each rate came from, what is
    left out."""
    total = math.fsum(task.hours for task in tasks)
    lines = [f"paper workload: {len(tasks)} GPU tasks, {total:,.1f} GPU hours in all, at the rates of "
             f"{measured.get('device', '?')} (a projection: greedy longest-first list schedule)"]
    lines += projection_table([list_schedule(tasks, g) for g in gpus])
    hours, path = critical_path(tasks)
    lines.append(f"critical path: {hours:,.1f} h ({hours / 24:.2f} days), the least wall time on any "
                 "number of GPUs:")
    by_name = {task.name: task for task in tasks}
    lines += [f"  {by_name[name].hours:8.2f} h  {name}" for name in path]
    lines.append("rates:")
    rates, sources = measured["rates"], measured.get("sources", {})
    for key in sorted({*rates, *sources} - set(measured.get("stage_seconds", {}))):
        value = f"{rates[key]:,.1f}/s" if rates.get(key) is not None else "none"
        lines.append(f"  {key:14s} {value:>10s}  {sources.get(key, 'measured: ' + measured.get('device', '?'))}")
    for key, seconds in measured.get("stage_seconds", {}).items():
        lines.append(f"  {key:14s} {seconds:>8,.0f} s  {sources.get(key, '')}")
    lines.append("left out:")
    lines += [f"  {why}" for why in (*left_out, *LEFT_OUT_ALWAYS)]
    return lines


def main() -> None:
    parser = common.parser(__doc__)
    parser.add_argument("--rates", type=Path, help="JSON: 'rates' {key: units/s}, optional 'sources' "
                        "{key: where it came from}, 'stage_seconds', 'device' (bench/rates/)")
    parser.add_argument("--data", type=Path, default=Path("data"))
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    parser.add_argument("--gpus", type=int, nargs="+", default=list(GPUS))
    args = parser.parse_args()
    params = read_params(args.params)
    if args.smoke:
        measured = SMOKE_RATES
        counts = {key: Count(100, "smoke fixture") for key in count_keys(params)}
        pixels: tuple[float, float] | str = SMOKE_PIXELS
    else:
        if args.rates is None:
            parser.error("--rates is required (or --smoke)")
        measured = json.loads(args.rates.read_text())
        counts = window_counts(args.data, params)
        pixels = map_pixels(args.data, params)
    measured = with_ethucy_estimate(measured, pixels)
    tasks, left_out = plan_tasks(paper_stages(params, counts), measured["rates"],
                                 measured.get("stage_seconds", {}))
    print("\n".join(report_lines(tasks, args.gpus, measured, left_out)))


if __name__ == "__main__":
    main()
