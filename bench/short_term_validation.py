"""A trained short-term Y-net and a fixed sample of its benchmark's validation windows.

Shared by `bench_short_term_scoring.py` and the experiments `docs/experiments/short_term_crop.py`,
`short_term_paths.py`, `short_term_steps.py` and `short_term_ttst.py` (not a benchmark itself:
`make bench` runs `bench_*.py` only). Validation windows only: they never look at the test set.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import torch

from bench.common import repro, require
from pipeline.benchmarks.ethucy import EthUcyFold, load_ethucy_scenes
from pipeline.benchmarks.registry import short_term
from pipeline.runners.ynet_scoring import load_model
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.ynet import YnetSettings
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.runners.short_term import sample_windows
from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import SceneWindows, group_by_scene
from ynet.model import YNet

SDD_MAPS = Path("data/semantic_maps")


@dataclass
class TrainedOnValidation:
    model: YNet
    settings: YnetSettings  # the checkpoint's (resize, crop, distance scale)
    stage: ShortTermModelsParams  # short_term_models.<profile>
    val: WindowArrays  # original pixels
    scenes: list[SceneWindows]  # val grouped by scene, in the checkpoint's resized pixels
    scenes_info: dict | None  # ETH/UCY: scene name -> EthUcySceneInfo (homographies)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options every short-term Y-net bench takes."""
    parser.add_argument("--dataset", default="sdd")
    parser.add_argument("--windows", type=Path, default=Path("data/short_term"))
    parser.add_argument("--sdd", type=Path, default=Path("data/raw/sdd"))
    parser.add_argument("--checkpoint", type=Path,
                        help="default: checkpoints/short_term/<dataset>_ynet/best.pt")
    parser.add_argument("--windows-sample", type=int, default=300)


def load_from_arguments(args: argparse.Namespace, bench: str) -> TrainedOnValidation:
    """`load` as the options say; exits naming the `dvc repro` that makes what is missing."""
    checkpoint = args.checkpoint or Path(f"checkpoints/short_term/{args.dataset}_ynet/best.pt")
    needs = {checkpoint: repro(f"train_short_term_ynet@{args.dataset}"),
             short_term(args.dataset).table(args.windows): repro("short_term_windows")}
    if args.dataset == "sdd":
        needs.update({SDD_MAPS: repro("semantic_maps"), args.sdd: repro("fetch@sdd")})
    require(bench, needs)
    return load(args.dataset, checkpoint, args.windows, args.sdd, args.windows_sample)


def load(dataset: str, checkpoint: Path, windows: Path, sdd: Path, sample: int) -> TrainedOnValidation:
    """The checkpoint's model (threads as trained) and `sample` seeded validation windows."""
    params = read_params()
    stage = load_profile(ShortTermModelsParams, "short_term_models", params)
    lengths = load_section(ShortTermParams, "short_term", params)
    benchmark = short_term(dataset)
    fold = isinstance(benchmark, EthUcyFold)
    scenes_info = load_ethucy_scenes(benchmark.maps(windows)) if fold else None
    bench = benchmark.load(windows, lengths.n_past, lengths.n_future)
    val = sample_windows(bench.val, sample, stage.seed)
    model, settings = load_model(checkpoint)
    torch.set_num_threads(settings.threads)
    maps = load_semantic_maps(benchmark.maps(windows) if fold else SDD_MAPS)
    sizes = benchmark.scene_sizes(windows, sdd, set(val.scene_id))
    return TrainedOnValidation(model, settings, stage, val,
                               group_by_scene(val, maps, sizes, settings.resize), scenes_info)
