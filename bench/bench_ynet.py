"""Speed of `ynet` on CPU against the authors' code (their figures: `AUTHORS` below).

Not a test: prints numbers. Random weights and a random 6-class semantic map, padded 512 x 416 input
(deathCircle_0 at resize 0.25), long-term SDD config (n_p 5, n_f 30, waypoints 14 and 29).

    python -m bench.bench_ynet --threads 2 --repeats 3 [--profile cpu|paper] [--smoke]

Timings are wall-clock min / median / max over `--repeats` runs after one warm-up. On a shared
machine they are noisy: the load average is printed with each line. With 2 threads on 2 cores that
another process is also using, OpenMP makes everything 2-3x slower than 1 thread: compare runs
with --threads 1 and 2.

The script re-executes itself with glibc malloc told to keep freed memory (`GLIBC_TUNABLES` below).
By default glibc hands every large tensor back to the kernel when it is freed, so each training
step faults its whole working set in again: at batch 8 that is 2.7 million page faults and half of
the step's time. Run training and evaluation stages with the same setting (--no-malloc-tuning
shows the difference).

`--smoke`: a Y-net of a few channels on a 64 x 64 map, batches of 1 and 2, K_e 4 and K_a 1 and 2,
one repeat (seconds: the code path, not a measurement; no authors' figures beside it).
"""

from __future__ import annotations

import dataclasses
import os
import resource
import statistics
import sys
import time
from pathlib import Path

import torch

from bench import common
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.ttst import TtstParams
from pipeline.config.ynet import YnetSettings
from ynet.config import upstream_max_distance
from ynet.heatmaps import distance_maps, gaussian_heatmaps, padded_size, scene_and_past
from ynet.loss import ynet_loss
from ynet.model import YNet, YNetConfig
from ynet.sampling import SamplingOptions, predict, sample_waypoints, softargmax

KEEP_FREED_MEMORY = "glibc.malloc.mmap_threshold=4294967296:glibc.malloc.trim_threshold=17179869184"
AUTHORS = {
    "train_b1": "1.41 / 1.48 / 1.59 s",
    "train_b8": "21.4 s (2.68 s per sample, peak RSS 5.6 GiB)",
    "eval_ka1": "1.60 / 4.67 / 5.35 s (mean 4.0)",
    "eval_ka5": "7.40 / 21.0 / 29.7 s",
}


def keep_freed_memory() -> None:
    """Re-execute this script with glibc malloc keeping freed memory (as dvc.yaml runs the torch
    stages), unless it already runs so."""
    if os.environ.get("GLIBC_TUNABLES") != KEEP_FREED_MEMORY:
        spec = getattr(sys.modules["__main__"], "__spec__", None)  # run as `python -m bench.x`
        argv = ["-m", spec.name, *sys.argv[1:]] if spec is not None else sys.argv
        os.execve(sys.executable, [sys.executable, *argv],
                  {**os.environ, "GLIBC_TUNABLES": KEEP_FREED_MEMORY})


def timed(fn, repeats: int) -> list[float]:
    fn()  # warm-up: allocator, oneDNN kernel selection
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return times


def summary(times: list[float]) -> str:
    return f"{min(times):.2f} / {statistics.median(times):.2f} / {max(times):.2f} s"


def load() -> str:
    return "load average %.2f %.2f %.2f" % os.getloadavg()


def peak_rss_gib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def make_window(cfg: YNetConfig, batch: int, height: int, width: int, g: torch.Generator):
    """A random semantic map (1, C, H, W) and `batch` straight-ish tracks (B, n_p + n_f, 2)."""
    semantic = torch.softmax(torch.randn(1, cfg.semantic_classes, height, width, generator=g), 1)
    start = torch.rand(batch, 1, 2, generator=g) * torch.tensor([width * 0.5, height * 0.5]) + 50
    step = torch.randn(batch, 1, 2, generator=g) * 3
    track = start + step * torch.arange(cfg.obs_len + cfg.pred_len)[None, :, None]
    return semantic, track.clamp(0, min(height, width) - 1)


def bench_training(cfg, batch, height, width, repeats, channels_last, max_distance) -> list[float]:
    """One optimiser step: inputs built (distance maps, Gaussian targets), forward, loss, backward, Adam."""
    g = torch.Generator().manual_seed(0)
    model = YNet(cfg)
    fmt = torch.channels_last if channels_last else torch.contiguous_format
    model = model.to(memory_format=fmt)
    opt = torch.optim.Adam(model.parameters(), lr=1e-4)
    semantic, track = make_window(cfg, batch, height, width, g)
    past, future = track[:, : cfg.obs_len], track[:, cfg.obs_len :]

    def step():
        x = scene_and_past(semantic.expand(batch, -1, -1, -1), past, max_distance)
        x = x.contiguous(memory_format=fmt)
        target = gaussian_heatmaps(future, height, width)
        waypoint_maps = distance_maps(future[:, list(cfg.waypoints)], height, width, max_distance)
        loss = ynet_loss(*model(x, waypoint_maps), target).total
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    return timed(step, repeats)


def bench_eval(cfg, options, height, width, repeats, max_distance, bf16) -> list[float]:
    """One test window: input built, encoder + goal decoder, TTST + CWS, trajectory decoder."""
    g = torch.Generator().manual_seed(0)
    model = YNet(cfg).eval()
    semantic, track = make_window(cfg, 1, height, width, g)
    past = track[:, : cfg.obs_len]

    def window():
        x = scene_and_past(semantic, past, max_distance)
        predict(model, x, past[:, -1], options, torch.Generator().manual_seed(1), max_distance, bf16=bf16)

    return timed(window, repeats)


def eval_breakdown(cfg, options, height, width, max_distance) -> dict[str, float]:
    """Where one window's evaluation time goes (fp32, channels_last, one run after a warm-up)."""
    g = torch.Generator().manual_seed(0)
    model = YNet(cfg).eval()
    semantic, track = make_window(cfg, 1, height, width, g)
    past = track[:, : cfg.obs_len]
    out = {}
    for _ in range(2):  # the second pass is the one kept
        with torch.inference_mode():
            t0 = time.perf_counter()
            x = scene_and_past(semantic, past, max_distance).contiguous(memory_format=torch.channels_last)
            features = model.encode(x)
            goal_logits = model.predict_goals(features)
            t1 = time.perf_counter()
            wl = goal_logits[:, list(cfg.waypoints)].contiguous()
            samples = sample_waypoints(wl, past[:, -1], options, torch.Generator().manual_seed(1))
            t2 = time.perf_counter()
            decode = soft = 0.0
            for s in range(0, options.K, 8):
                c = samples[:, s : s + 8]
                ta = time.perf_counter()
                maps = distance_maps(c.flatten(1, 2), height, width, max_distance).unflatten(1, c.shape[1:3])
                logits = model.predict_trajectory(features, maps)
                tb = time.perf_counter()
                softargmax(logits)
                tc = time.perf_counter()
                decode += tb - ta
                soft += tc - tb
        out = {
            "inputs + encoder + goal decoder": t1 - t0,
            "goal + waypoint sampling (TTST, CWS)": t2 - t1,
            "trajectory decoder (batched, shared skips)": decode,
            "softargmax of the trajectory maps": soft,
        }
    return out


def main():
    parser = common.parser(__doc__)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--height", type=int, default=512)
    parser.add_argument("--width", type=int, default=416)
    parser.add_argument("--keep-denormals", action="store_true", help="do not flush denormal floats")
    parser.add_argument("--skip-training", action="store_true")
    parser.add_argument("--skip-eval", action="store_true")
    parser.add_argument("--no-malloc-tuning", action="store_true", help="leave glibc malloc at its defaults")
    parser.add_argument("--profile", choices=("cpu", "paper"),
                        help="use params.yaml's ynet.<profile> resize (the map shrinks with it) and batch size")
    args = parser.parse_args()
    if not args.no_malloc_tuning:
        keep_freed_memory()

    if args.smoke:
        args.threads = 1
    torch.set_num_threads(args.threads)
    # Adam's second-moment estimates of these tiny BCE gradients fall into denormal floats, which
    # make x86 arithmetic ~10x slower (~1 s per optimiser step here); flushing them costs no accuracy.
    torch.set_flush_denormal(not args.keep_denormals)
    cfg = YNetConfig(obs_len=5, pred_len=30, semantic_classes=6, waypoints=(14, 29))
    h, w, resize, batches = args.height, args.width, 0.25, [(1, False), (1, True), (8, True)]
    k_e, k_as = 20, (1, 5)
    params_file = Path(__file__).resolve().parents[1] / "params.yaml"
    temperature = load_section(TtstParams, "ttst", read_params(params_file)).temperature
    max_distance = upstream_max_distance(resize)
    if args.profile:
        settings = load_profile(YnetSettings, "ynet", {**read_params(), "profile": args.profile})
        resize = settings.resize
        h, w = padded_size(round(args.height * resize / 0.25), round(args.width * resize / 0.25))
        # both layouts at the profile's batch: ynet_training uses channels_last when the profile
        # asks for bf16, yet on an AVX2-only CPU (float32 there) NCHW was 2-15% faster (2026-11-26)
        batches = [(1, True), (settings.batch_size, False), (settings.batch_size, True)]
        max_distance = settings.max_distance
        cfg = settings.model_config(5, 30)
        print(f"profile {args.profile}: resize {resize}, batch {settings.batch_size}")
    if args.smoke:
        h, w, batches, args.repeats = 64, 64, [(1, False), (1, True), (2, True)], 1
        k_e, k_as = 4, (1, 2)
        cfg = dataclasses.replace(cfg, **{k: tuple(v) for k, v in common.TINY_CHANNELS.items()})
    authors_apply = resize == 0.25 and not args.smoke  # the authors' figures: their map only
    n_params = sum(p.numel() for p in YNet(cfg).parameters())
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, input 1 x {cfg.in_channels} x {h} x {w}, "
          f"{n_params:,} parameters, flush denormals {not args.keep_denormals}, "
          f"GLIBC_TUNABLES={os.environ.get('GLIBC_TUNABLES', '(unset)')}")
    print(f"{args.repeats} repeats after a warm-up; min / median / max wall-clock. {load()}\n")

    if not args.skip_training:
        print("Training step (inputs built, forward, loss, backward, Adam step)")
        for batch, cl in batches:
            times = bench_training(cfg, batch, h, w, args.repeats, cl, max_distance)
            layout = "channels_last" if cl else "NCHW         "
            authors = AUTHORS["train_b1" if batch == 1 else "train_b8"] if authors_apply else "n/a"
            print(f"  batch {batch} {layout}: {summary(times)}  ({batch / statistics.median(times):.2f} samples/s)"
                  f"   authors: {authors}   peak RSS so far {peak_rss_gib():.1f} GiB   {load()}")
        print()

    if not args.skip_eval:
        print(f"Evaluation per test window, TTST + CWS, K_e {k_e} (input built, encoder, goal decoder, sampling, "
              "trajectory decoder)")
        for k_a in k_as:
            options = SamplingOptions(K_e=k_e, K_a=k_a, temperature=temperature)
            for bf16 in (False, True):
                times = bench_eval(cfg, options, h, w, args.repeats, max_distance, bf16)
                authors = AUTHORS["eval_ka1" if k_a == 1 else "eval_ka5"] if authors_apply else "n/a"
                precision = "bf16 autocast" if bf16 else "fp32         "
                print(f"  K_a {k_a} {precision}: {summary(times)}  ({1 / statistics.median(times):.2f} windows/s)"
                      f"   authors (fp32): {authors}   {load()}")
        print("  (the authors' evaluation figures are per window over the SDD test scenes, about 152,000 px on"
              f" average at resize 0.25; these are on the {h} x {w} = {h * w:,} px map)")
        print(f"\nBreakdown of one fp32 window, K_e {k_e}, K_a 1:")
        parts = eval_breakdown(cfg, SamplingOptions(K_e=k_e, K_a=1, temperature=temperature), h, w,
                               max_distance)
        total = sum(parts.values())
        for name, seconds in parts.items():
            print(f"  {name:45s} {seconds:6.2f} s  {100 * seconds / total:4.0f}%")
        print(f"  peak RSS {peak_rss_gib():.1f} GiB")


if __name__ == "__main__":
    main()
