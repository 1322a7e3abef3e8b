"""The scene segmentation network: a small U-Net that turns an RGB scene into class scores.

Y-net sees a scene only through its semantic map; what its channels mean (`CLASS_NAMES`) is fixed
in `ynet.classes` (no torch) and named here too, beside the network and its Dice loss. Tensors in,
tensors out: no files, no training loop (that is `pipeline/segmentation.py`).

The paper uses a U-Net with an ImageNet-pretrained ResNet101 encoder. No pretrained weights are
available here, so this U-Net is plain PyTorch, trained from scratch, and small enough for a CPU.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from ynet.classes import CLASS_NAMES, N_OUTPUTS, N_SCENE_CLASSES, PAD_CLASS  # the network's too


@dataclass(frozen=True)
class UNetConfig:
    """Shape of the U-Net; stored with every checkpoint so weights can be rebuilt without guessing."""

    in_channels: int = 3
    n_classes: int = N_OUTPUTS
    base_channels: int = 16  # channels of the first level, doubled at every level down
    depth: int = 4  # number of 2x downsamplings; inputs must be divisible by 2**depth

    def __post_init__(self) -> None:
        if self.in_channels < 1 or self.n_classes < 2:
            raise ValueError(f"need in_channels >= 1 and n_classes >= 2, got {self}")
        if self.base_channels < 1 or not 1 <= self.depth <= 6:
            raise ValueError(f"need base_channels >= 1 and 1 <= depth <= 6, got {self}")


class DoubleConv(nn.Module):
    """Two 3x3 conv + BatchNorm + ReLU: the unit every U-Net level is built from."""

    def __init__(self, c_in: int, c_out: int) -> None:
        super().__init__()
        self.body = nn.Sequential(
            nn.Conv2d(c_in, c_out, 3, padding=1, bias=False),
            nn.BatchNorm2d(c_out),
            nn.ReLU(inplace=True),
            nn.Conv2d(c_out, c_out, 3, padding=1, bias=False),
            nn.BatchNorm2d(c_out),
            nn.ReLU(inplace=True),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.body(x)


class Down(nn.Module):
    """Halve the resolution, then widen."""

    def __init__(self, c_in: int, c_out: int) -> None:
        super().__init__()
        self.conv = DoubleConv(c_in, c_out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.conv(F.max_pool2d(x, 2))


class Up(nn.Module):
    """Double the resolution, then fuse with the encoder skip of the same scale."""

    def __init__(self, c_in: int, c_skip: int, c_out: int) -> None:
        super().__init__()
        self.reduce = nn.Conv2d(c_in, c_out, 1)
        self.conv = DoubleConv(c_out + c_skip, c_out)

    def forward(self, x: torch.Tensor, skip: torch.Tensor) -> torch.Tensor:
        x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=False)
        x = self.reduce(x)  # (B, c_out, H, W)
        return self.conv(torch.cat([x, skip], dim=1))


class UNet(nn.Module):
    """U-Net: image (B, 3, H, W), float in [0, 1] -> class logits (B, n_classes, H, W).

    Padding pixels are exact zeros (black) both in training and at inference.
    """

    def __init__(self, cfg: UNetConfig) -> None:
        super().__init__()
        self.cfg = cfg
        widths = [cfg.base_channels * 2**i for i in range(cfg.depth + 1)]
        self.stem = DoubleConv(cfg.in_channels, widths[0])
        self.downs = nn.ModuleList(Down(widths[i], widths[i + 1]) for i in range(cfg.depth))
        self.ups = nn.ModuleList(
            Up(widths[i + 1], widths[i], widths[i]) for i in reversed(range(cfg.depth))
        )
        self.head = nn.Conv2d(widths[0], cfg.n_classes, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        multiple = 2**self.cfg.depth
        if x.shape[-1] % multiple or x.shape[-2] % multiple:
            raise ValueError(f"input {tuple(x.shape)}: H and W must be multiples of {multiple}")
        x = (x - 0.5) / 0.25  # fixed centring: no dataset statistics to keep in sync
        skips = [self.stem(x)]  # (B, C0, H, W)
        for down in self.downs:
            skips.append(down(skips[-1]))
        x = skips.pop()  # (B, C_depth, H / 2**depth, W / 2**depth)
        for up in self.ups:
            x = up(x, skips.pop())
        return self.head(x)  # (B, n_classes, H, W)


def dice_loss(logits: torch.Tensor, target: torch.Tensor, eps: float = 1e-6) -> torch.Tensor:
    """1 - mean soft Dice over the classes present in `target` (multi-class Dice loss).

    Dice is computed per class over the whole batch, so a class that is rare in pixels weighs as much
    as a common one (the point of a Dice loss on unbalanced maps, Sudre et al. 2017). Classes absent
    from the batch's target are left out: their Dice is 0/0 and would only push them to zero.
    logits: (B, C, H, W); target: (B, H, W) int64 class indices in 0..C-1.
    """
    n_classes = logits.shape[1]
    probs = logits.softmax(dim=1)  # (B, C, H, W)
    onehot = F.one_hot(target, n_classes).permute(0, 3, 1, 2).to(probs.dtype)  # (B, C, H, W)
    dims = (0, 2, 3)
    intersection = (probs * onehot).sum(dims)  # (C,)
    cardinality = probs.sum(dims) + onehot.sum(dims)  # (C,)
    dice = (2 * intersection + eps) / (cardinality + eps)  # (C,)
    present = onehot.sum(dims) > 0  # (C,)
    return 1 - dice[present].mean()


def confusion_matrix(pred: torch.Tensor, target: torch.Tensor, n_classes: int) -> torch.Tensor:
    """(n_classes, n_classes) counts, rows = target, columns = prediction; any shapes alike."""
    index = target.reshape(-1).long() * n_classes + pred.reshape(-1).long()
    return torch.bincount(index, minlength=n_classes * n_classes).reshape(n_classes, n_classes)
