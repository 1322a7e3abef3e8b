"""Same params, same numbers: every model trained and scored twice from scratch, in separate
folders, with the same seed, gives bit-identical weights and metrics (on one CPU; other CPUs may
round differently, which is why the report's spreads are over evaluation rounds of one model)."""

import numpy as np
import torch

from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.ynet import YnetSettings
from pipeline.data.ynet_data import group_by_scene
from pipeline.device import generator
from pipeline.runners.baselines import Baseline
from pipeline.harness.model_runs import score_rounds
from pipeline.models import window_set
from pipeline.runners.baselines.pecnet import Pecnet
from pipeline.runners.baselines.rpecnet import RecurrentPecnet
from pipeline.runners.baselines.sgan import SocialGan
from pipeline.runners.segmentation import fingerprint
from pipeline.runners.segmentation import train as train_unet
from pipeline.runners.ynet_scoring import evaluation_sequence, load_model
from pipeline.runners.ynet_training import train
from tests.test_baselines import TINY_PECNET, TINY_SGAN, state_of, straight_tracks
from tests.test_segmentation import tiny_params, tiny_scenes
from tests.test_train_ynet import MAPS, N_PAST, SETTINGS, SIZES, TTST, arrays


def without_times(node):
    """A metrics record without its wall-clock entries (the only ones that may differ)."""
    if isinstance(node, dict):
        return {k: without_times(v) for k, v in node.items() if "seconds" not in k}
    if isinstance(node, list):
        return [without_times(v) for v in node]
    return node


def assert_same_tensors(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for name in a:
        torch.testing.assert_close(a[name], b[name], rtol=0, atol=0, msg=name)


def test_ynet_trained_and_scored_twice_is_bit_identical(tmp_path):
    torch.set_num_threads(1)
    test = arrays(3, "test", 2)
    params = EvalParams(k_e=3, k_a=2, rounds=2, ablation_rounds=1, ka_grid_k_e=[3], ka_grid_k_a=[1, 2],
                        batch_size=2)
    runs = []
    for name in ("a", "b"):
        folder = tmp_path / name
        summary = train(arrays(6, "train", 0), arrays(2, "val", 1), MAPS, SIZES, YnetSettings(**SETTINGS),
                        N_PAST, folder / "last.pt", folder / "best.pt", folder / "history.csv")
        model, settings = load_model(folder / "best.pt")
        scenes = group_by_scene(test, MAPS, SIZES, settings.resize)
        metrics = evaluation_sequence(model, scenes, settings, params, TTST, CwsParams(), test.future)
        runs.append((without_times(summary), model.state_dict(), without_times(metrics)))
    (summary_a, weights_a, metrics_a), (summary_b, weights_b, metrics_b) = runs
    assert summary_a == summary_b and metrics_a == metrics_b
    assert_same_tensors(weights_a, weights_b)
    assert (tmp_path / "a" / "best.pt").read_bytes() == (tmp_path / "b" / "best.pt").read_bytes()


def test_baselines_trained_and_scored_twice_are_bit_identical(tmp_path):
    torch.set_num_threads(1)
    train_set, val_set = straight_tracks(16, 5, seed=7), straight_tracks(4, 5, seed=8)
    test = straight_tracks(6, 5, seed=9)
    for cls, config in ((SocialGan, TINY_SGAN), (Pecnet, TINY_PECNET)):
        fitted, scores = [], []
        for name in ("a", "b"):
            model = cls.fit(train_set, val_set, config, tmp_path / f"{cls.name}_{name}", seed=0)
            fitted.append(state_of(model))
            scores.append(without_times(score_rounds(
                cls.name, Baseline(cls.name), window_set(test, "train", with_future=False),
                test.future, tmp_path / f"{cls.name}_{name}", k=4, rounds=2, seed=3)))
        assert_same_tensors(*fitted)
        assert scores[0] == scores[1], cls.name
        assert scores[0]["ade"]["mean"] > 0 and len(scores[0]["per_round"]) == 2
    # R-PECNet rolls the fitted PECNet out
    model = RecurrentPecnet.load(tmp_path / "pecnet_a")
    once, again = (model.predict(test, 4, generator(torch.device("cpu"), 5)) for _ in range(2))
    np.testing.assert_array_equal(once, again)


def test_the_segmentation_unet_trained_twice_is_bit_identical(tmp_path):
    torch.set_num_threads(1)
    params, scenes = tiny_params(), tiny_scenes()
    run_id = fingerprint(params, ["a", "b"], scenes)
    first, log_a = train_unet(scenes, params, tmp_path / "a.pt", run_id, progress=False)
    second, log_b = train_unet(scenes, params, tmp_path / "b.pt", run_id, progress=False)
    assert [r["loss"] for r in log_a] == [r["loss"] for r in log_b]
    assert_same_tensors(first.state_dict(), second.state_dict())
