"""Social GAN (Gupta et al. 2018), retrained per horizon for the long-term setting.

Generator: an LSTM encodes each agent's observed displacements; a pooling module mixes the hidden
states of co-occurring agents (an MLP on [embedded relative position, neighbour hidden state],
max-pooled over neighbours); an MLP maps [hidden, pooled] to the decoder's initial state, of which
the last `noise_dim` entries are Gaussian noise shared by all agents of a scene at one time
("global" noise); an LSTM decoder then emits one displacement per future step. Discriminator: an
LSTM over the whole displacement sequence (observed + future) and an MLP to one logit.
Training: per batch, `d_steps` discriminator updates, then one generator update with the
adversarial loss plus the variety loss (the L2 over the displacement sequence of the best of
`best_of_k` samples, per window; S-GAN takes the best per scene sequence), both on one batch, and
soft labels for the discriminator as S-GAN does. Settings (`pipeline.config.sgan.SganConfig`): the
authors' released models (params.yaml `sgan`); the pre-pool MLP's hidden width (512) is S-GAN's
fixed one.

Units: the networks see displacements and relative positions divided by `coord_scale` pixels; no
absolute position enters, and predictions are returned in original pixels.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from pipeline import checkpoints
from pipeline.config.sgan import SganConfig
from pipeline.model_list import SGAN
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


class TrackEncoder(nn.Module):
    """Embedded displacements through an LSTM; the final hidden state summarises the track."""

    def __init__(self, embedding_dim: int, hidden: int):
        super().__init__()
        self.embed = nn.Linear(2, embedding_dim)
        self.lstm = nn.LSTM(embedding_dim, hidden, batch_first=True)

    def forward(self, rel: torch.Tensor) -> torch.Tensor:
        _, (h, _) = self.lstm(self.embed(rel))  # rel (B, T, 2) -> h (1, B, H)
        return h[0]  # (B, H)


class PoolHidden(nn.Module):
    """S-GAN's pooling: for agent i, max over co-occurring j of MLP([embed(p_j - p_i), h_j])."""

    def __init__(self, config: SganConfig):
        super().__init__()
        self.embed = nn.Linear(2, config.embedding_dim)
        self.mlp = mlp([config.embedding_dim + config.encoder_hidden, config.pool_hidden,
                        config.bottleneck_dim], last_activation=True)

    def forward(self, hidden: torch.Tensor, position: torch.Tensor, pairs: torch.Tensor) -> torch.Tensor:
        """hidden (B, H), position (B, 2) scaled, pairs (P, 2) of (i, j) with j a neighbour of i."""
        i, j = pairs[:, 0], pairs[:, 1]  # (P,)
        feat = self.mlp(torch.cat([self.embed(position[j] - position[i]), hidden[j]], dim=-1))  # (P, D)
        out = feat.new_zeros(len(hidden), feat.shape[1])  # (B, D); every i has a pair (i, i)
        return out.scatter_reduce(0, i[:, None].expand_as(feat), feat, "amax", include_self=False)


class TrackDecoder(nn.Module):
    """An LSTM cell fed the embedding of its own last displacement, one displacement per step."""

    def __init__(self, embedding_dim: int, hidden: int):
        super().__init__()
        self.embed = nn.Linear(2, embedding_dim)
        self.cell = nn.LSTMCell(embedding_dim, hidden)
        self.to_rel = nn.Linear(hidden, 2)

    def forward(self, last_rel: torch.Tensor, h0: torch.Tensor, n_steps: int) -> torch.Tensor:
        """last_rel (M, 2), h0 (M, H) -> displacements (M, n_steps, 2)."""
        h, c = h0, torch.zeros_like(h0)
        rel, out = last_rel, []
        for _ in range(n_steps):
            h, c = self.cell(self.embed(rel), (h, c))
            rel = self.to_rel(h)  # (M, 2)
            out.append(rel)
        return torch.stack(out, dim=1)  # (M, n_steps, 2)


class Generator(nn.Module):
    def __init__(self, config: SganConfig):
        super().__init__()
        self.noise_dim = config.noise_dim
        self.encoder = TrackEncoder(config.embedding_dim, config.encoder_hidden)
        self.pool = PoolHidden(config)
        self.context = mlp([config.encoder_hidden + config.bottleneck_dim, config.mlp_dim,
                            config.decoder_hidden - config.noise_dim], last_activation=True)
        self.decoder = TrackDecoder(config.embedding_dim, config.decoder_hidden)

    def forward(self, past_rel: torch.Tensor, last_pos: torch.Tensor, pairs: torch.Tensor,
                noise: torch.Tensor, n_future: int) -> torch.Tensor:
        """past_rel (B, n_p-1, 2), last_pos (B, 2), pairs (P, 2), noise (S, B, noise_dim)
        -> S sampled future displacements (S, B, n_future, 2)."""
        n_samples, batch = noise.shape[:2]
        hidden = self.encoder(past_rel)  # (B, He)
        pooled = self.pool(hidden, last_pos, pairs)  # (B, bottleneck)
        context = self.context(torch.cat([hidden, pooled], dim=-1))  # (B, Hd - noise)
        h0 = torch.cat([context.expand(n_samples, -1, -1), noise], dim=-1)  # (S, B, Hd)
        last_rel = past_rel[:, -1].expand(n_samples, -1, -1)  # (S, B, 2)
        rel = self.decoder(last_rel.reshape(-1, 2), h0.reshape(n_samples * batch, -1), n_future)
        return rel.reshape(n_samples, batch, n_future, 2)


class Discriminator(nn.Module):
    """Real-or-generated logit of a whole displacement sequence."""

    def __init__(self, config: SganConfig):
        super().__init__()
        self.encoder = TrackEncoder(config.embedding_dim, config.discriminator_hidden)
        self.classify = mlp([config.discriminator_hidden, config.mlp_dim, 1])

    def forward(self, rel: torch.Tensor) -> torch.Tensor:
        return self.classify(self.encoder(rel))[:, 0]  # rel (B, T, 2) -> (B,)


# ---------------------------------------------------------------------------------------------
# Batches


@dataclass
class Batch:
    """Scaled displacements of a batch of whole co-occurrence groups."""

    past_rel: torch.Tensor  # (B, n_p-1, 2)
    future_rel: torch.Tensor  # (B, n_f, 2), first one from the last observed position
    position: torch.Tensor  # (B, 2) last observed position (scaled; only differences are used)
    pairs: torch.Tensor  # (P, 2) co-occurring (i, j), i == j included
    group: torch.Tensor  # (B,) group index 0..G-1 within the batch (for the global noise)
    last_px: np.ndarray  # (B, 2) last observed position in pixels
    n_groups: int


def make_batch(past: np.ndarray, future: np.ndarray, groups: np.ndarray, scale: float,
               device: torch.device = CPU) -> Batch:
    """past (B, n_p, 2), future (B, n_f, 2) in pixels (future may be all zeros at test time);
    tensors on `device`."""
    track = np.concatenate([past, future], axis=1) / scale  # (B, T, 2)
    rel = as_input(np.diff(track, axis=1), device, torch.float32)  # (B, T-1, 2)
    n_p = past.shape[1]
    _, local = np.unique(groups, return_inverse=True)
    group = torch.as_tensor(local, device=CPU)
    pairs = (group[:, None] == group[None, :]).nonzero()  # (P, 2), S-GAN pools over the whole group
    return Batch(past_rel=rel[:, : n_p - 1], future_rel=rel[:, n_p - 1:],
                 position=as_input(track[:, n_p - 1], device, torch.float32),
                 pairs=to_device(pairs, device), group=to_device(group, device), last_px=past[:, -1],
                 n_groups=int(local.max()) + 1)


def global_noise(batch: Batch, n_samples: int, dim: int, generator: torch.Generator) -> torch.Tensor:
    """(S, B, dim): one Gaussian draw per sample and co-occurrence group, drawn on the generator's
    device, on the batch's."""
    noise = torch.randn(n_samples, batch.n_groups, dim, generator=generator, device=generator.device)
    return to_device(noise, batch.group.device)[:, batch.group]


def soft_labels(n: int, bounds: list[float], generator: torch.Generator,
                device: torch.device = CPU) -> torch.Tensor:
    """(n,) uniform in [low, high], drawn on the generator's device, on `device`."""
    low, high = bounds
    return low + (high - low) * to_device(torch.rand(n, generator=generator, device=generator.device), device)


# ---------------------------------------------------------------------------------------------
# The baseline


class SocialGan:
    """S-GAN behind the common baseline interface (fit / load / predict)."""

    name = SGAN
    config_class = SganConfig
    trainable = True

    def __init__(self, config: SganConfig, n_past: int, n_future: int, device: torch.device = CPU):
        self.config, self.n_past, self.n_future = config, n_past, n_future
        self.device = torch.device(device)
        # Initialised on the CPU (torch's global RNG), then moved: the same weights on any device.
        self.generator = Generator(config).to(self.device)
        self.discriminator = Discriminator(config).to(self.device)
        self.fit_result: FitResult | None = None  # set by fit

    @classmethod
    def fit(cls, train: WindowArrays, val: WindowArrays, config: SganConfig, checkpoint_dir: Path,
            seed: int, device: torch.device = CPU, preemption: Preemption = NEVER) -> SocialGan:
        if len(train) == 0 or len(val) == 0:
            raise ValueError("S-GAN needs training and validation windows")
        rng = checkpoints.seed_everything(seed, device)
        model = cls(config, train.past.shape[1], train.future.shape[1], device)
        common.check_windows(val, model.n_past, model.n_future, "validation windows")
        opt_g = torch.optim.Adam(model.generator.parameters(), lr=config.learning_rate)
        opt_d = torch.optim.Adam(model.discriminator.parameters(), lr=config.learning_rate)
        groups = common.co_occurrence_groups(train)

        def epoch_batches(epoch: int) -> list[np.ndarray]:
            return common.group_batches(groups, config.batch_size, rng)

        def train_batch(index: np.ndarray) -> np.ndarray:
            batch = make_batch(train.past[index], train.future[index], groups[index], config.coord_scale,
                               device)
            return model.train_step(batch, opt_g, opt_d, rng)

        def validate() -> np.ndarray:
            pred = model.predict(val, config.val_k, seeded_generator(device, seed + 1))
            return window_errors(pred, val.future).ade  # (N,)

        model.fit_result = run_training(
            name=cls.name, modules={"generator": model.generator, "discriminator": model.discriminator},
            optimizers={"generator": opt_g, "discriminator": opt_d}, epoch_batches=epoch_batches,
            train_batch=train_batch, loss_names=("loss_d", "loss_adv", "loss_l2"),
            validate=validate, epochs=config.epochs, config=dataclasses.asdict(config),
            meta={"n_past": model.n_past, "n_future": model.n_future, "seed": seed},
            data_fingerprint=checkpoints.run_digest(str(seed), train, val),
            checkpoint_dir=checkpoint_dir, generator=rng, device=device, preemption=preemption)
        return model

    def train_step(self, batch: Batch, opt_g: torch.optim.Optimizer, opt_d: torch.optim.Optimizer,
                   rng: torch.Generator) -> np.ndarray:
        """d_steps discriminator updates and one generator update; returns [loss_d, adv, l2]."""
        cfg, n_f = self.config, batch.future_rel.shape[1]
        real = torch.cat([batch.past_rel, batch.future_rel], dim=1)  # (B, T-1, 2)
        n = len(real)
        loss_d = torch.zeros((), device=real.device)
        for _ in range(cfg.d_steps):
            with torch.no_grad():
                fake_rel = self.generator(batch.past_rel, batch.position, batch.pairs,
                                          global_noise(batch, 1, cfg.noise_dim, rng), n_f)[0]
            fake = torch.cat([batch.past_rel, fake_rel], dim=1)
            loss_d = (F.binary_cross_entropy_with_logits(self.discriminator(real),
                                                         soft_labels(n, cfg.real_label, rng, real.device))
                      + F.binary_cross_entropy_with_logits(self.discriminator(fake),
                                                           soft_labels(n, cfg.fake_label, rng, real.device)))
            opt_d.zero_grad()
            loss_d.backward()
            if cfg.clip_d > 0:
                nn.utils.clip_grad_norm_(self.discriminator.parameters(), cfg.clip_d)
            opt_d.step()
        samples = self.generator(batch.past_rel, batch.position, batch.pairs,
                                 global_noise(batch, cfg.best_of_k, cfg.noise_dim, rng), n_f)  # (k, B, n_f, 2)
        l2 = ((samples - batch.future_rel) ** 2).sum(dim=(-1, -2))  # (k, B)
        loss_l2 = l2.min(dim=0).values.mean()
        fake = torch.cat([batch.past_rel, samples[0]], dim=1)
        loss_adv = F.binary_cross_entropy_with_logits(self.discriminator(fake),
                                                      soft_labels(n, cfg.real_label, rng, real.device))
        loss_g = loss_adv + cfg.l2_weight * loss_l2
        opt_g.zero_grad()
        loss_g.backward()
        if cfg.clip_g > 0:
            nn.utils.clip_grad_norm_(self.generator.parameters(), cfg.clip_g)
        opt_g.step()
        return np.array([loss_d.item(), loss_adv.item(), loss_l2.item()])

    @classmethod
    def load(cls, checkpoint_dir: Path, device: torch.device = CPU, selection: str = "raw") -> SocialGan:
        """The weights selection rule `selection` kept (`common.best_path`), on `device`."""
        state = common.load_checkpoint(common.best_path(checkpoint_dir, selection), map_location=device)
        model = cls(SganConfig(**state["config"]), state["meta"]["n_past"], state["meta"]["n_future"], device)
        model.generator.load_state_dict(state["modules"]["generator"])
        model.discriminator.load_state_dict(state["modules"]["discriminator"])
        model.generator.eval()
        return model

    @torch.no_grad()
    def predict(self, arrays: WindowArrays, k: int, generator: torch.Generator,
                batch_size: int = 512) -> np.ndarray:
        """(N, k, n_f, 2) sampled futures in pixels; the noise is drawn on `generator`'s device."""
        common.check_windows(arrays, self.n_past, None, "S-GAN input")
        self.generator.eval()
        groups = common.co_occurrence_groups(arrays)
        out = np.zeros((len(arrays), k, self.n_future, 2))
        empty_future = np.zeros((len(arrays), self.n_future, 2))
        for index in common.group_batches(groups, batch_size):
            batch = make_batch(arrays.past[index], empty_future[index], groups[index], self.config.coord_scale,
                               self.device)
            noise = global_noise(batch, k, self.config.noise_dim, generator)
            rel = self.generator(batch.past_rel, batch.position, batch.pairs, noise, self.n_future)
            path = rel.cumsum(dim=2).double().cpu().numpy() * self.config.coord_scale  # (k, B, n_f, 2)
            out[index] = batch.last_px[:, None, None] + path.transpose(1, 0, 2, 3)
        return out
