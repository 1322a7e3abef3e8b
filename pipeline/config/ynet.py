"""Section `ynet.<profile>` of params.yaml: Y-net's model and training settings (`YnetSettings`,
which builds a `ynet.config.YNetConfig`), apart from the training loop, so that code reading them
need not import it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pipeline.config.loading import ParamsError, active_profile, profile_entry
from ynet.config import YNetConfig, upstream_max_distance


# (quarter turns counter-clockwise, horizontal flip), the authors' 8 augmentations
# (`pipeline.data.ynet_data.augment` applies one).
AUGMENTATIONS = tuple((turns, flip) for turns in range(4) for flip in (False, True))


LR_SCHEDULES = ("constant", "cosine")


# Settings Y-net had once, at the only values any profile ran them with (`YnetSettings.from_saved`).
RETIRED_SETTINGS = {"distance_norm": "upstream", "mix_scenes": False, "weight_average_decay": 0.0}


@dataclass
class YnetSettings:
    """Section `ynet.<profile>` of params.yaml: Y-net's model and training settings."""

    resize: float = 0.25
    """Scale of maps and coordinates relative to the original image (authors: 0.25 for SDD)."""
    epochs: int = 300
    """Training epochs."""
    batch_size: int = 8
    """Windows per batch (all of one scene)."""
    learning_rate: float = 1e-4
    """Adam learning rate."""
    augmentations: int = 8
    """How many of the 8 rotation/flip variants each scene is seen under per epoch (8 = all)."""
    loss_scale: float = 1000.0
    """Factor on both BCE losses (authors: 1000)."""
    kernel_size: int = 31
    """Side of the Gaussian ground-truth kernel, pixels of the resized map."""
    sigma: float = 4.0
    """Standard deviation of the Gaussian ground truth, pixels of the resized map."""
    waypoints: list[int] = field(default_factory=lambda: [14, 29])
    """Future step indices conditioning the trajectory decoder; the last is the goal."""
    encoder_channels: list[int] = field(default_factory=lambda: [32, 32, 64, 64, 64])
    decoder_channels: list[int] = field(default_factory=lambda: [64, 64, 64, 32, 32])
    distance_gain: float = 1.0
    """Multiplies the distance maps, the authors' divided by their constant (1 = the authors').
    Their slope is tiny (2 / 371 per pixel at resize 0.125), so the decoders need large weights to
    turn a distance map into a sharp peak; a steeper input reaches those in far fewer steps (see
    the README's profile table)."""
    seed: int = 0
    """Seeds weights, shuffling and augmentation draws."""
    threads: int = 2
    """CPU threads for torch."""
    semantic_classes: int = 6
    """Channels of the scene map: SDD 6 (5 classes + padding), ETH/UCY 3 (road, not road, padding)."""
    steps_per_epoch: int = 0
    """Optimiser steps per epoch: the first of the epoch's shuffled batches; 0 = all of them."""
    head_bias: float | None = None
    """Initial bias of the decoders' output logits (see `ynet.config.YNetConfig.head_bias`);
    None = PyTorch's default, as the authors."""
    crop: int = 0
    """0: the model sees whole scenes (the authors). > 0 (a multiple of 32): a crop x crop window
    around each agent in training, validation and scoring (`ynet_data.window_inputs`); short
    horizons whose futures stay near the agent then cost a fraction of the pixels."""
    crop_lead_steps: float = 0.0
    """The crop is centred this many steps of the agent's last observed velocity ahead of it."""
    bf16: bool = False
    """bfloat16 autocast for the training forward passes on the CPU (about 1.7x on CPUs with
    AVX512-BF16 at batch 16; losses stay float32). CUDA always trains under bfloat16 autocast."""
    lr_schedule: str = "constant"
    """'constant', or 'cosine': the learning rate falls from `learning_rate` to 0 along a half
    cosine over the run's steps (a pure function of the step, so a resumed run follows it too)."""
    trajectory_lr_scale: float = 1.0
    """Multiplies the trajectory decoder's learning rate (schedule included); 1 = one rate for the
    whole model, as the authors. A short-term Y-net on crops learns its paths more slowly than its
    goals (README: its paths lose to straight lines towards the same goals)."""
    grad_clip_norm: float = 0.0
    """0: no clipping (the authors). > 0: before each step the gradients are scaled down so that
    their global L2 norm is at most this (`torch.nn.utils.clip_grad_norm_`): a rare huge batch
    gradient then moves the weights no further than a typical one. Losses are `loss_scale` times
    the BCE, so the norm's scale is that of the scaled loss."""

    def __post_init__(self):
        if not 0 < self.resize <= 1:
            raise ValueError(f"resize must be in (0, 1], got {self.resize}")
        if not 1 <= self.augmentations <= len(AUGMENTATIONS):
            raise ValueError(f"augmentations must be 1..{len(AUGMENTATIONS)}")
        if self.distance_gain <= 0:
            raise ValueError("distance_gain must be positive")
        if min(self.epochs, self.batch_size, self.semantic_classes) < 1:
            raise ValueError("epochs, batch_size and semantic_classes must be positive")
        if self.steps_per_epoch < 0:
            raise ValueError("steps_per_epoch must be >= 0 (0 = every batch)")
        if self.trajectory_lr_scale <= 0:
            raise ValueError(f"trajectory_lr_scale must be positive, got {self.trajectory_lr_scale}")
        if self.grad_clip_norm < 0:
            raise ValueError(f"grad_clip_norm must be >= 0 (0 = off), got {self.grad_clip_norm}")
        if self.lr_schedule not in LR_SCHEDULES:
            raise ValueError(f"lr_schedule must be one of {LR_SCHEDULES}, got {self.lr_schedule!r}")
        if self.crop < 0 or self.crop % 32:
            raise ValueError(f"crop must be 0 or a multiple of 32, got {self.crop}")

    def model_config(self, n_past: int, n_future: int) -> YNetConfig:
        return YNetConfig(obs_len=n_past, pred_len=n_future, semantic_classes=self.semantic_classes,
                          encoder_channels=tuple(self.encoder_channels),
                          decoder_channels=tuple(self.decoder_channels),
                          waypoints=tuple(self.waypoints), head_bias=self.head_bias)

    @classmethod
    def from_saved(cls, saved: dict) -> YnetSettings:
        """The settings a Y-net model file records (`ynet_training.train`). Files written while
        `distance_norm`, `mix_scenes` and `weight_average_decay` were settings record them too:
        read at the only values the pipeline ran them with, an error naming them otherwise."""
        other = {key: saved[key] for key in RETIRED_SETTINGS
                 if key in saved and saved[key] != RETIRED_SETTINGS[key]}
        if other:
            raise ValueError(f"a model trained with settings this code no longer has: {other}")
        return cls(**{key: value for key, value in saved.items() if key not in RETIRED_SETTINGS})

    @property
    def max_distance(self) -> float:
        return upstream_max_distance(self.resize) / self.distance_gain


def ynet_main_seed(params: dict[str, Any]) -> int:
    """`ynet.<profile>.seed` alone (the main Y-net's training seed), for a stage that declares only
    that key of the section (`YnetSettings` itself lives with the training code)."""
    entry = profile_entry(params, "ynet")
    seed = entry.get("seed") if isinstance(entry, dict) else None
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParamsError(f"params.yaml:ynet.{active_profile(params)}.seed: expected a "
                          f"non-negative integer seed, got {seed!r}")
    return seed
