"""The trained long-term Y-net, the release's validation windows and the `cpu` scoring params, for
the experiments beside it.

Shared by `long_term_bf16_scoring.py` and `long_term_ttst.py` (not an experiment itself).
Validation windows only: experiments that choose a setting never look at the test set.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from bench.common import repro, require
from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.ttst import TtstParams
from pipeline.config.windows import WindowParams
from pipeline.config.ynet import YnetSettings
from pipeline.data.labels import image_sizes
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.window_table import WindowArrays, to_arrays
from pipeline.data.ynet_data import SceneWindows
from pipeline.runners.ynet_scoring import load_for_scoring
from ynet.model import YNet


@dataclass
class TrainedOnValidation:
    model: YNet
    settings: YnetSettings  # the checkpoint's
    val: WindowArrays  # original pixels
    scenes: list[SceneWindows]  # val grouped by scene, at the model's resize
    eval_params: EvalParams  # eval.cpu: K_e, K_a, seed, bf16
    ttst: TtstParams
    cws: CwsParams


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options every long-term Y-net validation bench takes."""
    parser.add_argument("--windows", type=Path, default=Path("data/windows/release_tf30.parquet"))
    parser.add_argument("--model", type=Path, default=Path("data/ynet/model.pt"))
    parser.add_argument("--semantic-maps", type=Path, default=Path("data/semantic_maps"))
    parser.add_argument("--sdd", type=Path, default=Path("data/raw/sdd"))
    parser.add_argument("--threads", type=int, default=2)


def load(args: argparse.Namespace) -> TrainedOnValidation:
    """The model on `args.threads` threads and its validation windows (`windows.n_past` observed
    steps), with the `cpu` profile's scoring params from params.yaml. Exits naming the `dvc repro`
    that makes whatever of them is missing."""
    require(Path(sys.argv[0]).stem, {args.windows: repro("windows"), args.model: repro("train_ynet"),
                                     args.semantic_maps: repro("semantic_maps"),
                                     args.sdd: repro("fetch@sdd")})
    params = read_params()
    table = pd.read_parquet(args.windows)
    val = to_arrays(table[table["split"] == "val"], load_section(WindowParams, "windows", params).n_past)
    model, settings, scenes = load_for_scoring(args.model, val, load_semantic_maps(args.semantic_maps),
                                               image_sizes(args.sdd, set(val.scene_id)),
                                               args.threads)
    return TrainedOnValidation(model, settings, val, scenes,
                               load_profile(EvalParams, "eval", {**params, "profile": "cpu"}),
                               load_section(TtstParams, "ttst", params),
                               load_section(CwsParams, "cws", params))
