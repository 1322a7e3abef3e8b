"""The main Y-net, trained on the release's t_f = 30 windows, and the same model with other training
seeds: what stages `train_ynet`, `train_ynet_seed` and `evaluate_ynet_seed` share (nothing of
scoring, so that a change there never re-runs a training stage).

`train_main` is `train_ynet`'s training (train / val splits of the window table, the waypoints
scaled when the table predicts another horizon, `ynet_training.train`: resumable, preemptible).
Its `settings.seed` seeds everything random in training: the initial weights (`torch.manual_seed`),
the batch order and the augmentation variants drawn per scene and epoch (the epoch plan's numpy
generator); validation is deterministic. So `train_ynet_seed@<s>` is `train_main` with
`seed = s` and `ynet.<profile>`'s other settings, and with the main seed it trains the main model.

The seed stages' records: a slot the active profile does not train gets `seed_not_run_record`
(from both stages); a trained seed's record is `train_ynet`'s summary with the seed and its
validation curve (`seed_training_record`), of which `evaluate_ynet_seed` repeats `TRAINING_KEYS`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd
import torch

from pipeline.data.labels import image_sizes
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.window_table import to_arrays
from pipeline.device import CPU
from pipeline.preemption import NEVER, Preemption
from pipeline.runners.ynet_training import scale_waypoints, train

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.ynet import YnetSettings
    from pipeline.config.ynet_seeds import YnetSeedsParams

REFERENCE_FUTURE = 30
"""Steps the configured waypoints are for (the release's t_f = 30 s at 1 FPS)."""


def train_main(windows: Path, semantic_maps: Path, sdd: Path, n_past: int, settings: YnetSettings,
               checkpoint_dir: Path, best: Path, history: Path, device: torch.device = CPU,
               preemption: Preemption = NEVER) -> dict:
    """Train Y-net on the train split of the window table `windows`, the epoch selected on its val
    split; `checkpoint_dir/last.pt` is the resumable checkpoint, `best` the best weights, `history`
    the per-epoch CSV. Returns `ynet_training.train`'s summary."""
    table = pd.read_parquet(windows)
    train_arrays = to_arrays(table[table["split"] == "train"], n_past)
    val_arrays = to_arrays(table[table["split"] == "val"], n_past)
    n_future = train_arrays.future.shape[1]
    if n_future != REFERENCE_FUTURE:
        settings = replace(settings, waypoints=scale_waypoints(settings.waypoints, n_future))
    maps = load_semantic_maps(semantic_maps)
    sizes = image_sizes(sdd, set(train_arrays.scene_id) | set(val_arrays.scene_id))
    return train(train_arrays, val_arrays, maps, sizes, settings, n_past, checkpoint_dir / "last.pt",
                 best, history, device=device, preemption=preemption)


def seed_not_run_record(seed: int, profile: str, params: YnetSeedsParams) -> dict:
    """The record of a seed slot the active profile does not train (both seed stages write it)."""
    return {"seed": seed, "profile": profile, "trained": False,
            "not_run_reason": params.not_run_reason(profile, seed)}


def validation_curve(history: Path) -> list[float]:
    """Validation ADE per epoch (epoch 1 first) from a training history CSV."""
    return [float(v) for v in pd.read_csv(history)["val_ade"]]


def seed_training_record(seed: int, profile: str, summary: dict, history: Path) -> dict:
    """`train_ynet_seed`'s record: the seed, `train_ynet`'s summary and the validation curve (the
    kept epoch is its minimum), so that a change of epoch selection can be judged on every seed."""
    return {"seed": seed, "profile": profile, "trained": True, **summary,
            "val_ade_per_epoch": validation_curve(history)}


TRAINING_KEYS = (("epochs", int), ("best_epoch", int), ("best_val_ade", float),
                 ("best_val_fde", float), ("train_seconds", float), ("train_windows", int),
                 ("val_windows", int))
"""Keys (and types) of the training record that the seed's scoring record repeats, as
`metrics/ynet_train.json` has them."""
