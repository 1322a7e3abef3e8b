"""Seconds of `evaluate_ynet`'s scoring: every setting in its own pass over the test windows (the
encoder and goal decoder re-run for each round, ablation row and K_a grid cell) beside one pass
that encodes each batch once and samples it for every setting (`ynet_scoring.predict_samplings`),
same machine, same run. Also checks that both give the same numbers, bit for bit.

Not a test: prints numbers. Uses the real test windows (`data/windows/release_tf30.parquet`), the
semantic maps (`data/semantic_maps`) and the trained model (`data/ynet/model.pt`), `--windows`
test windows evenly spaced over the table's order, the active profile's `eval` section and `ttst` /
`cws`: the settings `evaluation_sequence` samples (main rounds, ablation, K_e x K_a grid).

    python -m bench.bench_evaluation_pass [--windows 24] [--threads 2] [--smoke]

`--smoke`: an untrained Y-net of a few channels on 4 synthetic windows of one 256 x 256 scene, K_e 4
and a K_a grid of 1 and 2 (seconds: the code path, not a measurement); no data needed.

It re-executes itself with glibc malloc told to keep freed memory, as the stages run (see
bench/bench_ynet.py). The machine may be shared: the load average is printed with the times.
"""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from bench import common
from bench.bench_profiles import N_FUTURE, N_PAST, SMOKE_IMAGE_HW, synthetic_windows
from bench.bench_ynet import keep_freed_memory
from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.ttst import TtstParams
from pipeline.config.ynet import YnetSettings
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.window_table import WindowArrays, to_arrays
from pipeline.data.ynet_data import SceneWindows, group_by_scene
from pipeline.device import conv_layout
from pipeline.runners.ynet_scoring import (load_for_scoring, predict_samplings,
                                           sequence_settings, setting_samplings)
from pipeline.data.labels import image_sizes
from ynet.model import YNet

WINDOWS = Path("data/windows/release_tf30.parquet")
MAPS = Path("data/semantic_maps")
MODEL = Path("data/ynet/model.pt")
SDD = Path("data/raw/sdd")
NEEDS = {WINDOWS: common.repro("windows"), MAPS: common.repro("semantic_maps"),
         MODEL: common.repro("train_ynet"), SDD: common.repro("fetch@sdd")}


def trained(params: dict, windows: int, threads: int
            ) -> tuple[YNet, YnetSettings, list[SceneWindows], WindowArrays]:
    """The trained model and `windows` test windows evenly spaced over the table's order."""
    table = pd.read_parquet(WINDOWS)
    table = table[table["split"] == "test"]
    ids = table["window_id"].unique()
    ids = ids[np.unique(np.linspace(0, len(ids) - 1, min(windows, len(ids))).astype(int))]
    test = to_arrays(table[table["window_id"].isin(ids)], params["windows"]["n_past"])
    model, settings, scenes = load_for_scoring(MODEL, test, load_semantic_maps(MAPS),
                                               image_sizes(SDD, set(test.scene_id)), threads)
    return model, settings, scenes, test


def untrained(params: dict, windows: int, threads: int
              ) -> tuple[YNet, YnetSettings, list[SceneWindows], WindowArrays]:
    """`--smoke`'s stand-in: a tiny untrained model of the profile and synthetic windows."""
    torch.set_num_threads(threads)
    torch.set_flush_denormal(True)
    settings = common.tiny_ynet(load_profile(YnetSettings, "ynet", params))
    test, maps, sizes = synthetic_windows(windows, 0, SMOKE_IMAGE_HW)
    model = conv_layout(YNet(settings.model_config(N_PAST, N_FUTURE)).eval(), torch.device("cpu"))
    return model, settings, group_by_scene(test, maps, sizes, settings.resize), test


def main() -> None:
    parser = common.parser(__doc__)
    parser.add_argument("--windows", type=int, default=24, help="test windows timed")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    keep_freed_memory()
    params = read_params()
    evaluation = load_profile(EvalParams, "eval", params)
    ttst, cws = load_section(TtstParams, "ttst", params), load_section(CwsParams, "cws", params)
    if args.smoke:
        args.threads = 1
        evaluation = dataclasses.replace(evaluation, k_e=4, k_a=1, rounds=1, ka_grid_k_e=[4],
                                         ka_grid_k_a=[1, 2], batch_size=2)
        model, settings, scenes, test = untrained(params, 4, args.threads)
    else:
        common.require("bench_evaluation_pass", NEEDS)
        model, settings, scenes, test = trained(params, args.windows, args.threads)
    samplings = setting_samplings(sequence_settings(evaluation, ttst, cws), evaluation.seed)
    n = len(test)
    warm = [scenes[0].subset(np.arange(1))]
    predict_samplings(model, warm, settings, samplings[:1], evaluation, n, "warm-up")

    start = time.perf_counter()
    separate = [predict_samplings(model, scenes, settings, [s], evaluation, n, "separate")[0][0]
                for s in samplings]
    separate_s = time.perf_counter() - start
    start = time.perf_counter()
    together, shared_s = predict_samplings(model, scenes, settings, samplings, evaluation, n, "one")
    together_s = time.perf_counter() - start
    identical = all(np.array_equal(a.paths, b.paths) and np.array_equal(a.goals, b.goals)
                    for a, b in zip(separate, together))

    samples = sum(s.options.K for s in samplings)
    print(f"torch {torch.__version__}, {args.threads} threads, load average "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    print(f"{n} test windows of {len(set(test.scene_id))} scenes, profile {params['profile']}: "
          f"{len(samplings)} samplings, {samples} samples per window")
    print(f"{'scoring':34s} {'s per window':>12s}")
    print(f"{'a pass per setting (before)':34s} {separate_s / n:12.3f}")
    print(f"{'one pass, each batch encoded once':34s} {together_s / n:12.3f}"
          f"   ({separate_s / together_s:.2f}x; encoding {shared_s / n:.3f} s of it)")
    print(f"identical predictions: {identical}")


if __name__ == "__main__":
    main()
