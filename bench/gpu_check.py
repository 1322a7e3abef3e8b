"""One prepared GPU check: the numbers a GPU session needs, from one command, written to one file.

Not a test. Needs only the repository (synthetic inputs: no data/, no ../shared, no network, no
DVC). On a CUDA device, with the `paper` profile's settings (params.yaml):

1. Y-net's training rate on an SDD-sized map under the old training settings (deterministic
   cuDNN, autotuning off: the device set up with purpose=SCORING) and under the new
   (purpose=TRAINING); and on an ETH/UCY-sized map (a UCY scene, 720 x 576, at the paper's
   resize 1 / 1.5, 3 classes, the short-term windows) in training's settings;
2. the top CUDA kernels by device time over a few training steps (torch.profiler);
3. scoring windows/s at K_e 20, K_a 1 (TTST + CWS) on the SDD map, and at K_e 20 (TTST) on the
   ETH/UCY one, each in scoring's repeatable settings and in training's; whether two scorings with
   one seed give the same bytes; scoring's top kernels and its kernel launches per window;
4. the host syncs of a few training steps and of one scoring batch, once both are warm, as
   `torch.cuda.set_sync_debug_mode("warn")` reports them (the warnings caught and counted);
5. the segmentation, S-GAN and PECNet training rates (`bench/stage_rates.py`) and the hours of
   every `paper` training stage (`bench/projection.py`; counts from --data's window tables, else
   unknown: `python -m bench.projection --rates <the JSON>` projects them later where data/ is).

Each part is timed after a warm-up on its shapes (`bench/bench_profiles.py`) and runs on its own:
one that fails records its error and the rest go on. Prints everything and writes
`gpu_check.json` (every number) and `gpu_check.txt` (what was printed) into --out (a folder;
default $OUT), or the JSON to --out itself if it ends in .json. `--rates-file` also writes the
measured rates in the layout of `bench/rates/` (device, rates, sources) for the projection.

    python -m bench.gpu_check --out "$OUT"          # a GPU machine: a few minutes
    python -m bench.gpu_check --out "$OUT" --rates-file "$OUT/h200-<date>.json"
    python -m bench.gpu_check --smoke --out /tmp/x  # anywhere: tiny sizes, CUDA parts skipped, < 1 min
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import time
import traceback
import warnings
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import torch
from torch.autograd import DeviceType

from bench import common, projection
from bench.bench_profiles import (IMAGE_HW, ScoringBench, TrainingBench, gib,
                                  main_options, profile_settings, warmup_rows)
from bench.bench_ynet import keep_freed_memory
from bench.stage_rates import smoke_params, stage_rates
from pipeline.benchmarks.registry import short_term
from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.ynet import YnetSettings
from pipeline.device import SCORING, TRAINING, describe, select_device, synchronize
from pipeline.runners.short_term import ynet_options
from ynet.sampling import SamplingOptions

SMOKE_IMAGE_HW = (512, 416)  # a quarter of the SDD-sized scene per side: 128 x 104 at resize 0.25
ETHUCY_IMAGE_HW = (576, 720)  # a UCY scene (zara, univ; hotel too) in oracle pixels
SMOKE_ETHUCY_IMAGE_HW = (144, 180)  # a quarter of it per side: 96 x 120 at resize 1 / 1.5
ETHUCY_CLASSES = 3
NO_CUDA = "skipped: no CUDA"
# What torch's sync debug mode says at each sync. Only that: `set_sync_debug_mode` itself warns,
# once a process, that the mode "does not yet detect all synchronizing operations", and counting
# every warning with "synchroniz" in it counted that one too (2 for one `.item()`, 2026-11-28).
SYNC_WARNING = "called a synchronizing CUDA operation"
# The host calls that launch a kernel (or a captured graph of them), as torch.profiler names them.
LAUNCH_CALLS = {"cudaLaunchKernel", "cudaLaunchKernelExC", "cuLaunchKernel", "cuLaunchKernelEx",
                "cudaGraphLaunch"}


def output_paths(out: Path) -> tuple[Path, Path]:
    """(JSON, text) files for --out: a .json path and the .txt beside it, or a folder's
    gpu_check.json and gpu_check.txt."""
    out = Path(out)
    if out.suffix == ".json":
        return out, out.with_suffix(".txt")
    return out / "gpu_check.json", out / "gpu_check.txt"


def top_events(events, time_attr: str, n: int, device_type=None) -> list[dict]:
    """The `n` profiler averages (`prof.key_averages()`) with the most `time_attr` (microseconds),
    of `device_type` only if given (`torch.autograd.DeviceType.CUDA`: the kernels themselves, not
    the ops that launched them), with their share of that type's total."""
    timed = [(getattr(e, time_attr, 0) or 0, e) for e in events
             if device_type is None or e.device_type == device_type]
    total = sum(t for t, _ in timed)
    ranked = sorted((pair for pair in timed if pair[0] > 0), key=lambda pair: -pair[0])[:n]
    return [{"name": e.key, "ms": t / 1000, "share": t / total if total else 0.0, "calls": e.count}
            for t, e in ranked]


def count_sync_warnings(fn: Callable[[], None],
                        set_mode: Callable[[str | int], None] | None = None) -> dict:
    """Run `fn` with CUDA's sync debug mode at "warn" (`set_mode`, default
    `torch.cuda.set_sync_debug_mode`) and count the synchronizing-operation warnings it raises,
    with the lines (file:line) they came from."""
    set_mode = set_mode or torch.cuda.set_sync_debug_mode
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        set_mode("warn")
        try:
            fn()
        finally:
            set_mode(0)
    syncs = [w for w in caught if SYNC_WARNING in str(w.message)]
    where = Counter(f"{Path(w.filename).parent.name}/{Path(w.filename).name}:{w.lineno}" for w in syncs)
    return {"count": len(syncs), "where": [[line, n] for line, n in where.most_common(10)],
            "other_warnings": len(caught) - len(syncs)}


def profiled(run: Callable[[], object], device: torch.device, activities, kernel_type,
             time_attr: str = "self_device_time_total") -> dict:
    """`run()` under torch.profiler with `activities`: the top kernels (events of `kernel_type`,
    by `time_attr`), the ops that launched them (by self device time), the kernels' total time
    and the kernel launches (`LAUNCH_CALLS`: 0 on the CPU)."""
    from torch.profiler import profile
    with profile(activities=activities) as prof:
        run()
        synchronize(device)
    events = prof.key_averages()
    kernel_us = sum(getattr(e, time_attr) for e in events if e.device_type == kernel_type)
    return {"kernels": top_events(events, time_attr, 15, kernel_type),
            "ops": top_events(events, "self_device_time_total", 10, DeviceType.CPU),
            "kernel_ms": kernel_us / 1000,
            "launches": sum(e.count for e in events if e.key in LAUNCH_CALLS)}


def profile_training(bench: TrainingBench, steps: int, activities, kernel_type,
                     time_attr: str = "self_device_time_total") -> dict:
    """`profiled` over `steps` warm training steps."""
    plan = bench.plan[:steps]
    return {"steps": len(plan),
            **profiled(lambda: bench.run(plan), bench.device, activities, kernel_type, time_attr)}


def profile_scoring(scoring: ScoringBench, activities, kernel_type,
                    time_attr: str = "self_device_time_total") -> dict:
    """`profiled` over scoring all of `scoring`'s (warm) windows, with the launches per window."""
    result = profiled(lambda: scoring.run(scoring.windows), scoring.device, activities, kernel_type,
                      time_attr)
    return {"windows": scoring.windows, **result,
            "launches_per_window": result["launches"] / scoring.windows}


def repeats(scoring: ScoringBench) -> dict:
    """Whether scoring all windows twice with one seed gives the same bytes (paths and goals), and
    by how much they differ at most (original pixels)."""
    first, second = scoring.run(scoring.windows), scoring.run(scoring.windows)
    differences = [float(abs(a - b).max()) for a, b in zip(first, second)]
    return {"identical": all(a.tobytes() == b.tobytes() for a, b in zip(first, second)),
            "max_abs_difference_px": max(differences), "windows": scoring.windows}


def ethucy_setup(params: dict, threads: int
                 ) -> tuple[YnetSettings, EvalParams, SamplingOptions, tuple[int, int]]:
    """The `paper` short-term Y-net of an ETH/UCY fold with `ETHUCY_CLASSES` classes: its settings
    (whole maps at resize 1 / 1.5), its scoring's batches and TTST at K_e 20, and its window steps
    (past, future), as `pipeline.runners.short_term` has them."""
    short = load_profile(ShortTermModelsParams, "short_term_models", {**params, "profile": "paper"})
    windows = load_section(ShortTermParams, "short_term", params)
    benchmark = short_term("eth")
    ynet, _ = profile_settings(params, "paper", threads)
    settings = benchmark.ynet_settings(ynet, short, windows.n_future, ETHUCY_CLASSES)
    return (settings, short.eval_params(), ynet_options(short, benchmark, 20),
            (windows.n_past, windows.n_future))


def sync_counts(bench: TrainingBench, scoring: ScoringBench, steps: int,
                set_mode: Callable[[str | int], None] | None = None) -> dict:
    """The host syncs of `steps` warm training steps (training's device settings) and of one warm
    scoring batch (scoring's), `count_sync_warnings` of each; `calibration`: the count for one
    `.item()`, which must be 1 on CUDA (0 would mean the warnings were not seen)."""
    one = torch.ones((), device=bench.device)  # made before: only the read is counted
    calibration = count_sync_warnings(lambda: one.item(), set_mode)
    select_device(str(bench.device), purpose=TRAINING)
    plan = bench.plan[:steps]
    train = {**count_sync_warnings(lambda: bench.run(plan), set_mode), "steps": len(plan)}
    select_device(str(scoring.device), purpose=SCORING)
    rows = warmup_rows(scoring.windows, scoring.evaluation.batch_size)[0]  # one batch, warm
    score = {**count_sync_warnings(lambda: scoring.run(rows), set_mode), "windows": rows}
    return {"calibration": calibration["count"], "calibration_where": calibration["where"],
            "training": train, "scoring": score}


class Report:
    """What the check prints, kept for the text file, and the JSON it writes."""

    def __init__(self):
        self.lines: list[str] = []
        self.data: dict = {}

    def say(self, line: str = "") -> None:
        print(line, flush=True)
        self.lines.append(line)

    def part(self, key: str, fn: Callable[[], object]) -> object:
        """`data[key] = fn()`, or {"error": ...} if it fails (the other parts still run)."""
        start = time.perf_counter()
        try:
            self.data[key] = fn()
        except Exception as e:  # noqa: BLE001 - one failing part must not lose the others
            self.data[key] = {"error": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc()}
            self.say(f"  {key}: FAILED {type(e).__name__}: {e}")
        self.say(f"  ({key}: {time.perf_counter() - start:.1f} s)")
        return self.data[key]


def environment(device: torch.device) -> dict:
    env = {"torch": torch.__version__, "cuda": torch.version.cuda, "device": describe(device),
           "threads": torch.get_num_threads(), "cpu_count": os.cpu_count(),
           "load_average": list(os.getloadavg())}
    if device.type == "cuda":
        env["cudnn"] = torch.backends.cudnn.version()
        env["gpu_memory_bytes"] = torch.cuda.get_device_properties(device).total_memory
    return env


def rates_record(report: Report, device: torch.device, commit: str) -> dict:
    """The measured rates in `bench/rates/`'s layout: where and with which torch, the rates the
    projection reads, scoring's windows/s, and where each came from."""
    env = report.data["environment"]
    where = (f"bench/gpu_check.py at {commit} on {env['device']}, torch {env['torch']} "
             f"(CUDA {env['cuda']}), {time.strftime('%Y-%m-%d')}")
    rates = {key: value for key, value in report.data["rates"].items() if value is not None}
    scoring = {key: report.data[key]["rate"] for key in SCORING_PARTS
               if isinstance(report.data.get(key), dict) and "rate" in report.data[key]}
    return {"device": f"one {describe(device)}, torch {env['torch']}, {time.strftime('%Y-%m-%d')}",
            "rates": rates, "scoring_windows_per_s": scoring,
            "sources": {key: f"measured by {where}" for key in [*rates, *scoring]}}


SCORING_PARTS = ("scoring", "scoring_training_settings", "ethucy_scoring",
                 "ethucy_scoring_training_settings")


def git_commit() -> str:
    """The checkout's commit, or "unknown" (a GPU machine may get the tree without .git)."""
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=Path(__file__).resolve().parent, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=os.environ.get("OUT"),
                        help="folder for gpu_check.json / .txt (default $OUT), or a .json path")
    parser.add_argument("--smoke", action="store_true",
                        help="tiny sizes and a few steps, to test the script (CPU: under a minute)")
    parser.add_argument("--device", default="auto")
    parser.add_argument("--steps", type=int, default=20, help="timed training steps")
    parser.add_argument("--windows", type=int, default=32, help="timed scoring windows")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--data", type=Path, default=Path("data"),
                        help="window tables for the projection's counts (absent: unknown)")
    parser.add_argument("--rates-file", type=Path,
                        help="also write the measured rates there, in bench/rates/'s layout")
    args = parser.parse_args(argv)
    if args.out is None:
        parser.error("give --out (or set $OUT)")
    keep_freed_memory()
    began = time.perf_counter()
    torch.set_num_threads(args.threads)
    torch.set_flush_denormal(True)
    params = read_params()
    device = select_device(args.device, purpose=TRAINING)
    cuda = device.type == "cuda"
    smoke = args.smoke
    steps, windows = (2, 2) if smoke else (args.steps, args.windows)
    image_hw = SMOKE_IMAGE_HW if smoke else IMAGE_HW
    settings, evaluation = profile_settings(params, "paper", args.threads)
    if smoke:
        settings = common.tiny_ynet(settings)  # batches of 2, a few channels
    evaluation = dataclasses.replace(evaluation, k_e=20, k_a=1)
    ethucy, ethucy_evaluation, ethucy_options, ethucy_steps = ethucy_setup(params, args.threads)
    ethucy_hw = SMOKE_ETHUCY_IMAGE_HW if smoke else ETHUCY_IMAGE_HW
    if smoke:
        ethucy = common.tiny_ynet(ethucy)
    report = Report()
    report.data.update(smoke=smoke, environment=environment(device), profile="paper")
    report.say(f"GPU check{' (smoke)' if smoke else ''}: torch {torch.__version__} on {describe(device)}; "
               f"paper Y-net, synthetic {image_hw[0]}x{image_hw[1]} scene at resize {settings.resize}, "
               f"batch {settings.batch_size}; {steps} timed training steps, {windows} timed windows")

    bench = TrainingBench(settings, device, steps, image_hw)
    ethucy_bench = TrainingBench(ethucy, device, steps, ethucy_hw, ethucy_steps)

    def measured(timed: TrainingBench | ScoringBench, purpose: str, what: str) -> dict:
        """`timed.measure()` in `purpose`'s device settings, printed."""
        select_device(args.device, purpose=purpose)
        result = {**timed.measure(), "purpose": purpose}
        per = "sample" if result["unit"] == "samples/s" else "window"
        shapes = f", shapes {result['shapes']}" if "shapes" in result else ""
        report.say(f"  {what}, purpose={purpose:8s}: {result['rate']:8.3f} {result['unit']}, "
                   f"{result['tflops']:.3f} TFLOP/s ({result[f'flops_per_{per}'] / 1e9:.1f} GFLOP per "
                   f"{per}), peak {gib(result['peak_memory']['bytes'])}{shapes}")
        return result

    report.say("\n1. Y-net training: old settings (deterministic cuDNN, no autotuning) and new")
    old = report.part("training_old", lambda: measured(bench, SCORING, "training"))
    new = report.part("training_new", lambda: measured(bench, TRAINING, "training"))
    if "rate" in old and "rate" in new:
        report.data["training_speedup"] = new["rate"] / old["rate"]
        report.say(f"  new / old: {report.data['training_speedup']:.2f}x"
                   + ("" if cuda else " (the CPU: both settings are the same)"))
    report.say(f"  ETH/UCY: synthetic {ethucy_hw[0]}x{ethucy_hw[1]} scene at resize {ethucy.resize:.4g}, "
               f"{ethucy.semantic_classes} classes, {ethucy_steps[0]} + {ethucy_steps[1]} steps, "
               f"batch {ethucy.batch_size}")
    ethucy_new = report.part("ethucy_training",
                             lambda: measured(ethucy_bench, TRAINING, "ETH/UCY training"))

    report.say("\n2. Top CUDA kernels over a few training steps (new settings)")

    def print_profile(result: dict, size: str) -> None:
        for what in ("kernels", "ops"):
            report.say(f"  {what} by self device time over {size} (ms, share, calls):")
            for row in result[what]:
                report.say(f"  {row['ms']:9.2f} ms {100 * row['share']:5.1f}% {row['calls']:6d}x  "
                           f"{row['name'][:100]}")

    def kernels() -> object:
        if not cuda:
            report.say(f"  {NO_CUDA}")
            return NO_CUDA
        from torch.profiler import ProfilerActivity
        select_device(args.device, purpose=TRAINING)
        result = profile_training(bench, 3, [ProfilerActivity.CPU, ProfilerActivity.CUDA],
                                  DeviceType.CUDA)
        print_profile(result, f"{result['steps']} steps")
        return result

    report.part("kernels", kernels)

    scoring = ScoringBench(settings, evaluation, device, windows, main_options(evaluation, params),
                           image_hw)
    ethucy_scoring = ScoringBench(ethucy, ethucy_evaluation, device, windows, ethucy_options,
                                  ethucy_hw, ethucy_steps)
    report.say(f"\n3. Scoring: SDD at K_e {evaluation.k_e}, K_a {evaluation.k_a} (TTST + CWS), "
               f"ETH/UCY at K_e {ethucy_options.K_e} (TTST); scoring's settings, then training's")

    for key, scored, purpose, what in zip(SCORING_PARTS, (scoring, scoring, ethucy_scoring, ethucy_scoring),
                                          (SCORING, TRAINING) * 2, ("SDD", "SDD", "ETH/UCY", "ETH/UCY")):
        report.part(key, lambda scored=scored, purpose=purpose, what=what:
                    measured(scored, purpose, f"{what} scoring"))

    def repeatable() -> dict:
        select_device(args.device, purpose=SCORING)
        result = repeats(scoring)
        report.say(f"  SDD scored twice with one seed (scoring's settings): identical {result['identical']}, "
                   f"max difference {result['max_abs_difference_px']:.3g} px")
        return result

    report.part("scoring_repeats", repeatable)

    def scoring_kernels() -> object:
        if not cuda:
            report.say(f"  scoring's kernels: {NO_CUDA}")
            return NO_CUDA
        from torch.profiler import ProfilerActivity
        select_device(args.device, purpose=SCORING)
        result = profile_scoring(scoring, [ProfilerActivity.CPU, ProfilerActivity.CUDA],
                                 DeviceType.CUDA)
        report.say(f"  SDD scoring, scoring's settings: {result['launches']} kernel launches, "
                   f"{result['launches_per_window']:.0f} per window, {result['kernel_ms']:.1f} ms of kernels")
        print_profile(result, f"{result['windows']} windows")
        return result

    report.part("scoring_kernels", scoring_kernels)

    report.say("\n4. Host syncs (torch.cuda.set_sync_debug_mode('warn'))")

    def syncs() -> object:
        if not cuda:
            report.say(f"  {NO_CUDA}")
            return NO_CUDA
        result = sync_counts(bench, scoring, 5)
        report.say(f"  calibration: {result['calibration']} sync counted for one .item() (expected 1)")
        for what in ("training", "scoring"):
            counted = result[what]
            size = (f"{counted['steps']} steps" if what == "training"
                    else f"one batch of {counted['windows']} windows")
            report.say(f"  {what}: {counted['count']} syncs over {size}; where: {counted['where']}")
        return result

    report.part("syncs", syncs)

    report.say("\n5. paper segmentation, S-GAN and PECNet training rates, and the projection")

    def other_stages() -> dict:
        select_device(args.device, purpose=TRAINING)
        rates = stage_rates(smoke_params(params) if smoke else params, device, smoke=smoke)
        for key, rate in rates.items():
            report.say(f"  {key:13s} {rate['rate']:10.2f} {rate['unit']} ({rate['what']})")
        return rates

    stages = report.part("stage_rates", other_stages)
    rates = {projection.YNET_SDD: new.get("rate") if isinstance(new, dict) else None,
             projection.YNET_ETHUCY: ethucy_new.get("rate") if isinstance(ethucy_new, dict) else None}
    if isinstance(stages, dict):
        rates.update({key: value["rate"] for key, value in stages.items() if "rate" in value})
    report.data["rates"] = rates
    counts = projection.window_counts(args.data, params)
    report.data["counts"] = {key: dataclasses.asdict(count) for key, count in counts.items()}
    rows = projection.project(projection.paper_stages(params, counts), rates)
    report.data["projection"] = rows
    hours, unknown = projection.total_hours(rows)
    report.data["projection_total_known_hours"] = hours
    report.say()
    for line in projection.projection_lines(rows, describe(device)):
        report.say(line)

    report.data["seconds"] = time.perf_counter() - began
    report.say(f"\nGPU check done in {report.data['seconds']:.0f} s")
    json_path, text_path = output_paths(args.out)
    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(json.dumps(report.data, indent=1, default=str) + "\n")
    text_path.write_text("\n".join(report.lines) + "\n")
    print(f"wrote {json_path} and {text_path}")
    if args.rates_file:
        args.rates_file.parent.mkdir(parents=True, exist_ok=True)
        args.rates_file.write_text(json.dumps(rates_record(report, device, git_commit()), indent=1) + "\n")
        print(f"wrote {args.rates_file}")


if __name__ == "__main__":
    main()
