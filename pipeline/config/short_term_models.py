"""Section `short_term_models.<profile>` of params.yaml: the short-term models' epochs, Y-net's
scales and training departures per benchmark, and their scoring (paper Tables 1 and 2)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from pipeline.config.eval import EvalParams
from pipeline import dataset_list
from pipeline.dataset_list import SHORT_TERM_SETTINGS_KEYS as SETTINGS_KEYS
from pipeline.model_list import SHORT_TERM_MODELS_OURS_FIRST as MODELS


@dataclass
class YnetScale:
    """Y-net's map scale on one benchmark and the Gaussian ground truth that goes with it."""

    resize: float
    """Maps and coordinates relative to the original image (authors: SDD 0.25, ETH/UCY 1 / 1.5)."""
    kernel_size: int
    """Side of the Gaussian ground-truth kernel, pixels of the resized map (authors: 31)."""
    sigma: float
    """Its standard deviation, pixels of the resized map (authors: 4)."""
    crop: int = 0
    """Side of the window around each agent the model sees (`YnetSettings.crop`); 0 = whole scene."""
    crop_lead_steps: float = 0.0
    """The window is centred this many steps of the last observed velocity ahead of the agent."""

    def __post_init__(self):
        if not 0 < self.resize <= 1 or self.sigma <= 0 or self.kernel_size % 2 != 1:
            raise ValueError("need 0 < resize <= 1, sigma > 0 and an odd kernel_size")


@dataclass(frozen=True)
class YnetTraining:
    """How the short-term Y-net trains where it departs from `ynet.<profile>`
    (`YnetSettings` documents each; null = `ynet.<profile>`'s)."""

    learning_rate: float | None = None
    batch_size: int | None = None
    bf16: bool = False
    """bfloat16 autocast for the training forward passes on the CPU."""
    lr_schedule: str = "constant"
    """constant | cosine (to 0 over the run)."""
    trajectory_lr_scale: float | None = None
    """Factor on the trajectory decoder's learning rate; null (or absent) = one rate, as the authors."""
    grad_clip_norm: float | None = None
    """Clip each step's gradients to this global L2 norm; null (or absent) = no clipping, as the
    authors."""

    def __post_init__(self):
        if self.learning_rate is not None and self.learning_rate <= 0:
            raise ValueError(f"learning_rate must be positive or null, got {self.learning_rate}")
        if self.trajectory_lr_scale is not None and self.trajectory_lr_scale <= 0:
            raise ValueError(f"trajectory_lr_scale must be positive or null, got "
                             f"{self.trajectory_lr_scale}")
        if self.batch_size is not None and self.batch_size < 1:
            raise ValueError(f"batch_size must be positive or null, got {self.batch_size}")
        if self.grad_clip_norm is not None and self.grad_clip_norm < 0:
            raise ValueError(f"grad_clip_norm must be >= 0 or null, got {self.grad_clip_norm}")

    def overrides(self) -> dict:
        """The `YnetSettings` fields this section sets."""
        return {key: value for key, value in dataclasses.asdict(self).items() if value is not None}


@dataclass(frozen=True)
class YnetTrainingByBenchmark:
    """`YnetTraining` for each short-term benchmark: a departure chosen on one benchmark's
    validation windows need not help the other (SDD in pixels, ETH/UCY's folds in metres)."""

    sdd: YnetTraining
    ethucy: YnetTraining

    def of(self, benchmark: str) -> YnetTraining:
        if benchmark not in SETTINGS_KEYS:
            raise ValueError(f"unknown benchmark {benchmark!r}; known: {list(SETTINGS_KEYS)}")
        return getattr(self, benchmark)


@dataclass
class ShortTermModelsParams:
    """Section `short_term_models.<profile>` of params.yaml."""

    epochs: dict[str, dict[str, int]]
    """Model (ynet, sgan, pecnet) -> benchmark (sdd, ethucy: each fold) -> training epochs."""
    ynet_steps_per_epoch: int
    """Y-net optimiser steps per epoch, about (windows drawn afresh each epoch); 0 = every window."""
    ynet_training: YnetTrainingByBenchmark
    """How Y-net trains on each benchmark, where it departs from `ynet.<profile>` (the long-term
    model's)."""
    val_windows: int
    """Validation windows that select the epoch (a fixed seeded sample); 0 = all of them."""
    ynet_sdd: YnetScale
    ynet_ethucy: YnetScale
    ynet_datasets: list[str]
    """Datasets this profile trains and scores Y-net on; any other gets a not-run record."""
    why_subset: str
    """Shown in the report for a dataset outside `ynet_datasets`."""
    temperature: float
    """TTST temperature of the short-term setting (authors: 1.0)."""
    rel_threshold: dict[str, float]
    """Benchmark (sdd, ethucy) -> TTST: goal pixels below rel_threshold * max are never sampled
    (authors: 0.01 on both)."""
    k_sdd: list[int]
    """K values scored on SDD (Table 1: 20 and 5)."""
    k_ethucy: list[int]
    """K values scored on ETH/UCY (Table 2: 20)."""
    rounds: int
    """Seeded evaluation rounds; mean and spread are reported."""
    seed: int
    """Round r samples with seed + r; also draws the validation sample."""
    eval_batch_size: int
    """Y-net: test windows per forward pass (one scene per batch)."""
    eval_chunk_size: int
    """Y-net: samples per window decoded together by the trajectory decoder."""
    eval_threads: int
    """Y-net: torch CPU threads for scoring (training's: `ynet.<profile>.threads`)."""
    bf16: bool
    """Y-net: bfloat16 autocast for the trajectory decoder (`ynet.sampling.predict`)."""

    def __post_init__(self):
        if set(self.epochs) != set(MODELS) or any(
                set(e) != set(SETTINGS_KEYS) or min(e.values()) < 1 for e in self.epochs.values()):
            raise ValueError(f"epochs must give every model {list(MODELS)} positive epochs for "
                             f"each of {list(SETTINGS_KEYS)}, got {self.epochs}")
        if self.ynet_steps_per_epoch < 0 or self.val_windows < 0:
            raise ValueError("ynet_steps_per_epoch and val_windows must be >= 0 (0 = all)")
        known = dataset_list.SHORT_TERM_DATASETS  # read now: a test adds a toy benchmark
        unknown = sorted(set(self.ynet_datasets) - set(known))
        if unknown:
            raise ValueError(f"ynet_datasets: unknown dataset(s) {unknown}; known: {list(known)}")
        if not self.k_sdd or not self.k_ethucy or min(self.k_sdd + self.k_ethucy) < 1:
            raise ValueError("k_sdd and k_ethucy must be non-empty lists of positive K")
        if (self.rounds < 1 or self.temperature <= 0 or set(self.rel_threshold) != set(SETTINGS_KEYS)
                or not all(0 <= value < 1 for value in self.rel_threshold.values())):
            raise ValueError(f"need rounds >= 1, temperature > 0 and 0 <= rel_threshold < 1 for each "
                             f"of {list(SETTINGS_KEYS)}, got rel_threshold {self.rel_threshold}")
        if min(self.eval_batch_size, self.eval_chunk_size, self.eval_threads) < 1:
            raise ValueError("eval_batch_size, eval_chunk_size and eval_threads must be positive")

    def eval_params(self) -> EvalParams:
        """What `evaluate_ynet.predict_scenes` reads (seeds are passed per round)."""
        return EvalParams(k_e=max(self.k_sdd + self.k_ethucy), k_a=1, rounds=self.rounds,
                          seed=self.seed, batch_size=self.eval_batch_size,
                          chunk_size=self.eval_chunk_size, bf16=self.bf16)
