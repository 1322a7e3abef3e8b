"""Training samples/s and scoring windows/s of the long-term Y-net, `paper` beside `cpu` profile,
and the `paper` training stages' hours projected from them.

Not a test: prints numbers. Runs the pipeline's own code paths (`ynet_training.train_epoch`,
`ynet_scoring.predict_scenes`, so device moves, autocast and input building are included) on a
synthetic scene of SDD size (original 2048 x 1664 px, so 512 x 416 at the paper's resize 0.25),
with each profile's settings from params.yaml (`ynet.<profile>`, `eval.<profile>`: resize, kernel,
batch, K_e / K_a, chunking) on `--device` (default: CUDA when present, else the CPU). The model is
laid out as the stages lay it out (`pipeline.device.conv_layout`: channels-last on CUDA), the
optimiser is training's, and the warm-up runs every input shape the timed part will see (a
rotated scene is another shape; cuDNN autotunes and the allocator grows per shape), so the timed
steps hold no set-up.

    python -m bench.bench_profiles [--device auto|cpu|cuda] [--threads 2] [--steps 20] [--windows 32]
                                   [--profiles cpu,paper] [--data data] [--skip-stages] [--stage-steps 8]
                                   [--smoke]

Printed per profile: samples/s and windows/s; achieved TFLOP/s, from the model's FLOPs counted
for the timed shapes (`torch.utils.flop_counter`: convolutions and matmuls of the forward and
backward passes in training, of the encoder, goal decoder and the K-sample trajectory decoder in
scoring; over the whole step's time, input building and sampling included); the peak memory
(CUDA: `torch.cuda.max_memory_allocated` of the measurement; the CPU: the process's peak RSS so
far). Then the `paper` segmentation, S-GAN and PECNet rates (`bench/stage_rates.py`; skip them
with --skip-stages) and the hours of every `paper` training stage (`bench/projection.py`, counts
from the window tables under --data; a missing table is named, not guessed).

On 2 CPU cores the defaults take several minutes (the `paper` Y-net: about 0.5 training samples/s,
the U-Net 6 s a step); `--steps 3 --windows 4 --stage-steps 1` is the quick look (about 2.5 min
on one thread). A busy 2-core machine runs two threads many times slower than one (OpenMP threads
wait for each other): compare --threads 1 and 2 there. On a GPU, `bench/gpu_check.py` runs this
and more in one command. `--smoke`: a Y-net of a few channels on a 256 x 256 scene, 2 steps and 2
windows per profile at K_e 4, the stages' rates on one step or epoch, the U-Net 4 channels wide
(seconds: the code path, not a measurement).

It re-executes itself with glibc malloc told to keep freed memory, as the stages run (dvc.yaml's
GLIBC_TUNABLES; see bench/bench_ynet.py).
"""

from __future__ import annotations

import dataclasses
import os
import resource
import time
from pathlib import Path

import numpy as np
import torch
from torch.utils.flop_counter import FlopCounterMode

from bench import common, projection
from bench.bench_ynet import keep_freed_memory
from bench.stage_rates import smoke_params, stage_rates
from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.ttst import TtstParams
from pipeline.config.ynet import YnetSettings
from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import group_by_scene
from pipeline.device import (SCORING, TRAINING, conv_layout, describe, select_device,
                             synchronize)
from pipeline.runners.ynet_scoring import predict_scenes, sampling_options
from pipeline.runners.ynet_training import (epoch_plan, plan_input_shape, train_epoch,
                                            ynet_optimizer)
from ynet.heatmaps import padded_size
from ynet.loss import ynet_loss
from ynet.model import YNet, YNetConfig
from ynet.sampling import SamplingOptions

IMAGE_HW = (2048, 1664)  # original pixels of the synthetic scene
SMOKE_IMAGE_HW = (256, 256)
N_PAST, N_FUTURE = 5, 30


def synthetic_windows(n: int, seed: int, image_hw: tuple[int, int] = IMAGE_HW,
                      steps: tuple[int, int] = (N_PAST, N_FUTURE), classes: int = 6
                      ) -> tuple[WindowArrays, dict, dict]:
    """`n` straight walks of `steps` (past, future) steps over one scene with a random map of
    `classes` classes (original pixels)."""
    rng = np.random.default_rng(seed)
    height, width = image_hw
    n_past, n_future = steps
    start = rng.uniform([0.1 * width, 0.1 * height], [0.6 * width, 0.5 * height], size=(n, 1, 2))
    velocity = rng.uniform(-12, 18, size=(n, 1, 2)) * width / IMAGE_HW[1]
    xy = start + np.arange(n_past + n_future)[None, :, None] * velocity
    arrays = WindowArrays(past=xy[:, :n_past], future=xy[:, n_past:], window_id=np.arange(n),
                          scene_id=np.array(["bench_0"] * n), track_id=np.arange(n),
                          first_frame=np.zeros(n), split=np.array(["train"] * n))
    probs = rng.dirichlet(np.ones(classes), size=(height // 4, width // 4)).astype(np.float32)
    return arrays, {"bench_0": probs.transpose(2, 0, 1)}, {"bench_0": image_hw}


# ---------------------------------------------------------------------------------------------
# Shapes, FLOPs, memory


def warmup_plan(plan: list, shapes: list[tuple]) -> list:
    """The first entry of `plan` of each distinct shape in `shapes` (one per entry): a warm-up
    that meets every shape the timed steps will."""
    first = {}
    for entry, shape in zip(plan, shapes):
        first.setdefault(shape, entry)
    return list(first.values())


def warmup_rows(windows: int, batch: int) -> list[int]:
    """Window counts of the scoring warm-up calls: one full batch, and the last, partial batch
    of the timed windows if there is one (its own shapes)."""
    sizes = [min(windows, batch)]
    if windows > batch and windows % batch:
        sizes.append(windows % batch)
    return sizes


def training_flops(config: YNetConfig, shape: tuple[int, int, int]) -> tuple[int, int]:
    """(forward, forward + backward) FLOPs of one training step's model and loss at `shape`
    (batch, height, width), counted on the meta device (nothing computed)."""
    batch, height, width = shape
    with torch.device("meta"):
        model = YNet(config)
        inputs = torch.empty(batch, config.in_channels, height, width)
        waypoint_maps = torch.empty(batch, config.n_waypoints, height, width)
        target = torch.empty(batch, config.pred_len, height, width)
    with FlopCounterMode(display=False) as forward:
        goal_logits, trajectory_logits = model(inputs, waypoint_maps)
    with FlopCounterMode(display=False) as backward:
        ynet_loss(goal_logits, trajectory_logits, target).total.backward()
    return forward.get_total_flops(), forward.get_total_flops() + backward.get_total_flops()


def scoring_flops(config: YNetConfig, batch: int, height: int, width: int, k: int, chunk: int) -> int:
    """FLOPs of scoring one batch of windows: encoder and goal decoder once, the trajectory decoder
    for `k` samples per window, `chunk` at a time (as `ynet.sampling.predict_encoded`)."""
    with torch.device("meta"), torch.inference_mode():
        model = YNet(config)
        with FlopCounterMode(display=False) as counter:
            features = model.encode(torch.empty(batch, config.in_channels, height, width))
            model.predict_goals(features)
            for start in range(0, k, chunk):
                samples = min(chunk, k - start)
                model.predict_trajectory(
                    features, torch.empty(batch, samples, config.n_waypoints, height, width))
    return counter.get_total_flops()


def reset_peak_memory(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.reset_peak_memory_stats(device)


def peak_memory(device: torch.device) -> dict:
    """The peak memory and what it is: CUDA's allocated peak since `reset_peak_memory`, or on the
    CPU the process's peak resident set (Linux: KiB), which no measurement can reset."""
    if device.type == "cuda":
        return {"bytes": int(torch.cuda.max_memory_allocated(device)),
                "what": "torch.cuda.max_memory_allocated (this measurement)"}
    return {"bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
            "what": "peak RSS of the process so far (resource.getrusage ru_maxrss)"}


# ---------------------------------------------------------------------------------------------
# Training and scoring


class TrainingBench:
    """A model, its optimiser (training's groups) and `steps` training steps of one synthetic scene
    (every batch full), ready to time; `run(plan)` is training's own `train_epoch`."""

    def __init__(self, settings: YnetSettings, device: torch.device, steps: int,
                 image_hw: tuple[int, int] = IMAGE_HW, window_steps: tuple[int, int] = (N_PAST, N_FUTURE)):
        self.settings, self.device = settings, device
        arrays, maps, sizes = synthetic_windows(settings.batch_size * steps, 0, image_hw, window_steps,
                                                settings.semantic_classes)
        self.scenes = group_by_scene(arrays, maps, sizes, settings.resize, device)
        torch.manual_seed(settings.seed)
        self.config = settings.model_config(*window_steps)
        self.model = conv_layout(YNet(self.config), device)
        self.optimizer = ynet_optimizer(self.model, settings, device)
        self.plan = epoch_plan(self.scenes, settings, np.random.default_rng(0))[:steps]
        self.shapes = [plan_input_shape(parts, self.scenes, settings) for parts in self.plan]

    def run(self, plan: list) -> None:
        train_epoch(self.model, self.optimizer, self.scenes, self.settings, plan, 1, [], self.device)

    def measure(self) -> dict:
        """Samples/s over the timed steps after a warm-up on their shapes; FLOPs, TFLOP/s, memory."""
        reset_peak_memory(self.device)
        warm = warmup_plan(self.plan, self.shapes)
        self.run(warm)
        synchronize(self.device)
        start = time.perf_counter()
        self.run(self.plan)
        synchronize(self.device)
        seconds = time.perf_counter() - start
        counted = {shape: training_flops(self.config, shape) for shape in set(self.shapes)}
        flops = sum(counted[shape][1] for shape in self.shapes)
        samples = sum(shape[0] for shape in self.shapes)
        return {"rate": samples / seconds, "unit": "samples/s", "seconds": seconds,
                "steps": len(self.plan), "samples": samples, "warmup_steps": len(warm),
                "map": list(padded_size(*self.scenes[0].semantic.shape[-2:])),
                "shapes": sorted(map(list, counted)),
                "forward_flops_per_sample": sum(counted[s][0] for s in self.shapes) / samples,
                "flops_per_sample": flops / samples,
                "tflops": projection.tflops_per_s(flops, seconds),
                "peak_memory": peak_memory(self.device)}


class ScoringBench:
    """A model in eval mode (as `load_model` lays it out) and `windows` synthetic test windows."""

    def __init__(self, settings: YnetSettings, evaluation: EvalParams, device: torch.device,
                 windows: int, options: SamplingOptions, image_hw: tuple[int, int] = IMAGE_HW,
                 window_steps: tuple[int, int] = (N_PAST, N_FUTURE)):
        self.settings, self.evaluation, self.options, self.device = settings, evaluation, options, device
        arrays, maps, sizes = synthetic_windows(windows, 1, image_hw, window_steps,
                                                settings.semantic_classes)
        self.scene = group_by_scene(arrays, maps, sizes, settings.resize, device)[0]
        self.config = settings.model_config(*window_steps)
        self.model = conv_layout(YNet(self.config).eval(), device)
        self.windows = windows
        # the first `rows` windows of each size `run` takes, cut here: cutting is no scoring work
        # (on CUDA a numpy index waits for the device)
        self.first = {rows: self.scene.subset(np.arange(rows))
                      for rows in {windows, *warmup_rows(windows, evaluation.batch_size)}}

    def run(self, rows: int, desc: str = "bench") -> tuple[np.ndarray, np.ndarray]:
        """Score the first `rows` windows (`rows`: the windows, or a size of `warmup_rows`) with
        seed 0: (paths, goals) as `predict_scenes` gives them."""
        return predict_scenes(self.model, [self.first[rows]], self.settings, self.options, 0,
                              self.evaluation, self.windows, desc)

    def measure(self) -> dict:
        """Windows/s over all windows after a warm-up on their batch shapes; FLOPs, TFLOP/s, memory."""
        reset_peak_memory(self.device)
        warm = warmup_rows(self.windows, self.evaluation.batch_size)
        for rows in warm:
            self.run(rows, "warm-up")
        synchronize(self.device)
        start = time.perf_counter()
        self.run(self.windows)
        synchronize(self.device)
        seconds = time.perf_counter() - start
        height, width = padded_size(*self.scene.semantic.shape[-2:])
        batch = self.evaluation.batch_size
        sizes = [batch] * (self.windows // batch) + ([self.windows % batch] if self.windows % batch else [])
        flops = sum(scoring_flops(self.config, b, height, width, self.options.K,
                                  self.evaluation.chunk_size) for b in sizes)
        return {"rate": self.windows / seconds, "unit": "windows/s", "seconds": seconds,
                "windows": self.windows, "warmup_windows": sum(warm), "k_e": self.options.K_e,
                "k_a": self.options.K_a, "map": [height, width],
                "flops_per_window": flops / self.windows,
                "tflops": projection.tflops_per_s(flops, seconds),
                "peak_memory": peak_memory(self.device)}


def profile_settings(params: dict, profile: str, threads: int) -> tuple[YnetSettings, EvalParams]:
    chosen = {**params, "profile": profile}
    settings = load_profile(YnetSettings, "ynet", chosen)
    settings.threads = threads
    return settings, load_profile(EvalParams, "eval", chosen)


def main_options(evaluation: EvalParams, params: dict) -> SamplingOptions:
    """TTST + CWS at the profile's K_e and K_a, with params.yaml's TTST and CWS values."""
    return sampling_options(evaluation.k_e, evaluation.k_a, load_section(TtstParams, "ttst", params),
                            load_section(CwsParams, "cws", params), True, True)


def gib(n: int) -> str:
    return f"{n / 2**30:.2f} GiB"


def main() -> None:
    parser = common.parser(__doc__)
    parser.add_argument("--device", default="auto")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--steps", type=int, default=20, help="timed training steps per profile")
    parser.add_argument("--windows", type=int, default=32, help="timed test windows per profile")
    parser.add_argument("--profiles", default="cpu,paper", help="comma-separated, of cpu and paper")
    parser.add_argument("--data", type=Path, default=Path("data"),
                        help="where the window tables are (for the projection's counts)")
    parser.add_argument("--skip-stages", action="store_true",
                        help="leave out the segmentation, S-GAN and PECNet rates (their rows unknown)")
    parser.add_argument("--stage-steps", type=int, default=8,
                        help="segmentation steps per timed epoch (two epochs after a warm-up one)")
    args = parser.parse_args()
    keep_freed_memory()
    if args.smoke:
        args.steps, args.windows, args.threads = 2, 2, 1
    image_hw = SMOKE_IMAGE_HW if args.smoke else IMAGE_HW
    torch.set_num_threads(args.threads)
    torch.set_flush_denormal(True)
    device = select_device(args.device, purpose=SCORING)
    params = read_params()
    print(f"torch {torch.__version__} on {describe(device)}; GLIBC_TUNABLES="
          f"{os.environ.get('GLIBC_TUNABLES', '(unset)')}; load average "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    print(f"{args.steps} timed training steps and {args.windows} timed test windows per profile, "
          "each after a warm-up on the same shapes; TFLOP/s of the model's counted FLOPs\n")
    print(f"{'profile':8s} {'resize':>6s} {'map':>9s} {'batch':>5s} {'K_e x K_a':>9s} "
          f"{'train samples/s':>16s} {'TFLOP/s':>8s} {'score windows/s':>16s} {'TFLOP/s':>8s} "
          f"{'peak train':>11s} {'peak score':>11s}")
    rates, memory_what = {}, ""
    for profile in args.profiles.split(","):
        settings, evaluation = profile_settings(params, profile, args.threads)
        if args.smoke:
            settings = common.tiny_ynet(settings)
            evaluation = dataclasses.replace(evaluation, k_e=4, k_a=1, batch_size=2)
        select_device(args.device, purpose=TRAINING)  # each measured as its stages run
        train = TrainingBench(settings, device, args.steps, image_hw).measure()
        select_device(args.device, purpose=SCORING)
        options = main_options(evaluation, params)
        score = ScoringBench(settings, evaluation, device, args.windows, options, image_hw).measure()
        rates[profile] = train["rate"]
        memory_what = train["peak_memory"]["what"]
        hw = "x".join(map(str, train["map"]))
        print(f"{profile:8s} {settings.resize:6.4g} {hw:>9s} {settings.batch_size:5d} "
              f"{evaluation.k_e:>4d} x {evaluation.k_a:<2d} {train['rate']:16.2f} {train['tflops']:8.3f} "
              f"{score['rate']:16.3f} {score['tflops']:8.3f} {gib(train['peak_memory']['bytes']):>11s} "
              f"{gib(score['peak_memory']['bytes']):>11s}")
        print(f"{'':8s} training: {train['flops_per_sample'] / 1e9:.1f} GFLOP per sample "
              f"(forward {train['forward_flops_per_sample'] / 1e9:.1f}), shapes {train['shapes']}, "
              f"{train['warmup_steps']} warm-up step(s), {train['seconds']:.1f} s timed; scoring: "
              f"{score['flops_per_window'] / 1e9:.1f} GFLOP per window, {score['seconds']:.1f} s timed")
    print(f"(peak memory: {memory_what})")

    measured = {projection.YNET_SDD: rates.get("paper")}
    if not args.skip_stages:
        select_device(args.device, purpose=TRAINING)
        print("\npaper segmentation, S-GAN and PECNet training (bench/stage_rates.py):")
        for key, rate in stage_rates(smoke_params(params) if args.smoke else params, device,
                                     smoke=args.smoke, segmentation_steps=args.stage_steps).items():
            measured[key] = rate["rate"]
            print(f"  {key:13s} {rate['rate']:10.2f} {rate['unit']}  ({rate['what']}; "
                  f"{rate['epochs']} epoch(s) in {rate['seconds']:.1f} s after one warm-up epoch)")
    print()
    rows = projection.project(projection.paper_stages(params, projection.window_counts(args.data, params)),
                              measured)
    print("\n".join(projection.projection_lines(rows, describe(device))))


if __name__ == "__main__":
    main()
