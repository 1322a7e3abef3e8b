"""Section `segmentation.<profile>` of params.yaml: the U-Net's training and its augmentations."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class AugmentParams:
    """Ranges of the random augmentations (all zero / False = plain random crops)."""

    rotate_deg: float = 180.0
    """Rotation angle drawn uniformly from [-rotate_deg, rotate_deg]; drone views have no 'up'."""
    flip: bool = True
    """Mirror with probability 1/2 (with free rotation this covers vertical flips too)."""
    scale_min: float = 0.75
    """Smallest zoom factor; factors are log-uniform in [scale_min, scale_max] (>1 zooms out)."""
    scale_max: float = 1.33
    """Largest zoom factor."""
    perspective: float = 0.05
    """Each crop corner moves by up to this fraction of the crop size (perspective distortion)."""
    noise_std: float = 0.03
    """Gaussian pixel noise with std drawn uniformly from [0, noise_std] (image in [0, 1])."""
    blur_prob: float = 0.3
    """Probability of a Gaussian blur."""
    blur_sigma: float = 1.5
    """Blur sigma drawn uniformly from [0.3, blur_sigma] pixels."""
    brightness: float = 0.15
    """Additive brightness shift drawn uniformly from [-brightness, brightness]."""
    contrast: float = 0.25
    """Contrast factor drawn uniformly from [1 - contrast, 1 + contrast] about the crop mean."""
    colour: float = 0.1
    """Per-channel gain drawn uniformly from [1 - colour, 1 + colour] (colour cast)."""

    def __post_init__(self) -> None:
        if not 0 <= self.rotate_deg <= 180:
            raise ValueError(f"rotate_deg must be in [0, 180], got {self.rotate_deg}")
        if not 0 < self.scale_min <= self.scale_max:
            raise ValueError(f"need 0 < scale_min <= scale_max, got {self.scale_min}, {self.scale_max}")
        if not 0 <= self.perspective < 0.25:
            raise ValueError(f"perspective must be in [0, 0.25), got {self.perspective}")
        if not 0 <= self.blur_prob <= 1:
            raise ValueError(f"blur_prob must be in [0, 1], got {self.blur_prob}")
        if self.blur_sigma < 0.3:
            raise ValueError(f"blur_sigma must be >= 0.3, got {self.blur_sigma}")
        for name in ("noise_std", "brightness"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        for name in ("contrast", "colour"):
            if not 0 <= getattr(self, name) < 1:
                raise ValueError(f"{name} must be in [0, 1), got {getattr(self, name)}")


@dataclass(frozen=True)
class SegmentationParams:
    """Section `segmentation` of params.yaml, one per profile (`segmentation: {cpu: ..., paper: ...}`)."""

    base_channels: int
    """U-Net width of the first level, doubled at every level down (cpu: 16; paper: 32)."""
    depth: int
    """Number of 2x downsamplings of the U-Net; `pad_multiple` and `crop` must divide by 2**depth."""
    epochs: int
    """Passes over the training videos."""
    crops_per_image: int
    """Random crops drawn from every training video per epoch (paper: 1, one per image)."""
    lr_drop_epoch: int
    """From this epoch on the learning rate is multiplied by `lr_drop_factor` (paper: 1500)."""
    bf16: bool
    """On the CPU, bfloat16 autocast + channels-last: ~3x faster on CPUs with AMX/AVX512-BF16, slow
    elsewhere. On CUDA both are always on, whatever this says (`pipeline.device.autocast`)."""
    seed: int = 0
    """Seeds weight init and the crop/augmentation stream (one numpy stream per epoch)."""
    downsample: int = 4
    """Images and labels are shrunk by this factor (paper: 4 for SDD); Y-net's resize is 1/downsample."""
    pad_multiple: int = 32
    """Downsampled images are padded (padding class) to a multiple of this (paper: 32)."""
    crop: int = 256
    """Side of the square training crops (paper: 256)."""
    batch_size: int = 4
    """Crops per optimiser step (paper: 4)."""
    lr: float = 1e-4
    """Adam learning rate (paper: 1e-4)."""
    lr_drop_factor: float = 0.1
    """Learning-rate factor from `lr_drop_epoch` on (paper: 1e-4 -> 1e-5)."""
    augment: AugmentParams = field(default_factory=AugmentParams)
    """Ranges of the random augmentations."""
    threads: int = 1
    """torch CPU threads. One: on 2 cores two threads ran about 4x slower than one, and a
    single-threaded stage runs beside another one under `make repro` (tools/parallel_repro.py)."""

    def __post_init__(self) -> None:
        for name in ("base_channels", "depth", "epochs", "crops_per_image", "downsample",
                     "pad_multiple", "crop", "batch_size", "threads"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.lr_drop_epoch < 0:
            raise ValueError(f"lr_drop_epoch must be >= 0, got {self.lr_drop_epoch}")
        if not self.lr > 0 or not 0 < self.lr_drop_factor <= 1:
            raise ValueError(f"need lr > 0 and 0 < lr_drop_factor <= 1, got {self.lr}, "
                             f"{self.lr_drop_factor}")
        if self.pad_multiple % 2**self.depth or self.crop % 2**self.depth:
            raise ValueError(f"depth={self.depth}: pad_multiple ({self.pad_multiple}) and crop "
                             f"({self.crop}) must be divisible by 2**depth")
