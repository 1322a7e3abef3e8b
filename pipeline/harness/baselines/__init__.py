"""The baselines of the long-term benchmark, behind one small interface.

Every baseline class has
- `name` (its registry key), `trainable`, `config_class` (the dataclass of its settings, or None);
- `fit(train, val, config, checkpoint_dir, seed, device=cpu, preemption=NEVER) -> model`
  (trainable ones): trains on `device`, keeps the epoch that is best on `val`, checkpoints every
  epoch (and mid-epoch when `preemption` stops it) and resumes from `checkpoint_dir`;
- `load(checkpoint_dir, device=cpu, selection="raw") -> model`: the weights a finished `fit` kept
  under epoch selection rule `selection` (`pipeline.harness.epoch_selection`), on `device`;
- `model.predict(arrays, k, generator) -> (N, k, n_f, 2)` sampled futures in original pixels
  (random draws on `generator`'s device: `pipeline.device.generator(device, seed)`).

| name              | what                                                        | trained per horizon |
|-------------------|-------------------------------------------------------------|---------------------|
| constant_velocity | last observed velocity extrapolated                         | no (nothing to fit) |
| sgan              | Social GAN                                                  | yes                 |
| pecnet            | PECNet                                                      | yes                 |
| rpecnet           | the t_f = 5 s PECNet rolled out on its own predictions      | no (uses pecnet@5)  |
"""

from __future__ import annotations

from pipeline.harness.baselines.constant_velocity import ConstantVelocity
from pipeline.harness.baselines.pecnet import Pecnet
from pipeline.harness.baselines.rpecnet import RecurrentPecnet
from pipeline.harness.baselines.sgan import SocialGan

BASELINES = {cls.name: cls for cls in (ConstantVelocity, SocialGan, Pecnet, RecurrentPecnet)}
TRAINABLE = tuple(name for name, cls in BASELINES.items() if cls.trainable)


def get(name: str):
    """The baseline class registered as `name`."""
    try:
        return BASELINES[name]
    except KeyError:
        raise ValueError(f"unknown baseline {name!r}; known: {sorted(BASELINES)}") from None
