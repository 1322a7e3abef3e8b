"""Y-net: a U-net encoder U_e and two U-net decoders, U_g (goal and waypoint heatmaps) and U_t
(trajectory heatmaps conditioned on a goal and waypoints).

Read top to bottom: building blocks, encoder, decoder, the full model. Shapes use
B = batch (windows), K = samples per window, C = semantic classes, n_p / n_f = observed / future steps,
n_w = waypoints including the goal, H x W = the padded map (multiples of 2^L = 32 for L = 5 levels).

The layer sizes follow the authors' code, so the parameter count matches theirs (1,654,022 for the
long-term SDD config): in particular each decoder block's upsampling conv halves the channels, and the
trajectory decoder's conditioning maps widen its centre block to 2 * (64 + n_w) channels.
"""

from __future__ import annotations

import torch
import torch.nn as nn
import torch.nn.functional as F

from ynet.config import YNetConfig


def conv3x3(in_channels: int, out_channels: int) -> nn.Conv2d:
    return nn.Conv2d(in_channels, out_channels, kernel_size=3, padding=1)


def shared_input_conv(
    conv: nn.Conv2d,
    shared: torch.Tensor,
    before: torch.Tensor | None = None,
    after: torch.Tensor | None = None,
) -> torch.Tensor:
    """`conv(cat([before, shared, after], dim=1))`, where `shared` may be given once per window.

    A conv is linear in its input channels. When `shared` is (B, ...) and `before` / `after` carry
    K samples per window (B*K, ...), the share of `shared` is computed once per window and broadcast
    over the K samples. This is what makes the trajectory decoder cheap to run for many sampled goals:
    the encoder skips are the same for all of them.
    """
    others = [t for t in (before, after) if t is not None]
    if all(t.shape[0] == shared.shape[0] for t in others):  # one sample per window: a plain conv
        return conv(torch.cat([t for t in (before, shared, after) if t is not None], dim=1))
    lo = 0 if before is None else before.shape[1]
    hi = lo + shared.shape[1]
    w = conv.weight
    w_shared = w[:, lo:hi].contiguous()
    shared_term = F.conv2d(shared, w_shared, conv.bias, padding=conv.padding)  # (B, C, h, w)
    w_others = torch.cat([w[:, :lo], w[:, hi:]], dim=1)
    out = F.conv2d(torch.cat(others, dim=1), w_others, padding=conv.padding)  # (B*K, C, h, w)
    out.unflatten(0, (shared.shape[0], -1)).add_(shared_term.unsqueeze(1))  # (B, K, C, h, w), in place
    return out


def pointwise_conv(conv: nn.Conv2d, x: torch.Tensor) -> torch.Tensor:
    """`conv(x)` for a 1x1 conv, as a batched matmul whose output is NCHW whatever x's layout.

    Every output map later goes through a spatial softmax (or the loss), which is ~2.5x faster on
    contiguous maps than on channels_last ones.
    """
    weight = conv.weight.flatten(1).expand(x.shape[0], -1, -1)  # (N, C_out, C_in)
    out = torch.baddbmm(conv.bias[None, :, None], weight, x.flatten(2))  # (N, C_out, H*W)
    return out.unflatten(2, x.shape[-2:])  # (N, C_out, H, W)


def cuda_autocast_dtype(x: torch.Tensor) -> torch.dtype | None:
    """The dtype CUDA autocast runs convolutions in, where `x` is on CUDA under autocast; else
    None (the CPU, whose numbers the shortcuts that ask this must not move)."""
    if x.is_cuda and torch.is_autocast_enabled("cuda"):
        return torch.get_autocast_dtype("cuda")
    return None


def upsample2x(x: torch.Tensor) -> torch.Tensor:
    """x2 bilinear upsampling (B, C, h, w) -> (B, C, 2h, 2w), corners not aligned (as upstream).

    On CUDA under autocast it runs in x's own dtype, the autocast one after a convolution:
    autocast's policy for this op is float32, a copy to float32 and back around a float32 kernel
    (11 % of a `paper` training step's kernel time on an H200, forward and backward).
    """
    if cuda_autocast_dtype(x) is not None:
        with torch.autocast(x.device.type, enabled=False):
            return F.interpolate(x, scale_factor=2, mode="bilinear", align_corners=False)
    return F.interpolate(x, scale_factor=2, mode="bilinear", align_corners=False)


def memory_format(x: torch.Tensor) -> torch.memory_format:
    """channels_last if `x` is stored that way (convs on CPU are about 1.5x faster in it), else NCHW."""
    if x.dim() == 4 and x.is_contiguous(memory_format=torch.channels_last):
        return torch.channels_last
    return torch.contiguous_format


class Encoder(nn.Module):
    """U_e: a conv stem, then blocks of [maxpool 2, conv, conv], then a last maxpool.

    Returns the output of every stage, fine to coarse: the decoders use them as skip connections.
    """

    def __init__(self, config: YNetConfig):
        super().__init__()
        ch = config.encoder_channels
        self.stem = nn.Sequential(conv3x3(config.in_channels, ch[0]), nn.ReLU(inplace=True))
        self.blocks = nn.ModuleList(
            nn.Sequential(
                nn.MaxPool2d(2),
                conv3x3(c_in, c_out),
                nn.ReLU(inplace=True),
                conv3x3(c_out, c_out),
                nn.ReLU(inplace=True),
            )
            for c_in, c_out in zip(ch[:-1], ch[1:])
        )
        self.pool = nn.MaxPool2d(2)

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        x = self.stem(x)  # (B, c0, H, W)
        features = [x]
        for block in self.blocks:
            x = block(x)  # (B, c_i, H / 2^i, W / 2^i)
            features.append(x)
        features.append(self.pool(x))  # (B, c_last, H / 2^L, W / 2^L), L = len(encoder_channels)
        return features


class UpBlock(nn.Module):
    """One decoder block: x2 bilinear upsampling, a conv halving the channels (no ReLU after it, as
    upstream), concatenation with the encoder skip (and the conditioning maps), two conv + ReLU."""

    def __init__(self, in_channels: int, skip_channels: int, out_channels: int):
        super().__init__()
        self.up = conv3x3(in_channels, in_channels // 2)
        self.conv1 = conv3x3(in_channels // 2 + skip_channels, out_channels)
        self.conv2 = conv3x3(out_channels, out_channels)

    def forward(
        self, x: torch.Tensor, skip: torch.Tensor, cond: torch.Tensor | None = None
    ) -> torch.Tensor:
        # x: (B*K, c_in, h, w), skip: (B, c_skip, 2h, 2w), cond: (B*K, n_w, 2h, 2w) or None
        x = upsample2x(x)
        x = self.up(x)  # (B*K, c_in / 2, 2h, 2w)
        x = F.relu(shared_input_conv(self.conv1, skip, before=x, after=cond), inplace=True)
        return F.relu(self.conv2(x), inplace=True)  # (B*K, c_out, 2h, 2w)


class Decoder(nn.Module):
    """U_g (n_cond = 0) or U_t (n_cond = n_w): a centre block on the coarsest encoder feature, one
    UpBlock per finer level, a 1x1 conv to one logit map per future step.

    U_t gets the goal and waypoint distance maps, average-pooled to every scale, concatenated to the
    centre input and to every skip. Its `forward` takes K samples per window at once: the skips are
    given once per window and broadcast (see `shared_input_conv`).
    """

    def __init__(self, config: YNetConfig, n_cond: int = 0):
        super().__init__()
        skips = [c + n_cond for c in reversed(config.encoder_channels)]  # coarse to fine
        centre = skips[0]
        self.n_cond = n_cond
        self.centre1 = conv3x3(centre, 2 * centre)
        self.centre2 = conv3x3(2 * centre, 2 * centre)
        ins = [2 * centre, *config.decoder_channels[:-1]]
        self.blocks = nn.ModuleList(
            UpBlock(c_in, c_skip, c_out)
            for c_in, c_skip, c_out in zip(ins, skips, config.decoder_channels)
        )
        self.head = nn.Conv2d(config.decoder_channels[-1], config.pred_len, kernel_size=1)
        if config.head_bias is not None:
            nn.init.constant_(self.head.bias, config.head_bias)

    def forward(
        self, features: list[torch.Tensor], cond: torch.Tensor | None = None
    ) -> torch.Tensor:
        # features: encoder outputs fine to coarse, each (B, c, H / 2^i, W / 2^i)
        # cond: (B*K, n_w, H, W) distance maps, K samples per window, or None for U_g
        if (cond is None) != (self.n_cond == 0) or (cond is not None and cond.shape[1] != self.n_cond):
            raise ValueError(f"this decoder expects {self.n_cond} conditioning channels")
        conds = [None] * len(features)
        if cond is not None:
            # Restrided, not `.contiguous()`: a 1-channel map (one waypoint) counts as contiguous
            # in both layouts, and torch picks a conv's layout from its input's strides, so the
            # K-sample decoder would fall back to NCHW (about 1.5x slower on CPU) with a copy at
            # every skip. On CUDA under autocast, in its dtype: a float32 map would promote every
            # concatenation with the features to float32, each cast back by the next conv.
            dtype, layout = cuda_autocast_dtype(cond), memory_format(features[0])
            conds[0] = (cond.clone(memory_format=layout) if dtype is None
                        else cond.to(dtype, memory_format=layout, copy=True))
            for i in range(1, len(features)):
                conds[i] = F.avg_pool2d(conds[i - 1], 2)  # (B*K, n_w, H / 2^i, W / 2^i)
        x = F.relu(shared_input_conv(self.centre1, features[-1], after=conds[-1]), inplace=True)
        x = F.relu(self.centre2(x), inplace=True)  # (B*K, 2 * centre, H / 2^L, W / 2^L)
        for block, skip, c in zip(self.blocks, features[-2::-1], conds[-2::-1]):
            x = block(x, skip, c)
        return pointwise_conv(self.head, x)  # (B*K, n_f, H, W)


class YNet(nn.Module):
    """The whole model. `forward` is the training pass (ground-truth goal and waypoints); inference
    runs `encode` once, `predict_goals` once, then `predict_trajectory` for many sampled goals."""

    def __init__(self, config: YNetConfig):
        super().__init__()
        self.config = config
        self.encoder = Encoder(config)
        self.goal_decoder = Decoder(config)
        self.trajectory_decoder = Decoder(config, n_cond=config.n_waypoints)

    def encode(self, scene_and_past: torch.Tensor) -> list[torch.Tensor]:
        """(B, C + n_p, H, W) semantic map and past distance maps -> encoder features, fine to coarse."""
        return self.encoder(scene_and_past)

    def predict_goals(self, features: list[torch.Tensor]) -> torch.Tensor:
        """Goal and waypoint logits for every future step (the non-waypoint steps are the auxiliary
        task): (B, n_f, H, W)."""
        return self.goal_decoder(features)

    def predict_trajectory(
        self, features: list[torch.Tensor], waypoint_maps: torch.Tensor
    ) -> torch.Tensor:
        """Trajectory logits conditioned on goal and waypoint distance maps.

        waypoint_maps: (B, n_w, H, W) -> (B, n_f, H, W), or K samples per window
        (B, K, n_w, H, W) -> (B, K, n_f, H, W), decoded in one batched pass.
        """
        if waypoint_maps.dim() == 4:
            return self.trajectory_decoder(features, waypoint_maps)
        b, k = waypoint_maps.shape[:2]
        logits = self.trajectory_decoder(features, waypoint_maps.flatten(0, 1))  # (B*K, n_f, H, W)
        return logits.unflatten(0, (b, k))

    def forward(
        self, scene_and_past: torch.Tensor, waypoint_maps: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """(B, C + n_p, H, W), (B, n_w, H, W) -> goal logits, trajectory logits, each (B, n_f, H, W)."""
        features = self.encode(scene_and_past)
        return self.predict_goals(features), self.predict_trajectory(features, waypoint_maps)


HEADS = ("goal_decoder.head.", "trajectory_decoder.head.")
"""The only parameters whose shape depends on the horizon: one output map per future step."""


def weights_for_horizon(state: dict[str, torch.Tensor], pred_len: int) -> dict[str, torch.Tensor]:
    """A trained Y-net's weights as the starting point of a model for another horizon `pred_len`.

    Every layer is kept as it is (the waypoints are the same fractions of any horizon, so the
    trajectory decoder's conditioning channels keep their meaning); each head's map for future
    step t is the trained head's map at the same fraction of the horizon, rounded up: step
    ceil((t + 1) * n_src / pred_len) - 1, so the goal maps to the goal.
    """
    sources = {name.rsplit(".", 1)[0] for name in state if name.startswith(HEADS)}
    if len(sources) != len(HEADS):
        raise ValueError(f"expected the parameters of both heads {HEADS}, found {sorted(sources)}")
    out = {}
    for name, value in state.items():
        if name.startswith(HEADS):
            n_src = value.shape[0]
            steps = [-(-(t + 1) * n_src // pred_len) - 1 for t in range(pred_len)]  # integer ceil
            value = value[torch.tensor(steps)]  # (pred_len, ...) as the head's (n_src, ...)
        out[name] = value.clone()
    return out
