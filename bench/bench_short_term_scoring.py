"""Where a short-term Y-net scoring second goes, and what the scoring batch size does to it.

Not a test: prints numbers. Takes a trained `train_short_term_ynet@<dataset>` checkpoint and a
fixed seeded sample of that benchmark's *validation* windows (never the test set), samples them as
`evaluate_short_term_ynet` does (TTST at K_e = `--k`, no CWS, the profile's chunking and bf16,
`ynet_scoring.predict_samplings`) and prints:

- seconds per window at each `--batch-sizes` (windows of one scene encoded and sampled together);
- at the profile's `eval_batch_size`, the share of the time in each step (cProfile, cumulative
  seconds of the functions named below; the profiler's own overhead inflates the many small calls).

    python -m bench.bench_short_term_scoring --dataset univ --windows-sample 400 --batch-sizes 4 16 64

(ETH/UCY's univ alone has 24,334 test windows: its scoring dominates the short-term stages.)
`--smoke`: an untrained short-term Y-net of a few channels (the profile's crops) on 6 synthetic
windows of two 1024 x 1024 scenes, K_e 4, batches of 2 and 4 (seconds: the code path, not a
measurement); no checkpoint needed.
"""

from __future__ import annotations

import cProfile
import os
import pstats
import time
from dataclasses import replace

import torch

from bench import common, short_term_validation
from bench.bench_training_precision import SMOKE_IMAGE_HW, synthetic_windows
from pipeline.benchmarks.registry import short_term
from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.ynet import YnetSettings
from pipeline.data.ynet_data import group_by_scene
from pipeline.runners.short_term import ynet_options
from pipeline.runners.ynet_scoring import Sampling, predict_samplings
from ynet.model import YNet

STEPS = {  # printed name: function name in the profile (file suffix, function)
    "input crops and distance maps": ("ynet_data.py", "window_inputs"),
    "encoder + goal decoder": ("sampling.py", "encode"),
    "TTST draws": ("sampling.py", "sample_positions"),
    "TTST k-means": ("sampling.py", "kmeans"),
    "goal masses": ("sampling.py", "goal_masses"),
    "distance maps (past, waypoints)": ("heatmaps.py", "distance_maps"),
    "trajectory decoder": ("model.py", "predict_trajectory"),
    "softargmax": ("sampling.py", "softargmax"),
}


def cumulative_seconds(stats: pstats.Stats) -> dict[str, float]:
    """Cumulative seconds of each of STEPS' functions (summed over same-named entries)."""
    found = dict.fromkeys(STEPS, 0.0)
    for (filename, _, function), (_, _, _, cumulative, _) in stats.stats.items():
        for step, (suffix, name) in STEPS.items():
            if function == name and filename.endswith(suffix):
                found[step] += cumulative
    return found


def untrained(dataset: str, windows: int) -> short_term_validation.TrainedOnValidation:
    """`--smoke`'s stand-in for a trained checkpoint and its validation windows: an untrained
    short-term Y-net of the profile's settings with a few channels, and synthetic windows."""
    params = read_params()
    stage = load_profile(ShortTermModelsParams, "short_term_models", params)
    lengths = load_section(ShortTermParams, "short_term", params)
    classes = 6 if dataset == "sdd" else 3
    settings = short_term(dataset).ynet_settings(
        common.tiny_ynet(load_profile(YnetSettings, "ynet", params)), stage, lengths.n_future,
        classes)
    val, maps, sizes = synthetic_windows(windows, lengths.n_past, lengths.n_future, classes,
                                         image_hw=SMOKE_IMAGE_HW)
    torch.manual_seed(settings.seed)
    model = YNet(settings.model_config(lengths.n_past, lengths.n_future)).eval()
    scenes = group_by_scene(val, maps, sizes, settings.resize)
    return short_term_validation.TrainedOnValidation(model, settings, stage, val, scenes, None)


def main() -> None:
    parser = common.parser(__doc__)
    short_term_validation.add_arguments(parser)
    parser.add_argument("--k", type=int, default=20)
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[4, 16, 64])
    args = parser.parse_args()
    if args.smoke:
        args.k, args.batch_sizes = 4, [2, 4]
        trained = untrained(args.dataset, 6)
        torch.set_num_threads(1)
    else:
        trained = short_term_validation.load_from_arguments(args, "bench_short_term_scoring")
    model, loaded, settings, val, scenes = (trained.model, trained.settings, trained.stage,
                                            trained.val, trained.scenes)
    # as the stage samples
    sampling = Sampling(ynet_options(settings, short_term(args.dataset), args.k), settings.seed)
    configured = settings.eval_params()  # batch, chunk and bf16 as the stage scores

    def score(params: EvalParams) -> float:
        start = time.perf_counter()
        predict_samplings(model, scenes, loaded, [sampling], params, len(val), "bench",
                          loaded.crop, loaded.crop_lead_steps)
        return (time.perf_counter() - start) / len(val)

    print(f"{args.dataset}: {len(val)} val windows of {len(scenes)} scenes, K_e = {args.k}, crop "
          f"{loaded.crop}, chunk {configured.chunk_size}, bf16 {configured.bf16}, load average "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    score(configured)  # warm-up
    print(f"{'batch':>5s} {'ms per window':>14s}")
    for batch_size in args.batch_sizes:
        print(f"{batch_size:5d} {1000 * score(replace(configured, batch_size=batch_size)):14.1f}")

    profiler = cProfile.Profile()
    profiler.enable()
    score(configured)
    profiler.disable()
    stats = pstats.Stats(profiler)
    total = stats.total_tt
    print(f"\nat batch {configured.batch_size}, under cProfile ({1000 * total / len(val):.1f} ms per "
          "window with its overhead):")
    for step, seconds in cumulative_seconds(stats).items():
        print(f"  {step:32s} {1000 * seconds / len(val):7.2f} ms per window  "
              f"{100 * seconds / total:5.1f}%")


if __name__ == "__main__":
    main()
