"""The paper's baselines, behind the contract every long-term model is written to.

Each baseline class has
- `name` (its registry key), `trainable`, `config_class` (the dataclass of its settings, or None);
- `fit(train, val, config, checkpoint_dir, seed, device=cpu, preemption=NEVER) -> model`
  (trainable ones): trains on `device`, keeps the epoch that is best on `val`, checkpoints every
  epoch (and mid-epoch when `preemption` stops it) and resumes from `checkpoint_dir`;
- `load(checkpoint_dir, device=cpu, selection="raw") -> model`: the weights a finished `fit` kept
  under epoch selection rule `selection` (`pipeline.harness.epoch_selection`), on `device`;
- `model.predict(arrays, k, generator) -> (N, k, n_f, 2)` sampled futures in original pixels
  (random draws on `generator`'s device: `pipeline.device.generator(device, seed)`).

`Baseline` puts each of them behind `pipeline.models`' contract (`fit(train, val, workdir, seed)`,
`predict(test, k, workdir, seed)`, `WindowSet`s in, pixels out), the one every registered model
(constant velocity, yours) is written to, so one loop (`pipeline.harness.model_runs.score_rounds`)
scores the paper's baselines and the registered models alike.

| name    | what                                                        | trained per horizon |
|---------|-------------------------------------------------------------|---------------------|
| sgan    | Social GAN                                                  | yes                 |
| pecnet  | PECNet                                                      | yes                 |
| rpecnet | the t_f = 5 s PECNet rolled out on its own predictions      | no (uses pecnet@5)  |

Constant velocity is a registered model (`pipeline.models.constant_velocity`), not one of these.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from pipeline.device import CPU
from pipeline.device import generator as seeded_generator
from pipeline.runners.baselines.common import FitResult
from pipeline.runners.baselines.pecnet import Pecnet
from pipeline.runners.baselines.rpecnet import RecurrentPecnet
from pipeline.runners.baselines.sgan import SocialGan
from pipeline.models import WindowSet, window_arrays
from pipeline.preemption import NEVER, Preemption

BASELINES = {cls.name: cls for cls in (SocialGan, Pecnet, RecurrentPecnet)}
TRAINABLE = tuple(name for name, cls in BASELINES.items() if cls.trainable)


def get(name: str):
    """The baseline class registered as `name`."""
    try:
        return BASELINES[name]
    except KeyError:
        raise ValueError(f"unknown baseline {name!r}; known: {sorted(BASELINES)}") from None


def config_class(name: str) -> type:
    """The class of trained baseline `name`'s settings (section `sgan` / `pecnet`, one entry per
    profile), which a stage loads for the active profile."""
    if name not in TRAINABLE:
        raise ValueError(f"{name!r} is not trained; trainable: {TRAINABLE}")
    return get(name).config_class


class Baseline:
    """Baseline `name` written to the contract of `pipeline.models`: `workdir` is its checkpoint
    folder (R-PECNet's: the t_f = 5 s PECNet's), `seed` the training seed in `fit` and the round's
    seed in `predict` (its draws on a generator of `device` seeded with it, as every baseline
    round is). `config` (its settings dataclass) is needed to fit only; `selection` is the epoch
    selection rule whose weights `predict` loads, once per workdir."""

    def __init__(self, name: str, config=None, device: torch.device = CPU, selection: str = "raw",
                 preemption: Preemption = NEVER) -> None:
        self.name, self.config, self.device = name, config, device
        self.selection, self.preemption = selection, preemption
        self.fit_result: FitResult | None = None  # of the last `fit`
        self._loaded: tuple[Path, object] | None = None  # (workdir, the model loaded from it)

    def fit(self, train: WindowSet, val: WindowSet, workdir: Path, seed: int) -> None:
        """Train on `train`, keep the epoch best on `val`, checkpoint to (and resume from)
        `workdir`; raises `StopRequested` after a mid-epoch checkpoint when preempted."""
        fitted = get(self.name).fit(window_arrays(train, "train"), window_arrays(val, "val"),
                                    self.config, Path(workdir), seed, device=self.device,
                                    preemption=self.preemption)
        self.fit_result = fitted.fit_result

    def loaded(self, workdir: Path):
        """The model `fit` kept in `workdir` under `selection`, on `device`."""
        if self._loaded is None or self._loaded[0] != Path(workdir):
            self._loaded = Path(workdir), get(self.name).load(Path(workdir), self.device,
                                                              self.selection)
        return self._loaded[1]

    def predict(self, test: WindowSet, k: int, workdir: Path, seed: int) -> np.ndarray:
        """(N, k, n_f, 2) sampled futures in original pixels."""
        return self.loaded(workdir).predict(window_arrays(test, "test"), k,
                                            seeded_generator(self.device, seed))
