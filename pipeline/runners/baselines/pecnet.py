"""PECNet (Mangalam et al. 2020), retrained per horizon for the long-term setting.

An endpoint-conditioned CVAE: a past encoder summarises the observed track; while training, an
endpoint encoder and a latent encoder give q(z | past, endpoint) and the endpoint decoder
reconstructs the endpoint from (past, z); at test time z ~ N(0, sigma^2) with sigma = 1.3 (the
"truncation trick"), one z per sample. The path to the (generated) endpoint is then predicted from
[past features, endpoint features, position], after `nonlocal_rounds` rounds of non-local social
pooling (attention restricted to co-occurring agents that came within `neighbour_radius` pixels of
each other during the observed steps). Loss: MSE(endpoint) + KL + MSE(path), weights 1 (the KL
summed over the batch, as upstream does). Settings: `pipeline.config.pecnet.PecnetConfig`,
upstream's in params.yaml `pecnet.paper`.

Units (upstream's normalisation): each window is shifted so its first observed point is the
origin, then multiplied by `data_scale`; the absolute last observed position, divided by
`position_scale`, is an extra input of the path predictor. Reversed windows (the whole track
played backwards) are added to the training set when `reverse_augment` is on.

Loss balance: the MSEs are means and the KL a sum over the batch, so per window the objective is a
Gaussian likelihood of standard deviation sigma_px = sqrt(batch_size * kl_weight) / data_scale
pixels plus the KL. Upstream (data_scale 1.86, batch 512, kl_weight 1) has sigma_px = 12.2 px. Its
literal units make 30-s endpoints about 1,000 units large, and training from them was unstable
in our runs (KL ~1e10 after 40 epochs). The `cpu` profile keeps sigma_px (12.6 px: data_scale
0.02, batch 64, kl_weight 0.001) with 50-px units, smaller batches (more steps in few epochs) and
a larger learning rate (1e-3).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from pipeline import checkpoints
from pipeline.config.pecnet import PecnetConfig
from pipeline.model_list import PECNET
from pipeline.runners.baselines import common
from pipeline.runners.baselines.common import FitResult, as_input, mlp
from pipeline.runners.baselines.training import run_training
from pipeline.device import generator as seeded_generator
from pipeline.device import CPU, to_device
from pipeline.harness.metrics import window_errors
from pipeline.preemption import NEVER, Preemption
from pipeline.data.window_table import WindowArrays


# ---------------------------------------------------------------------------------------------
# Modules


class NonLocalPooling(nn.Module):
    """feat + softmax-attention over neighbours (mask) of g(feat); weights from theta . phi."""

    def __init__(self, width: int, config: PecnetConfig):
        super().__init__()
        self.theta = mlp([width, *config.nonlocal_hidden, config.nonlocal_dim])
        self.phi = mlp([width, *config.nonlocal_hidden, config.nonlocal_dim])
        self.g = mlp([width, *config.nonlocal_hidden, width])

    def forward(self, feat: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """feat (B, F), mask (B, B) bool with a True diagonal -> (B, F)."""
        scores = self.theta(feat) @ self.phi(feat).T  # (B, B)
        weights = torch.softmax(scores.masked_fill(~mask, float("-inf")), dim=-1)  # (B, B)
        return feat + weights @ self.g(feat)


class PecnetNet(nn.Module):
    def __init__(self, config: PecnetConfig, n_past: int, n_future: int):
        super().__init__()
        f, z = config.feature_dim, config.latent_dim
        self.n_future = n_future
        self.encode_past = mlp([2 * n_past, *config.past_hidden, f])
        self.encode_endpoint = mlp([2, *config.endpoint_hidden, f])
        self.encode_latent = mlp([2 * f, *config.latent_hidden, 2 * z])
        self.decode_endpoint = mlp([f + z, *config.decoder_hidden, 2])
        width = 2 * f + 2  # [past features, endpoint features, position]
        self.pooling = nn.ModuleList(NonLocalPooling(width, config) for _ in range(config.nonlocal_rounds))
        self.predict_path = mlp([width, *config.predictor_hidden, 2 * (n_future - 1)])

    def posterior(self, past_feat: torch.Tensor, endpoint: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Mean and log-variance of q(z | past, endpoint), each (B, latent_dim)."""
        stats = self.encode_latent(torch.cat([past_feat, self.encode_endpoint(endpoint)], dim=-1))
        return stats.chunk(2, dim=-1)

    def path(self, past_feat: torch.Tensor, endpoint: torch.Tensor, position: torch.Tensor,
             mask: torch.Tensor) -> torch.Tensor:
        """Path to `endpoint` (B, 2): the n_f - 1 intermediate points (B, n_f - 1, 2)."""
        feat = torch.cat([past_feat, self.encode_endpoint(endpoint), position], dim=-1)  # (B, 2f+2)
        for pool in self.pooling:
            feat = pool(feat, mask)
        return self.predict_path(feat).reshape(len(feat), self.n_future - 1, 2)

    def forward(self, past: torch.Tensor, position: torch.Tensor, mask: torch.Tensor,
                endpoint: torch.Tensor | None = None, z: torch.Tensor | None = None):
        """past (B, 2 n_p) normalised; position (B, 2); mask (B, B).

        Training: pass the true `endpoint` (B, 2); z is drawn from the posterior (reparametrised,
        with torch's global RNG unless `z` holds the standard-normal noise). Sampling: pass `z`
        (B, latent_dim) and no endpoint. Returns (endpoint (B, 2), path (B, n_f-1, 2), mu, logvar),
        the path conditioned on the generated endpoint; mu and logvar are None when sampling.
        """
        past_feat = self.encode_past(past)  # (B, f)
        mu = logvar = None
        if endpoint is not None:
            mu, logvar = self.posterior(past_feat, endpoint)
            eps = torch.randn_like(mu) if z is None else z
            z = mu + eps * torch.exp(0.5 * logvar)
        elif z is None:
            raise ValueError("pass the true endpoint (training) or z (sampling)")
        generated = self.decode_endpoint(torch.cat([past_feat, z], dim=-1))  # (B, 2)
        return generated, self.path(past_feat, generated, position, mask), mu, logvar


# ---------------------------------------------------------------------------------------------
# Batches


@dataclass
class Batch:
    past: torch.Tensor  # (B, 2 n_p) origin-shifted, scaled, flattened
    position: torch.Tensor  # (B, 2) last observed position / position_scale
    mask: torch.Tensor  # (B, B) neighbours
    origin: np.ndarray  # (B, 2) first observed position in pixels
    endpoint: torch.Tensor | None = None  # (B, 2) normalised
    path: torch.Tensor | None = None  # (B, n_f - 1, 2) normalised


def make_batch(past: np.ndarray, groups: np.ndarray, config: PecnetConfig,
               future: np.ndarray | None = None, device: torch.device = CPU,
               origin: np.ndarray | None = None) -> Batch:
    """past (B, n_p, 2), future (B, n_f, 2) in pixels; tensors on `device`. Each window is shifted
    by its first observed point, or by `origin` (B, 2) where given (the R-PECNet diagnostic's
    re-centring slip: any other point puts the input off the origin the model was trained at)."""
    origin = past[:, 0] if origin is None else origin  # (B, 2)
    mask = common.neighbour_mask(as_input(groups, device), as_input(past, device), config.neighbour_radius)

    def norm(xy: np.ndarray) -> torch.Tensor:
        return as_input((xy - origin[:, None]) * config.data_scale, device, torch.float32)

    batch = Batch(past=norm(past).flatten(1), mask=mask, origin=origin,
                  position=as_input(past[:, -1] / config.position_scale, device, torch.float32))
    if future is not None:
        fut = norm(future)  # (B, n_f, 2)
        batch.endpoint, batch.path = fut[:, -1], fut[:, :-1]
    return batch


def reversed_windows(arrays: WindowArrays, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(past, future, groups) of the windows plus the same tracks played backwards (new groups)."""
    n_p = arrays.past.shape[1]
    track = np.concatenate([arrays.past, arrays.future], axis=1)[:, ::-1]  # (N, T, 2)
    past = np.concatenate([arrays.past, track[:, :n_p]])
    future = np.concatenate([arrays.future, track[:, n_p:]])
    return past, future, np.concatenate([groups, groups + groups.max() + 1])


def kl_divergence(mu: torch.Tensor, logvar: torch.Tensor) -> torch.Tensor:
    """KL(N(mu, exp(logvar)) || N(0, 1)), summed over batch and dimensions."""
    return -0.5 * torch.sum(1 + logvar - mu**2 - logvar.exp())


# ---------------------------------------------------------------------------------------------
# The baseline


class Pecnet:
    """PECNet behind the common baseline interface (fit / load / predict)."""

    name = PECNET
    config_class = PecnetConfig
    trainable = True

    def __init__(self, config: PecnetConfig, n_past: int, n_future: int, device: torch.device = CPU):
        if n_future < 2:
            raise ValueError("PECNet predicts an endpoint and a path: n_future must be >= 2")
        self.config, self.n_past, self.n_future = config, n_past, n_future
        self.device = torch.device(device)
        # Initialised on the CPU (torch's global RNG), then moved: the same weights on any device.
        self.net = PecnetNet(config, n_past, n_future).to(self.device)
        self.fit_result: FitResult | None = None  # set by fit

    @classmethod
    def fit(cls, train: WindowArrays, val: WindowArrays, config: PecnetConfig, checkpoint_dir: Path,
            seed: int, device: torch.device = CPU, preemption: Preemption = NEVER,
            after_epoch: Callable[[Pecnet, int], None] | None = None) -> Pecnet:
        """Train on `train`, keeping the epochs the selection rules choose on `val`
        (`training.run_training`). `after_epoch(model, epoch)`, when given, sees the model with each
        epoch's weights once it is validated (a diagnostic's per-epoch hook; None: training only)."""
        if len(train) == 0 or len(val) == 0:
            raise ValueError("PECNet needs training and validation windows")
        rng = checkpoints.seed_everything(seed, device)
        model = cls(config, train.past.shape[1], train.future.shape[1], device)
        common.check_windows(val, model.n_past, model.n_future, "validation windows")
        optimizer = torch.optim.Adam(model.net.parameters(), lr=config.learning_rate)
        groups = common.co_occurrence_groups(train)
        if config.reverse_augment:
            past, future, groups = reversed_windows(train, groups)
        else:
            past, future = train.past, train.future

        def epoch_batches(epoch: int) -> list[np.ndarray]:
            return common.group_batches(groups, config.batch_size, rng)

        def train_batch(index: np.ndarray) -> np.ndarray:
            batch = make_batch(past[index], groups[index], config, future[index], device)
            return model.train_step(batch, optimizer, rng)

        def validate() -> np.ndarray:
            pred = model.predict(val, config.val_k, seeded_generator(device, seed + 1))
            return window_errors(pred, val.future).ade  # (N,)

        model.fit_result = run_training(
            name=cls.name, modules={"net": model.net}, optimizers={"net": optimizer},
            epoch_batches=epoch_batches, train_batch=train_batch,
            loss_names=("loss_endpoint", "loss_kl", "loss_path"), validate=validate,
            epochs=config.epochs, config=dataclasses.asdict(config),
            meta={"n_past": model.n_past, "n_future": model.n_future, "seed": seed},
            data_fingerprint=checkpoints.run_digest(str(seed), train, val),
            checkpoint_dir=checkpoint_dir, generator=rng, device=device, preemption=preemption,
            after_epoch=None if after_epoch is None else (lambda epoch: after_epoch(model, epoch)))
        return model

    def train_step(self, batch: Batch, optimizer: torch.optim.Optimizer, rng: torch.Generator) -> np.ndarray:
        """One Adam step; returns [endpoint MSE, KL, path MSE]."""
        eps = to_device(torch.randn(len(batch.past), self.config.latent_dim, generator=rng, device=rng.device),
                        batch.past.device)
        endpoint, path, mu, logvar = self.net(batch.past, batch.position, batch.mask, batch.endpoint, eps)
        loss_endpoint = F.mse_loss(endpoint, batch.endpoint)
        loss_kl = kl_divergence(mu, logvar)
        loss_path = F.mse_loss(path, batch.path)
        loss = loss_endpoint + self.config.kl_weight * loss_kl + self.config.path_weight * loss_path
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        return np.array([loss_endpoint.item(), loss_kl.item(), loss_path.item()])

    @classmethod
    def load(cls, checkpoint_dir: Path, device: torch.device = CPU, selection: str = "raw") -> Pecnet:
        """The weights selection rule `selection` kept (`common.best_path`), on `device`."""
        state = common.load_checkpoint(common.best_path(checkpoint_dir, selection), map_location=device)
        model = cls(PecnetConfig(**state["config"]), state["meta"]["n_past"], state["meta"]["n_future"],
                    device)
        model.net.load_state_dict(state["modules"]["net"])
        model.net.eval()
        return model

    def draw_latent(self, n: int, k: int, generator: torch.Generator) -> torch.Tensor:
        """(n, k, latent_dim) standard-normal draws on `generator`'s device, for `sample(latent=)`
        (a caller that keeps one z per sample path across several calls)."""
        return torch.randn(n, k, self.config.latent_dim, generator=generator, device=generator.device)

    @torch.no_grad()
    def sample(self, past: np.ndarray, groups: np.ndarray, k: int, generator: torch.Generator,
               batch_size: int = 1024, latent: torch.Tensor | None = None,
               origin: np.ndarray | None = None) -> np.ndarray:
        """K sampled futures (N, k, n_f, 2) in pixels of observed tracks past (N, n_p, 2);
        windows with equal `groups` co-occur (pool with each other). z is drawn on `generator`'s
        device, or taken from `latent` (N, k, latent_dim) standard-normal draws (`draw_latent`;
        scaled by sigma as drawn ones are; `generator` then unused). `origin` (N, 2): the point
        each window is shifted by before the model and back after it, instead of its first
        observed point (`make_batch`)."""
        if past.ndim != 3 or past.shape[1:] != (self.n_past, 2):
            raise ValueError(f"PECNet takes (N, {self.n_past}, 2) observed tracks, got {past.shape}")
        if latent is not None and tuple(latent.shape) != (len(past), k, self.config.latent_dim):
            raise ValueError(f"latent must be (N, k, latent_dim) = "
                             f"{(len(past), k, self.config.latent_dim)}, got {tuple(latent.shape)}")
        if origin is not None and origin.shape != (len(past), 2):
            raise ValueError(f"origin must be (N, 2) = {(len(past), 2)}, got {origin.shape}")
        self.net.eval()
        out = np.zeros((len(past), k, self.n_future, 2))
        for index in common.group_batches(groups, batch_size):
            batch = make_batch(past[index], groups[index], self.config, device=self.device,
                               origin=None if origin is None else origin[index])
            rows = None if latent is None else latent[torch.as_tensor(index, device=latent.device)]
            samples = []
            for s in range(k):
                noise = (torch.randn(len(index), self.config.latent_dim, generator=generator,
                                     device=generator.device) if rows is None else rows[:, s])
                z = self.config.sigma * to_device(noise, self.device)
                endpoint, path, _, _ = self.net(batch.past, batch.position, batch.mask, z=z)
                samples.append(torch.cat([path, endpoint[:, None]], dim=1))  # (B, n_f, 2)
            future = torch.stack(samples, dim=1).double().cpu().numpy()  # (B, k, n_f, 2): one copy back
            out[index] = future / self.config.data_scale + batch.origin[:, None, None]
        return out

    def predict(self, arrays: WindowArrays, k: int, generator: torch.Generator) -> np.ndarray:
        """(N, k, n_f, 2) sampled futures in pixels."""
        return self.sample(arrays.past, common.co_occurrence_groups(arrays), k, generator)
