"""R-PECNet: a PECNet trained for a short horizon (t_f = 5 s) rolled out on its own predictions.

Round 1 feeds the observed n_p positions; every further round feeds the last n_p positions of the
track so far (observed + predicted), and appends the model's n_f' predicted positions, until the
horizon is covered; the surplus of the last round is cut off, so any horizon works (also one that
is not a multiple of n_f').

Samples: the K samples are K independent chains. Chain k draws a fresh z for every round and
always continues from its own previous round, so each of the K returned tracks is one coherent
sample path (never a mix of different samples' pieces), and the cost is K x rounds model calls.
(The alternative, branching K ways at every round, grows as K^rounds and would need a rule to
prune back to K.) Social pooling inside a round mixes chain k of co-occurring agents only with
chain k of their neighbours: their positions in the same imagined future.

Nothing is trained here: `load` takes the checkpoint directory of the t_f = 5 PECNet. The rollout
itself is numpy between rounds (the tracks are short); each round runs on the PECNet's device.

Variants (`VARIANTS`; a diagnostic of how the paper's R-PECNet, whose FDE / ADE of 2.9 says its
error compounds, may have been rolled out; never the headline, which is `INDEPENDENT`):
- `independent`: the behaviour above.
- `shared_latent`: each chain draws its z once and keeps it for every round.
- `mean_fed_back`: one context per window; every round draws K samples from it and continues the
  context with their mean; sample k is the shared context so far + the last round's sample k.
- `original_frame`: a re-centring slip; every round's input is shifted by the observed window's
  first point (and the output shifted back by it) instead of by the input's own first point, so
  the model sees inputs further and further from the origin it was trained at.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import torch

from pipeline.model_list import RPECNET
from pipeline.runners.baselines import common
from pipeline.runners.baselines.pecnet import Pecnet
from pipeline.device import CPU
from pipeline.data.window_table import WindowArrays


INDEPENDENT, SHARED_LATENT, MEAN_FED_BACK, ORIGINAL_FRAME = (
    "independent", "shared_latent", "mean_fed_back", "original_frame")
VARIANTS = (INDEPENDENT, SHARED_LATENT, MEAN_FED_BACK, ORIGINAL_FRAME)  # INDEPENDENT: the headline


def rollout(model: Pecnet, past: np.ndarray, groups: np.ndarray, k: int, n_future: int,
            generator: torch.Generator, variant: str = INDEPENDENT) -> np.ndarray:
    """K chains of `model` rolled out to n_future steps: past (N, n_p, 2) -> (N, k, n_future, 2).
    `variant` (`VARIANTS`): how the rounds are chained (module docstring)."""
    n, n_p = len(past), model.n_past
    if past.shape[1] < n_p:
        raise ValueError(f"the model needs {n_p} observed steps, got {past.shape[1]}")
    if variant not in VARIANTS:
        raise ValueError(f"unknown R-PECNet roll-out variant {variant!r}; known: {VARIANTS}")
    rounds = math.ceil(n_future / model.n_future)
    if variant == MEAN_FED_BACK:
        return mean_fed_back(model, past, groups, k, n_future, rounds, generator)
    # Chains as rows: row i * k + s is chain s of window i; it pools with chain s of its group.
    track = np.repeat(past, k, axis=0)  # (N k, n_p, 2)
    chain_groups = np.repeat(groups, k) * k + np.tile(np.arange(k), n)  # (N k,)
    # shared_latent: one z per chain for every round; original_frame: every round in the
    # observed window's frame.
    latent = model.draw_latent(n * k, 1, generator) if variant == SHARED_LATENT else None
    origin = track[:, 0].copy() if variant == ORIGINAL_FRAME else None  # (N k, 2)
    for _ in range(rounds):
        step = model.sample(track[:, -n_p:], chain_groups, 1, generator, latent=latent,
                            origin=origin)[:, 0]  # (N k, n_f', 2)
        track = np.concatenate([track, step], axis=1)
    future = track[:, past.shape[1]: past.shape[1] + n_future]  # (N k, n_future, 2)
    return future.reshape(n, k, n_future, 2)


def mean_fed_back(model: Pecnet, past: np.ndarray, groups: np.ndarray, k: int, n_future: int,
                  rounds: int, generator: torch.Generator) -> np.ndarray:
    """The `mean_fed_back` roll-out: past (N, n_p, 2) -> (N, k, n_future, 2). One context per
    window: each round samples K continuations of it (pooling with the co-occurring windows'
    contexts) and extends it by their mean; sample k is the context before the last round + the
    last round's sample k, so the K samples differ only in the last n_f' steps."""
    n_p, n_obs = model.n_past, past.shape[1]
    context = past.copy()  # (N, n_obs + steps so far, 2)
    step = None
    for _ in range(rounds):
        step = model.sample(context[:, -n_p:], groups, k, generator)  # (N, k, n_f', 2)
        context = np.concatenate([context, step.mean(axis=1)], axis=1)
    shared = np.repeat(context[:, None, n_obs:-model.n_future], k, axis=1)  # (N, k, done, 2)
    return np.concatenate([shared, step], axis=2)[:, :, :n_future]


class RecurrentPecnet:
    """R-PECNet behind the common baseline interface (load / predict; nothing to fit)."""

    name = RPECNET
    config_class = None
    trainable = False
    base_horizon = 5  # seconds (= steps at 1 FPS) the underlying PECNet is trained for

    def __init__(self, model: Pecnet):
        self.model = model

    @classmethod
    def load(cls, checkpoint_dir: Path, device: torch.device = CPU, selection: str = "raw") -> RecurrentPecnet:
        """The PECNet of `checkpoint_dir` (trained for t_f = 5 s in the benchmark) as selection rule
        `selection` kept it, on `device`."""
        return cls(Pecnet.load(checkpoint_dir, device, selection))

    def predict(self, arrays: WindowArrays, k: int, generator: torch.Generator,
                n_future: int | None = None, variant: str = INDEPENDENT) -> np.ndarray:
        """(N, k, n_f, 2) in pixels; n_f is the windows' future length unless `n_future` is given;
        `variant` of the roll-out (`VARIANTS`; only the diagnostic asks for another)."""
        n_future = arrays.future.shape[1] if n_future is None else n_future
        common.check_windows(arrays, self.model.n_past, None, "R-PECNet input")
        return rollout(self.model, arrays.past, common.co_occurrence_groups(arrays), k, n_future,
                       generator, variant)
