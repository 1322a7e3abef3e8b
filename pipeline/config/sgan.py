"""Section `sgan.<profile>` of params.yaml: S-GAN's model and training settings."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class SganConfig:
    """Section `sgan.<profile>` of params.yaml: S-GAN's model and training settings
    (`pipeline.runners.baselines.sgan`)."""

    epochs: int = 200
    """Training epochs (passes over the training windows); the best on val is kept."""
    batch_size: int = 64
    """Windows per batch (whole co-occurrence groups, so about this many)."""
    learning_rate: float = 1e-3
    """Adam learning rate of generator and discriminator."""
    clip_g: float = 1.5
    """Generator gradient-norm clip (0: none)."""
    clip_d: float = 0.0
    """Discriminator gradient-norm clip (0: none)."""
    d_steps: int = 2
    """Discriminator updates per generator update."""
    best_of_k: int = 10
    """Samples the variety loss takes the best of."""
    l2_weight: float = 1.0
    """Weight of the variety (best-of-k L2) loss against the adversarial loss."""
    real_label: list[float] = field(default_factory=lambda: [0.7, 1.2])
    """Range the discriminator's target for real tracks (and the generator's) is drawn from."""
    fake_label: list[float] = field(default_factory=lambda: [0.0, 0.3])
    """Range the discriminator's target for generated tracks is drawn from."""
    embedding_dim: int = 16
    """Width of the displacement / relative-position embeddings."""
    encoder_hidden: int = 32
    """Hidden size of the generator's encoder LSTM."""
    decoder_hidden: int = 32
    """Hidden size of the decoder LSTM (its initial state: context + noise)."""
    noise_dim: int = 8
    """Gaussian noise entries of the decoder's initial state."""
    bottleneck_dim: int = 32
    """Output width of the pooling module."""
    pool_hidden: int = 512
    """Hidden width of the pooling module's pre-pool MLP."""
    mlp_dim: int = 64
    """Hidden width of the context MLP and of the discriminator's classifier."""
    discriminator_hidden: int = 48
    """Hidden size of the discriminator's LSTM."""
    coord_scale: float = 20.0
    """Pixels per network unit (about one step of walking at 1 FPS)."""
    val_k: int = 20
    """Samples per window when scoring the validation split (min-over-K ADE selects the epoch)."""

    def __post_init__(self):
        positive = ("epochs", "batch_size", "d_steps", "best_of_k", "embedding_dim", "encoder_hidden",
                    "bottleneck_dim", "pool_hidden", "mlp_dim", "discriminator_hidden", "val_k")
        for name in positive:
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not 0 <= self.noise_dim < self.decoder_hidden:
            raise ValueError("noise_dim must be in [0, decoder_hidden)")
        if self.learning_rate <= 0 or self.coord_scale <= 0:
            raise ValueError("learning_rate and coord_scale must be > 0")
        if self.clip_g < 0 or self.clip_d < 0 or self.l2_weight < 0:
            raise ValueError("clip_g, clip_d and l2_weight must be >= 0")
        for name in ("real_label", "fake_label"):
            low, high = getattr(self, name)
            if low > high:
                raise ValueError(f"{name}: [low, high] with low <= high")
