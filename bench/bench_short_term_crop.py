"""What seeing a window around each agent costs and saves short-term Y-net, against whole scenes.

Not a test: prints numbers. Takes a trained `short_term_ynet@<dataset>` checkpoint (trained on
crops in the cpu profile) and a fixed seeded sample of that benchmark's *validation* windows (never
the test set), scores them at K_e on each crop side (0 = the whole scene; a convolutional model
runs on any size) and prints best-of-K ADE / FDE (original pixels), seconds per window and the
share of windows whose future leaves the crop.

    python bench/bench_short_term_crop.py --dataset sdd --crops 64 96 0 --windows-sample 300
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from pipeline.evaluate_ynet import (CwsParams, EvalParams, TtstParams, load_model,
                                    predict_scenes, sampling_options)
from pipeline.metrics import window_errors
from pipeline.params import load_profile, load_section, read_params
from pipeline.semantic_maps import load_semantic_maps
from pipeline.short_term import ShortTermParams, load_ethucy_scenes
from pipeline.short_term_models import (ETHUCY_SCENES, ShortTermModelsParams,
                                        load_benchmark, sample_windows, table_path)
from pipeline.train_ynet import image_sizes
from pipeline.ynet_data import group_by_scene


def outside_share(past: np.ndarray, future: np.ndarray, resize: float, crop: int,
                  lead_steps: float) -> float:
    """Share of windows with a future position outside the crop (as `window_inputs` centres it)."""
    last = past[:, -1]
    centre = np.round((last + lead_steps * (last - past[:, -2])) * resize)  # (N, 2) map pixels
    reach = np.abs(future * resize - centre[:, None]).max(axis=(1, 2))
    return float((reach > crop // 2 - 1).mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="sdd")
    parser.add_argument("--windows", type=Path, default=Path("data/short_term"))
    parser.add_argument("--sdd", type=Path, default=Path("data/raw/sdd"))
    parser.add_argument("--checkpoint", type=Path,
                        help="default: checkpoints/short_term/<dataset>_ynet/best.pt")
    parser.add_argument("--crops", type=int, nargs="+", default=[64, 96, 0])
    parser.add_argument("--windows-sample", type=int, default=300)
    parser.add_argument("--k", type=int, default=20)
    args = parser.parse_args()
    checkpoint = args.checkpoint or Path(f"checkpoints/short_term/{args.dataset}_ynet/best.pt")
    if not checkpoint.exists():
        print(f"bench_short_term_crop: no checkpoint at {checkpoint}; run "
              f"`dvc repro short_term_ynet@{args.dataset}` first")
        return
    params = read_params()
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    scenes_info = None if args.dataset == "sdd" else load_ethucy_scenes(args.windows / ETHUCY_SCENES)
    bench = load_benchmark(pd.read_parquet(table_path(args.windows, args.dataset)), args.dataset,
                           windows.n_past, windows.n_future, scenes_info)
    val = sample_windows(bench.val, args.windows_sample, settings.seed)
    model, loaded = load_model(checkpoint)
    torch.set_num_threads(loaded.threads)
    if scenes_info is None:
        maps = load_semantic_maps(Path("data/semantic_maps"))
        sizes = image_sizes(args.sdd, set(val.scene_id))
    else:
        maps = load_semantic_maps(args.windows / ETHUCY_SCENES)
        sizes = {name: info.image_hw for name, info in scenes_info.items()}
    scenes = group_by_scene(val, maps, sizes, loaded.resize)
    ttst = TtstParams(temperature=settings.temperature, rel_threshold=settings.rel_threshold)
    options = sampling_options(args.k, 1, ttst, CwsParams(), use_ttst=True, use_cws=False)
    eval_params = EvalParams(k_e=args.k, rounds=1, seed=settings.seed,
                             batch_size=settings.eval_batch_size, chunk_size=settings.eval_chunk_size)
    print(f"{args.dataset}: {len(val)} val windows, K_e = {args.k}, resize {loaded.resize:.4f}, "
          f"trained on crop {loaded.crop}, lead {loaded.crop_lead_steps} steps, load average "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    for crop in args.crops:
        start = time.perf_counter()
        paths, goals = predict_scenes(model, scenes, loaded, options, settings.seed, eval_params,
                                      len(val), f"crop {crop}", crop, loaded.crop_lead_steps)
        seconds = (time.perf_counter() - start) / len(val)
        errors = window_errors(paths, val.future, goals)
        leaves = ("whole scene" if crop == 0 else f"futures leaving it "
                  f"{outside_share(val.past, val.future, loaded.resize, crop, loaded.crop_lead_steps):.1%}")
        print(f"  crop {crop:3d}: ADE {errors.ade.mean():7.2f} px  FDE {errors.fde.mean():7.2f} px  "
              f"{seconds:.3f} s per window  ({leaves})")


if __name__ == "__main__":
    main()
