"""Section `pecnet.<profile>` of params.yaml: PECNet's model and training settings."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class PecnetConfig:
    """Section `pecnet.<profile>` of params.yaml: PECNet's model and training settings
    (`pipeline.runners.baselines.pecnet`)."""

    epochs: int = 650
    """Training epochs; the best on val is kept."""
    batch_size: int = 512
    """Windows per batch (whole co-occurrence groups, so about this many)."""
    learning_rate: float = 3e-4
    """Adam learning rate."""
    past_hidden: list[int] = field(default_factory=lambda: [512, 256])
    """Hidden widths of the past encoder (2 n_p -> ... -> feature_dim)."""
    endpoint_hidden: list[int] = field(default_factory=lambda: [8, 16])
    """Hidden widths of the endpoint encoder (2 -> ... -> feature_dim)."""
    latent_hidden: list[int] = field(default_factory=lambda: [8, 50])
    """Hidden widths of the latent encoder (2 feature_dim -> ... -> 2 latent_dim)."""
    decoder_hidden: list[int] = field(default_factory=lambda: [1024, 512, 1024])
    """Hidden widths of the endpoint decoder (feature_dim + latent_dim -> ... -> 2)."""
    predictor_hidden: list[int] = field(default_factory=lambda: [1024, 512, 256])
    """Hidden widths of the path predictor (-> 2 (n_f - 1))."""
    nonlocal_hidden: list[int] = field(default_factory=lambda: [256, 128, 64])
    """Hidden widths of the non-local theta, phi and g MLPs."""
    nonlocal_dim: int = 128
    """Width of the non-local embedding whose dot products weigh the neighbours."""
    nonlocal_rounds: int = 3
    """Rounds of non-local social pooling before the path predictor."""
    feature_dim: int = 16
    """Width of the past and endpoint features."""
    latent_dim: int = 16
    """Width of the latent z."""
    sigma: float = 1.3
    """Standard deviation of z at test time (truncation trick)."""
    neighbour_radius: float = 100.0
    """Pixels: co-occurring agents closer than this at some observed step pool together."""
    data_scale: float = 1.86
    """Factor applied to origin-shifted pixel coordinates."""
    position_scale: float = 1000.0
    """Pixels per unit of the absolute-position input."""
    kl_weight: float = 1.0
    """Weight of the KL term (summed over batch and latent dimensions); see "Loss balance"."""
    path_weight: float = 1.0
    """Weight of the path MSE."""
    reverse_augment: bool = True
    """Add every training window played backwards."""
    val_k: int = 20
    """Samples per window when scoring the validation split (min-over-K ADE selects the epoch)."""

    def __post_init__(self):
        for name in ("epochs", "batch_size", "nonlocal_dim", "feature_dim", "latent_dim", "val_k"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.nonlocal_rounds < 0:
            raise ValueError("nonlocal_rounds must be >= 0")
        for name in ("learning_rate", "sigma", "neighbour_radius", "data_scale", "position_scale"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0")
        if self.kl_weight < 0 or self.path_weight < 0:
            raise ValueError("kl_weight and path_weight must be >= 0")
        for name in ("past_hidden", "endpoint_hidden", "latent_hidden", "decoder_hidden",
                     "predictor_hidden", "nonlocal_hidden"):
            widths = getattr(self, name)
            if not isinstance(widths, list) or any(int(w) != w or w < 1 for w in widths):
                raise ValueError(f"{name} must be a list of positive widths, got {widths}")
