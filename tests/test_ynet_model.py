import math

import pytest
import torch
import torch.nn.functional as F
from torch.testing import assert_close
from torch.utils._python_dispatch import TorchDispatchMode
from torch.utils._pytree import tree_leaves

import ynet.model

from ynet.heatmaps import distance_maps, gaussian_heatmaps, scene_and_past
from ynet.loss import ynet_loss
from ynet.model import Decoder, Encoder, YNet, YNetConfig, shared_input_conv, weights_for_horizon
from ynet.sampling import SamplingOptions, predict, softargmax

torch.set_num_threads(1)

# 5 levels like the real model, few channels: maps must be multiples of 32
TINY = YNetConfig(
    obs_len=3,
    pred_len=6,
    semantic_classes=2,
    encoder_channels=(8, 16, 16, 16, 16),
    decoder_channels=(16, 16, 16, 16, 8),
    waypoints=(2, 5),
)
# 3 levels: maps must be multiples of 8
SHALLOW = YNetConfig(
    obs_len=2,
    pred_len=4,
    semantic_classes=3,
    encoder_channels=(4, 8, 8),
    decoder_channels=(8, 8, 4),
    waypoints=(1, 3),
)


def n_params(module):
    return sum(p.numel() for p in module.parameters())


def test_parameter_count_matches_authors():
    sdd = YNetConfig(obs_len=5, pred_len=30, semantic_classes=6, waypoints=(14, 29))
    assert n_params(YNet(sdd)) == 1_654_022


def test_config_checks():
    with pytest.raises(ValueError, match="goal"):
        YNetConfig(pred_len=30, waypoints=(14, 28))
    with pytest.raises(ValueError, match="increasing"):
        YNetConfig(pred_len=30, waypoints=(29, 14))
    with pytest.raises(ValueError, match="decoder_channels"):
        YNetConfig(decoder_channels=(64, 32))
    assert TINY.in_channels == 5 and TINY.n_waypoints == 2


@pytest.mark.parametrize("cfg,h,w", [(TINY, 64, 96), (SHALLOW, 24, 40)])
def test_module_shapes(cfg, h, w):
    torch.manual_seed(0)
    b, levels = 2, len(cfg.encoder_channels)
    x = torch.rand(b, cfg.in_channels, h, w)
    features = Encoder(cfg)(x)
    assert [f.shape for f in features] == [
        (b, c, h // 2**i, w // 2**i) for i, c in enumerate([*cfg.encoder_channels, cfg.encoder_channels[-1]])
    ]
    assert len(features) == levels + 1
    goal = Decoder(cfg)(features)
    assert goal.shape == (b, cfg.pred_len, h, w)
    cond = torch.rand(b, cfg.n_waypoints, h, w)
    assert Decoder(cfg, n_cond=cfg.n_waypoints)(features, cond).shape == (b, cfg.pred_len, h, w)
    with pytest.raises(ValueError, match="conditioning"):
        Decoder(cfg)(features, cond)

    model = YNet(cfg)
    goal_logits, traj_logits = model(x, cond)
    assert goal_logits.shape == traj_logits.shape == (b, cfg.pred_len, h, w)
    k = 3
    many = model.predict_trajectory(model.encode(x), torch.rand(b, k, cfg.n_waypoints, h, w))
    assert many.shape == (b, k, cfg.pred_len, h, w)


def test_batched_samples_equal_one_at_a_time():
    """K samples per window through the shared-skip path == each sample decoded on its own."""
    torch.manual_seed(0)
    model = YNet(SHALLOW)
    x = torch.rand(2, SHALLOW.in_channels, 16, 24)
    maps = torch.rand(2, 4, SHALLOW.n_waypoints, 16, 24) * 2  # (B, K, n_w, H, W)
    features = model.encode(x)
    batched = model.predict_trajectory(features, maps)
    for k in range(4):
        assert_close(batched[:, k], model.predict_trajectory(features, maps[:, k]), rtol=1e-4, atol=1e-5)


def test_shared_input_conv_equals_concatenated_conv():
    torch.manual_seed(0)
    conv = torch.nn.Conv2d(3 + 4 + 2, 5, 3, padding=1)
    up, skip, cond = torch.rand(6, 3, 8, 8), torch.rand(2, 4, 8, 8), torch.rand(6, 2, 8, 8)
    out = shared_input_conv(conv, skip, before=up, after=cond)  # K = 3 samples per window
    expected = conv(torch.cat([up, skip.repeat_interleave(3, 0), cond], 1))
    assert_close(out, expected, rtol=1e-5, atol=1e-5)


def test_one_waypoint_sampled_decoder_stays_channels_last():
    """A single conditioning map is a 1-channel tensor, NCHW and channels_last at once; the
    K-sample trajectory decoder must still run (and return) channels_last when the encoder did,
    with the numbers of one sample at a time."""
    torch.manual_seed(0)
    one_waypoint = YNetConfig(obs_len=3, pred_len=6, semantic_classes=2,
                              encoder_channels=(8, 16, 16, 16, 16),
                              decoder_channels=(16, 16, 16, 16, 8), waypoints=(5,))
    model = YNet(one_waypoint).eval()
    x = torch.rand(2, one_waypoint.in_channels, 64, 64).contiguous(memory_format=torch.channels_last)
    maps = torch.rand(2, 3, 1, 64, 64)  # (B, K, n_w, H, W)
    seen = []
    hook = model.trajectory_decoder.blocks[-1].conv2.register_forward_hook(
        lambda module, inputs, output: seen.append(inputs[0]))
    with torch.inference_mode():
        features = model.encode(x)
        batched = model.predict_trajectory(features, maps)  # (B, K, n_f, H, W)
        hook.remove()
        for k in range(3):
            assert_close(batched[:, k], model.predict_trajectory(features, maps[:, k]),
                         rtol=1e-4, atol=1e-5)
    assert seen[0].shape[0] == 6 and seen[0].is_contiguous(memory_format=torch.channels_last)
    assert not seen[0].is_contiguous()


def test_channels_last_matches_contiguous():
    torch.manual_seed(0)
    model = YNet(TINY)
    x, cond = torch.rand(1, TINY.in_channels, 64, 64), torch.rand(1, 2, 64, 64)
    ref = model(x, cond)
    model_cl = model.to(memory_format=torch.channels_last)
    out = model_cl(x.contiguous(memory_format=torch.channels_last), cond)
    for a, b in zip(out, ref):
        assert_close(a, b, rtol=1e-4, atol=1e-4)


def test_loss_is_scaled_bce_of_both_decoders():
    g, t, target = torch.randn(2, 4, 8, 8), torch.randn(2, 4, 8, 8), torch.rand(2, 4, 8, 8) / 64
    loss = ynet_loss(g, t, target, loss_scale=1000.0)
    bce = lambda z: (-(target * F.logsigmoid(z) + (1 - target) * F.logsigmoid(-z))).mean()  # noqa: E731
    assert_close(loss.goal, 1000 * bce(g))
    assert_close(loss.trajectory, 1000 * bce(t))
    assert_close(loss.total, loss.goal + loss.trajectory)


def test_tiny_model_overfits_one_trajectory():
    """Training on one window makes the full inference (softargmax goal, CWS waypoint, trajectory
    decoder softargmax) land within a few pixels of it."""
    torch.manual_seed(1)
    h = w = 64
    model = YNet(TINY)
    # start the heads at the log prior of a one-pixel target, so 300 steps suffice
    for head in (model.goal_decoder.head, model.trajectory_decoder.head):
        torch.nn.init.constant_(head.bias, -8.0)
    s = torch.linspace(0, 1, TINY.obs_len + TINY.pred_len)
    track = torch.stack([10 + 40 * s, 50 - 30 * s], -1)[None]  # (1, 9, 2), straight, constant speed
    past, future = track[:, : TINY.obs_len], track[:, TINY.obs_len :]
    x = scene_and_past(torch.softmax(torch.randn(1, 2, h, w), 1), past)
    target = gaussian_heatmaps(future, h, w, sigma=3.0)
    waypoint_maps = distance_maps(future[:, list(TINY.waypoints)], h, w)
    opt = torch.optim.Adam(model.parameters(), lr=3e-3)
    for _ in range(300):
        loss = ynet_loss(*model(x, waypoint_maps), target).total
        opt.zero_grad()
        loss.backward()
        opt.step()

    with torch.no_grad():
        assert (softargmax(model(x, waypoint_maps)[1]) - future).norm(dim=-1).mean() < 2.0
    options = SamplingOptions(K_e=1, K_a=1, temperature=1.8)
    pred = predict(model, x, past[:, -1], options, torch.Generator().manual_seed(0))
    ade = (pred.trajectory[0, 0] - future[0]).norm(dim=-1).mean()
    fde = (pred.goals[0, 0] - future[0, -1]).norm()
    assert ade < 3.0, ade
    assert fde < 4.0, fde


def test_head_bias_starts_every_map_low_and_none_keeps_the_default():
    torch.manual_seed(0)
    low = YNet(YNetConfig(**{**TINY.__dict__, "head_bias": -15.0}))
    x = torch.rand(2, TINY.in_channels, 32, 32)
    cond = torch.rand(2, TINY.n_waypoints, 32, 32)
    goal_logits, trajectory_logits = low(x, cond)
    for logits in (goal_logits, trajectory_logits):
        assert logits.shape == (2, TINY.pred_len, 32, 32)
        assert abs(logits.mean().item() + 15.0) < 1.0
    assert torch.all(low.trajectory_decoder.head.bias == -15.0)
    torch.manual_seed(0)
    default = YNet(TINY)
    assert not torch.all(default.trajectory_decoder.head.bias == -15.0)
    assert default.trajectory_decoder.head.bias.abs().max() < 1.0


@pytest.mark.parametrize("pred_len, waypoints, goal_source", [(60, (29, 59), 29), (10, (4, 9), 29),
                                                              (5, (2, 4), 29), (30, (14, 29), 29)])
def test_weights_for_horizon_keep_every_layer_and_take_each_step_at_the_same_fraction(
        pred_len, waypoints, goal_source):
    torch.manual_seed(0)
    source = YNet(YNetConfig(pred_len=30, waypoints=(14, 29))).state_dict()
    moved = weights_for_horizon(source, pred_len)
    target = YNet(YNetConfig(pred_len=pred_len, waypoints=waypoints))
    target.load_state_dict(moved)  # every shape fits the other horizon's model
    for name, value in source.items():
        if ".head." in name:
            assert moved[name].shape[0] == pred_len
            assert torch.equal(moved[name][-1], value[goal_source])  # the goal's map is the goal's
            # step t of pred_len takes the source step at the same fraction of the horizon
            steps = [math.ceil((t + 1) * 30 / pred_len) - 1 for t in range(pred_len)]
            assert torch.equal(moved[name], value[torch.tensor(steps)])
        else:
            assert torch.equal(moved[name], value)
    if pred_len == 30:
        assert all(torch.equal(moved[k], source[k]) for k in source)  # the same horizon: a copy


def test_weights_for_horizon_need_both_heads():
    state = YNet(YNetConfig()).state_dict()
    del state["goal_decoder.head.weight"], state["goal_decoder.head.bias"]
    with pytest.raises(ValueError, match="both heads"):
        weights_for_horizon(state, 60)


class InputDtypes(TorchDispatchMode):
    """Records each dispatched op with the dtypes of its tensor inputs and of its output."""

    def __init__(self):
        super().__init__()
        self.seen = []

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        out = func(*args, **(kwargs or {}))
        tensors = [t for t in tree_leaves(args) if isinstance(t, torch.Tensor)]
        self.seen.append((str(func), {t.dtype for t in tensors},
                          out.dtype if isinstance(out, torch.Tensor) else None))
        return out


def test_under_cuda_autocast_the_decoder_upsamples_and_concatenates_in_its_dtype(monkeypatch):
    """`ynet.model.cuda_autocast_dtype` decides, and on the CPU it says None: nothing changes
    there. Here CPU autocast stands in for CUDA's (whose policy, unlike the CPU's, would run the
    upsampling in float32): the upsampling then runs on bfloat16 and no activation goes back to
    float32 (a float32 distance map would promote every concatenation
    with it), and the trajectory logits stay within bfloat16's rounding of the others."""
    torch.manual_seed(0)
    model = YNet(TINY).eval()
    x = torch.randn(2, TINY.in_channels, 64, 64)
    maps = torch.rand(2, 3, TINY.n_waypoints, 64, 64)  # float32, as distance_maps gives them
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16):
        features = model.encode(x)
        with InputDtypes() as before:
            reference = model.predict_trajectory(features, maps)
        monkeypatch.setattr(ynet.model, "cuda_autocast_dtype",
                            lambda t: torch.get_autocast_dtype("cpu"))
        with InputDtypes() as after:
            shortcut = model.predict_trajectory(features, maps)
    upsampled = [dtypes for op, dtypes, _ in after.seen if op.startswith("aten.upsample_bilinear2d")]
    assert len(upsampled) == len(TINY.decoder_channels) and all(d == {torch.bfloat16} for d in upsampled)
    def round_trips(seen):  # bfloat16 activations cast to float32 (for a concatenation, say)
        return [op for op, dtypes, out in seen
                if op.startswith(("aten.to.", "aten._to_copy.")) and dtypes == {torch.bfloat16}
                and out == torch.float32]

    assert round_trips(before.seen) and not round_trips(after.seen)
    assert_close(shortcut.float(), reference.float(), atol=0.05, rtol=0.02)
