"""What `bench/bench_profiles.py` times and counts: the input shape of a training step (the
runner's `plan_input_shape`), a warm-up that meets every timed shape, and the FLOP counts behind
its TFLOP/s."""

from types import SimpleNamespace

import numpy as np
import torch

from bench.bench_profiles import scoring_flops, training_flops, warmup_plan, warmup_rows
from pipeline.config.ynet import YnetSettings
from pipeline.runners.ynet_training import plan_input_shape
from ynet.model import YNetConfig


def scene(height, width):
    return SimpleNamespace(semantic=torch.zeros(6, height, width))


def test_a_plan_entrys_input_shape_pads_and_turns_the_map():
    settings = YnetSettings()
    scenes = [scene(100, 70)]
    rows = np.arange(3)
    assert plan_input_shape([(0, 0, False, rows)], scenes, settings) == (3, 128, 96)
    assert plan_input_shape([(0, 1, True, rows)], scenes, settings) == (3, 96, 128)
    assert plan_input_shape([(0, 2, False, rows[:1])], scenes, settings) == (1, 128, 96)
    cropped = YnetSettings(crop=64)
    assert plan_input_shape([(0, 1, False, rows)], scenes, cropped) == (3, 64, 64)


def test_the_warm_up_meets_every_timed_shape_once():
    entries = ["a", "b", "c", "d", "e"]
    shapes = [(8, 128, 96), (8, 96, 128), (8, 128, 96), (3, 128, 96), (8, 96, 128)]
    assert warmup_plan(entries, shapes) == ["a", "b", "d"]
    assert warmup_rows(32, 4) == [4]
    assert warmup_rows(10, 4) == [4, 2]
    assert warmup_rows(3, 4) == [3]


def test_flop_counts_scale_with_the_work():
    config = YNetConfig(obs_len=5, pred_len=30, waypoints=(14, 29))
    forward, both = training_flops(config, (2, 64, 64))
    assert 2.5 * forward < both < 3.5 * forward  # the backward pass: about twice the forward
    assert training_flops(config, (4, 64, 64)) == (2 * forward, 2 * both)
    assert training_flops(config, (2, 128, 64))[0] == 2 * forward
    one, twenty = (scoring_flops(config, 1, 64, 64, k, 8) for k in (1, 20))
    assert one == forward / 2 < twenty < 20 * one  # one encoding shared by the samples
    assert scoring_flops(config, 2, 64, 64, 20, 8) == 2 * twenty
