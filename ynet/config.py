"""Y-net's configuration and the authors' distance-map normaliser: plain Python, no torch.

Kept apart from `ynet.model` and `ynet.heatmaps` so that settings code (`pipeline.config`) can
build a `YNetConfig` without depending on the network's code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class YNetConfig:
    obs_len: int = 5
    """n_p: observed steps, one distance-map input channel each."""
    pred_len: int = 30
    """n_f: future steps, one output heatmap each (from both decoders)."""
    semantic_classes: int = 6
    """Channels of the semantic map (SDD: 5 classes + background/padding)."""
    encoder_channels: tuple[int, ...] = (32, 32, 64, 64, 64)
    """Output channels of the encoder's stem and of each of its pool-conv-conv blocks."""
    decoder_channels: tuple[int, ...] = (64, 64, 64, 32, 32)
    """Output channels of each decoder block, coarse to fine."""
    waypoints: tuple[int, ...] = (14, 29)
    """Future step indices (0-based) the trajectory decoder is conditioned on; the last is the goal."""
    head_bias: float | None = None
    """Initial bias of both decoders' output logits; None keeps PyTorch's default (the authors').

    The targets are Gaussians summing to 1, so a trained map is near zero almost everywhere. From
    the default init (logits ~0) the background sinks slowly, and while it sits a few nats below
    the peak, the softargmax over ~10^4-10^5 pixels is pulled toward the image centre (the
    trajectory decoder's ADE suffers most). Starting the background low (e.g. -15, as in
    RetinaNet's prior-probability init) lets short training runs reach sharp maps."""

    def __post_init__(self):
        if min(self.obs_len, self.pred_len, self.semantic_classes) < 1:
            raise ValueError("obs_len, pred_len and semantic_classes must be positive")
        if len(self.decoder_channels) != len(self.encoder_channels):
            raise ValueError("decoder_channels needs one entry per encoder level")
        wp = tuple(self.waypoints)
        if not wp or list(wp) != sorted(set(wp)) or wp[0] < 0:
            raise ValueError(f"waypoints must be increasing step indices, got {wp}")
        if wp[-1] != self.pred_len - 1:
            raise ValueError(f"the last waypoint must be the goal, step {self.pred_len - 1}, got {wp}")

    @property
    def in_channels(self) -> int:
        return self.semantic_classes + self.obs_len

    @property
    def n_waypoints(self) -> int:
        return len(self.waypoints)


# The authors build every distance map by cropping one square template of side int(4200 * resize),
# normalised by ITS maximum (centre to corner), so the slope of a distance map is the same constant for
# every position and every scene of a dataset. 4200 px is their choice (more than twice the largest SDD
# image side), not a property of the data.
UPSTREAM_TEMPLATE_SIDE = 4200


def upstream_max_distance(resize: float, template_side: int = UPSTREAM_TEMPLATE_SIDE) -> float:
    """The normaliser the authors' distance maps use at a given `resize` (742.46 px at 0.25).

    Their template is a `S x S` grid, `S = int(template_side * resize)`, of distances to its centre
    pixel `S // 2`, divided by its own maximum: the distance from the centre to the corner (0, 0),
    `sqrt(2) * (S // 2)`. Pass the result as `max_distance` to `distance_maps`.
    """
    side = int(template_side * resize)
    return math.sqrt(2.0) * (side // 2)
