"""Everything a long-term benchmark of its own folder trains (inD, paper Tables 3/4: stage
`train_ind`), with the library functions the SDD stages use; `pipeline.runners.long_term_benchmark`
scores it.

1. Semantic maps of every scene's background (`semantic_maps.background_maps`): the SDD-trained
   U-Net fine-tuned on the benchmark's labelled train backgrounds, if any (encoder frozen for the
   first `freeze_encoder_epochs`, the SDD schedule otherwise), else unchanged; kept in
   `<checkpoint-dir>/segmentation/maps.npz` for scoring.
2. Y-net (`ynet.<profile>` at the benchmark's map scale) trained on train, the epoch selected on val.
3. S-GAN and PECNet on the benchmark's horizon, and PECNet on the base horizon (R-PECNet's).

Checkpoints (`--checkpoint-dir`): ynet/, sgan_tf30/, pecnet_tf30/ and pecnet_tf5/ survive an
interruption and resume (`pipeline.checkpoints`), while a changed run (other windows, maps or
settings) starts afresh; segmentation/model.pt is the fine-tuned U-Net (short; re-trained on every
run, seeded).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import torch

from pipeline.config.runtime import RuntimeParams
from pipeline.device import CPU
from pipeline.io import write_npz
from pipeline.model_list import BY_NAME, RPECNET, TRAINED_BASELINES, YNET
from pipeline.preemption import NEVER, Preemption
from pipeline.runners import baseline_runs
from pipeline.runners.long_term_benchmark import MAPS, baseline_dirs, not_provided_record
from pipeline.runners.semantic_maps import background_maps
from pipeline.runners.ynet_training import train

if TYPE_CHECKING:  # annotations only: a stage's code holds the sections it reads (code_graph)
    import numpy as np

    from pipeline.benchmarks.long_term import LongTermBenchmark
    from pipeline.config.segmentation import SegmentationParams
    from pipeline.config.train_baseline import TrainBaselineParams
    from pipeline.config.ynet import YnetSettings
    from pipeline.data.window_table import WindowArrays


@dataclass(frozen=True)
class TrainSettings:
    """What training is configured by, as the stage read it from params.yaml, at the benchmark's
    scales (`ynet.resize`, `segmentation.downsample`; inD: `benchmarks.ind.at_ind_scale`)."""

    profile: str
    ynet: YnetSettings
    segmentation: SegmentationParams  # the U-Net's fine-tuning schedule
    freeze_encoder_epochs: int  # of `segmentation.epochs`: the U-Net's encoder frozen
    baseline_configs: dict[str, Any]  # sgan / pecnet -> their config dataclass
    train_baseline: TrainBaselineParams
    runtime: RuntimeParams = field(default_factory=lambda: RuntimeParams(device="cpu"))


def train_ynet(splits: dict[str, WindowArrays], maps: dict[str, np.ndarray],
               sizes: dict[str, tuple[int, int]], settings: TrainSettings, n_past: int,
               folder: Path, device: torch.device = CPU, preemption: Preemption = NEVER) -> dict:
    """Train Y-net (val selects the epoch) in `folder`; returns the training summary. A `last.pt`
    there resumes only if written for the same windows, maps and settings (its identity,
    `pipeline.checkpoints`), as for every Y-net training."""
    folder.mkdir(parents=True, exist_ok=True)
    return train(splits["train"], splits["val"], maps, sizes, settings.ynet, n_past,
                 folder / "last.pt", folder / "best.pt", folder / "history.csv", device=device,
                 preemption=preemption)


def train_baselines(long: WindowArrays, base: WindowArrays, settings: TrainSettings,
                    checkpoint_dir: Path, device: torch.device = CPU,
                    preemption: Preemption = NEVER) -> dict[str, dict]:
    """Train S-GAN and PECNet on the long windows and PECNet on the base ones (R-PECNet's);
    returns each checkpoint folder's training facts."""
    seed = settings.train_baseline.seed
    torch.set_num_threads(settings.train_baseline.threads)
    dirs = baseline_dirs(checkpoint_dir, long.future.shape[1], base.future.shape[1])
    facts = {}
    for model in TRAINED_BASELINES:
        facts[model] = baseline_runs.train(model, long, settings.baseline_configs[model], dirs[model],
                                           seed, device, preemption)
    base_model = BY_NAME[RPECNET].trained_as
    facts[RPECNET] = baseline_runs.train(base_model, base, settings.baseline_configs[base_model],
                                         dirs[RPECNET], seed, device, preemption)
    return facts


def train_benchmark(benchmark: LongTermBenchmark, folder: Path, segmentation_model: Path,
                    checkpoint_dir: Path, settings: TrainSettings, device: torch.device = CPU,
                    preemption: Preemption = NEVER) -> dict:
    """Train everything on the benchmark's `folder` into `checkpoint_dir`; returns the training
    record (or why there is none)."""
    reason = benchmark.not_provided(folder)  # the folder checked before anything is written
    checkpoint_dir.mkdir(parents=True, exist_ok=True)
    if reason is not None:
        return not_provided_record(reason)
    data = benchmark.load(folder)
    start = time.perf_counter()
    maps, semantic = background_maps(data, segmentation_model, settings.segmentation,
                                     settings.freeze_encoder_epochs, settings.ynet.resize,
                                     settings.profile, checkpoint_dir / "segmentation", device)
    write_npz(checkpoint_dir / MAPS, maps)
    ynet = train_ynet(data.splits, maps, data.sizes, settings, data.n_past,
                      checkpoint_dir / YNET, device, preemption)
    trained = train_baselines(data.long, data.base, settings, checkpoint_dir, device, preemption)
    return {"provided": True, "status": "ok", "profile": settings.profile,
            "t_f": data.horizon, "windows": {s: len(a) for s, a in data.splits.items()},
            "semantic": semantic, YNET: ynet, "baselines": trained,
            "seconds": time.perf_counter() - start}
