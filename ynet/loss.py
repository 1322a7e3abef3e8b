"""Y-net's training loss: per-pixel binary cross-entropy against Gaussian ground-truth heatmaps."""

from __future__ import annotations

from typing import NamedTuple

import torch
import torch.nn.functional as F


class YNetLoss(NamedTuple):
    total: torch.Tensor
    goal: torch.Tensor
    trajectory: torch.Tensor


def ynet_loss(
    goal_logits: torch.Tensor,
    trajectory_logits: torch.Tensor,
    target: torch.Tensor,
    loss_scale: float = 1000.0,
) -> YNetLoss:
    """BCE-with-logits of both decoders against the same target, each times `loss_scale`.

    goal_logits, trajectory_logits, target: (B, n_f, H, W); target = `gaussian_heatmaps` of the future.
    The goal decoder is trained on every future step, not only the waypoints: the other steps are an
    auxiliary task. The paper's weights lambda_1 = lambda_2 = 1; the authors scale both terms by 1000
    because the targets (peak ~0.01) make the mean BCE tiny.
    """
    goal = F.binary_cross_entropy_with_logits(goal_logits, target) * loss_scale
    trajectory = F.binary_cross_entropy_with_logits(trajectory_logits, target) * loss_scale
    return YNetLoss(goal + trajectory, goal, trajectory)
