"""No code path creates a tensor on a fixed device while its inputs live elsewhere.

Under `with torch.device("meta")` every factory call that forgot `device=` makes a meta tensor, and
mixing it with the CPU inputs fails loudly; a GPU is not needed to find such calls. Modules and
optimiser state are created before entering the block (their creation is not what is tested).
Each result must also equal the same call's outside the block: a stray meta tensor that some op
accepts silently (a meta boolean mask, say) would change it. The baselines' and the segmentation's
steps have the same test beside their own tests.
"""

import copy

import numpy as np
import pytest
import torch

from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.ynet import YnetSettings
from pipeline.runners.ynet_scoring import predict_scenes, qualitative, sampling_options
from pipeline.runners.ynet_training import epoch_plan, train_epoch, validate
from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import group_by_scene
from ynet.model import YNet
from tests.test_train_ynet import TTST

N_PAST, N_FUTURE = 3, 4
SETTINGS = dict(resize=0.25, epochs=1, batch_size=2, learning_rate=1e-3, augmentations=2,
                kernel_size=7, sigma=1.5, waypoints=[1, 3], encoder_channels=[4, 4, 8, 8, 8],
                decoder_channels=[8, 8, 8, 4, 4], seed=0, threads=1, head_bias=-5.0)


def scenes(n: int, resize: float):
    rng = np.random.default_rng(n)
    xy = rng.uniform(40, 120, size=(n, 1, 2)) + np.arange(N_PAST + N_FUTURE)[None, :, None] * 6.0
    arrays = WindowArrays(past=xy[:, :N_PAST], future=xy[:, N_PAST:], window_id=np.arange(n),
                          scene_id=np.array(["gates_0"] * n), track_id=np.arange(n),
                          first_frame=np.zeros(n), split=np.array(["train"] * n))
    maps = {"gates_0": np.full((6, 60, 68), 1 / 6, np.float32)}  # padded to 64 x 96
    return group_by_scene(arrays, maps, {"gates_0": (240, 272)}, resize), arrays


@pytest.fixture(params=[(0, False), (32, False), (32, True)],
                ids=["whole scene", "crops", "crops, bf16"])
def setup(request):
    torch.manual_seed(0)
    crop, mixed = request.param
    settings = YnetSettings(**SETTINGS, crop=crop, crop_lead_steps=1.0, bf16=mixed,
                            lr_schedule="cosine" if mixed else "constant")
    model = YNet(settings.model_config(N_PAST, N_FUTURE))
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
    train_scenes, _ = scenes(4, settings.resize)
    rng = np.random.default_rng(0)
    # one step outside the block: Adam creates its `step` counters on the default device
    train_epoch(model, optimizer, train_scenes, settings, epoch_plan(train_scenes, settings, rng)[:1],
                1, [])
    return model, optimizer, settings, train_scenes, rng


def test_training_epoch_and_validation(setup):
    model, optimizer, settings, train_scenes, rng = setup
    plan = epoch_plan(train_scenes, settings, rng)
    twin = copy.deepcopy(model)
    twin_optimizer = torch.optim.Adam(twin.parameters(), lr=1e-3)
    twin_optimizer.load_state_dict(copy.deepcopy(optimizer.state_dict()))
    with torch.device("meta"):
        loss = train_epoch(model, optimizer, train_scenes, settings, plan, 2, [])
        scores = validate(model, train_scenes, settings)
    assert np.isfinite(loss) and np.isfinite(scores["val_ade"])
    assert loss == train_epoch(twin, twin_optimizer, train_scenes, settings, plan, 2, [])
    assert scores == validate(twin, train_scenes, settings)
    assert all(p.device.type == "cpu" for p in model.parameters())


@pytest.mark.parametrize("use_ttst, use_cws, k_a", [(True, True, 2), (False, True, 1),
                                                     (False, False, 1), (True, False, 1)])
def test_prediction_with_every_sampler(setup, use_ttst, use_cws, k_a):
    model, _, settings, _, _ = setup
    test_scenes, arrays = scenes(3, settings.resize)
    model.eval()
    options = sampling_options(3, k_a, TTST, CwsParams(), use_ttst, use_cws)
    params = EvalParams(k_e=3, k_a=k_a, batch_size=2, chunk_size=2)
    def run():
        return predict_scenes(model, test_scenes, settings, options, 0, params, len(arrays),
                              "meta", settings.crop, settings.crop_lead_steps)

    with torch.device("meta"):
        paths, goals = run()
    assert np.isfinite(paths).all() and np.isfinite(goals).all()
    expected_paths, expected_goals = run()
    np.testing.assert_array_equal(paths, expected_paths)
    np.testing.assert_array_equal(goals, expected_goals)
    assert paths.shape == (3, 3 * k_a, N_FUTURE, 2)


def test_qualitative_figure_arrays(setup):
    model, _, settings, _, _ = setup
    test_scenes, _ = scenes(2, settings.resize)
    model.eval()
    image = np.zeros((256, 256, 3), np.uint8)
    options = sampling_options(3, 1, TTST, CwsParams(), True, True)
    with torch.device("meta"):
        arrays = qualitative(model, test_scenes[0], 0, settings, options, image, 0)
    assert np.isfinite(arrays["goal_heatmap"]).all() and arrays["predictions"].shape[-1] == 2
    expected = qualitative(model, test_scenes[0], 0, settings, options, image, 0)
    for key, value in expected.items():
        np.testing.assert_array_equal(arrays[key], value)
