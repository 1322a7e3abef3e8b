"""R-PECNet's roll-out variants (`pipeline.runners.baselines.rpecnet.VARIANTS`) and the diagnostic
stage `rpecnet_rollouts`: each variant's shape and what sets it apart (on stand-in models whose
calls are recorded, and on a small untrained PECNet), determinism under a seeded generator, the
default roll-out byte for byte as it was before the variants existed, the choice rule on
hand-made records, and the stage end to end on straight tracks. One thread."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
import torch
import yaml

from pipeline.studies import rpecnet_rollouts as rr
from pipeline.runners.baselines import common
from pipeline.models.constant_velocity import extrapolate
from pipeline.runners.baselines.pecnet import Pecnet, make_batch
from pipeline.runners.baselines.rpecnet import (INDEPENDENT, MEAN_FED_BACK, ORIGINAL_FRAME,
                                                SHARED_LATENT, VARIANTS, RecurrentPecnet, rollout)
from pipeline.data.window_table import load_windows, select_split
from pipeline.device import to_device
from pipeline.stages import rpecnet_rollouts as stage
from tests.test_baselines import N_PAST, TINY_PECNET, straight_tracks, window_table

torch.set_num_threads(1)
N_FUTURE = 3  # the stand-ins' and the small PECNet's horizon: 7 steps take 3 rounds, the last cut


def small_pecnet(seed: int = 0) -> Pecnet:
    """An untrained PECNet of horizon 3 (weights from `seed`): enough to exercise every path."""
    torch.manual_seed(seed)
    model = Pecnet(TINY_PECNET, N_PAST, N_FUTURE)
    model.net.eval()
    return model


def generator(seed: int = 0) -> torch.Generator:
    return torch.Generator().manual_seed(seed)


# ---------------------------------------------------------------------------------------------
# The headline roll-out is unchanged


def old_sample(model: Pecnet, past, groups, k, generator, batch_size=1024):
    """`Pecnet.sample` as it was before `latent` and `origin` existed, word for word."""
    model.net.eval()
    out = np.zeros((len(past), k, model.n_future, 2))
    with torch.no_grad():
        for index in common.group_batches(groups, batch_size):
            batch = make_batch(past[index], groups[index], model.config, device=model.device)
            samples = []
            for _ in range(k):
                z = model.config.sigma * to_device(
                    torch.randn(len(index), model.config.latent_dim, generator=generator,
                                device=generator.device), model.device)
                endpoint, path, _, _ = model.net(batch.past, batch.position, batch.mask, z=z)
                samples.append(torch.cat([path, endpoint[:, None]], dim=1))
            future = torch.stack(samples, dim=1).double().cpu().numpy()
            out[index] = future / model.config.data_scale + batch.origin[:, None, None]
    return out


def old_rollout(model: Pecnet, past, groups, k, n_future, generator):
    """`rpecnet.rollout` as it was before its variants, word for word (with `old_sample`)."""
    n, n_p = len(past), model.n_past
    track = np.repeat(past, k, axis=0)
    chain_groups = np.repeat(groups, k) * k + np.tile(np.arange(k), n)
    for _ in range(math.ceil(n_future / model.n_future)):
        step = old_sample(model, track[:, -n_p:], chain_groups, 1, generator)[:, 0]
        track = np.concatenate([track, step], axis=1)
    future = track[:, past.shape[1]: past.shape[1] + n_future]
    return future.reshape(n, k, n_future, 2)


def test_the_default_rollout_is_byte_identical_to_the_one_before_the_variants():
    model, arrays = small_pecnet(), straight_tracks(6, 7, seed=11)
    groups = common.co_occurrence_groups(arrays)
    before = old_rollout(model, arrays.past, groups, 4, 7, generator(3))
    now = rollout(model, arrays.past, groups, 4, 7, generator(3))
    explicit = RecurrentPecnet(model).predict(arrays, 4, generator(3), variant=INDEPENDENT)
    assert now.tobytes() == before.tobytes() and explicit.tobytes() == before.tobytes()
    assert RecurrentPecnet(model).predict(arrays, 4, generator(3)).tobytes() == before.tobytes()
    # ... and so is PECNet's own sampling, which the variants extended.
    assert (model.sample(arrays.past, groups, 3, generator(5)).tobytes()
            == old_sample(model, arrays.past, groups, 3, generator(5)).tobytes())


def test_given_latents_and_origins_are_what_sample_would_have_drawn_and_used():
    model, arrays = small_pecnet(), straight_tracks(4, 3, seed=12)
    groups = common.co_occurrence_groups(arrays)
    drawn = model.sample(arrays.past, groups, 1, generator(8))  # one batch, K = 1: one draw
    latent = model.draw_latent(len(arrays), 1, generator(8))  # the same draw, (N, 1, latent_dim)
    assert tuple(latent.shape) == (4, 1, TINY_PECNET.latent_dim)
    np.testing.assert_array_equal(model.sample(arrays.past, groups, 1, generator(99),
                                               latent=latent), drawn)
    np.testing.assert_array_equal(model.sample(arrays.past, groups, 1, generator(8),
                                               origin=arrays.past[:, 0].copy()), drawn)
    moved = model.sample(arrays.past, groups, 1, generator(8), origin=arrays.past[:, 0] - 100.0)
    assert not np.allclose(moved, drawn)  # another frame: another input, another output
    with pytest.raises(ValueError, match=r"latent must be \(N, k, latent_dim\)"):
        model.sample(arrays.past, groups, 2, generator(8), latent=latent)
    with pytest.raises(ValueError, match=r"origin must be \(N, 2\)"):
        model.sample(arrays.past, groups, 1, generator(8), origin=arrays.past[:2, 0])


# ---------------------------------------------------------------------------------------------
# Each variant: shape, determinism, what sets it apart


@pytest.mark.parametrize("variant", VARIANTS)
def test_every_variant_has_the_shape_and_is_determined_by_its_seed(variant):
    model, arrays = small_pecnet(), straight_tracks(6, 7, seed=13)
    rpecnet = RecurrentPecnet(model)
    pred = rpecnet.predict(arrays, 4, generator(0), variant=variant)
    assert pred.shape == (6, 4, 7, 2) and np.isfinite(pred).all()
    assert pred.tobytes() == rpecnet.predict(arrays, 4, generator(0), variant=variant).tobytes()
    assert not np.array_equal(pred, rpecnet.predict(arrays, 4, generator(1), variant=variant))
    assert pred[:, 0].std() > 0 and not np.allclose(pred[:, 0], pred[:, 1])  # K real samples


def test_an_unknown_variant_is_named():
    with pytest.raises(ValueError, match="unknown R-PECNet roll-out variant 'mean_fedback'"):
        rollout(small_pecnet(), straight_tracks(2, 3).past, np.zeros(2, int), 2, 7, generator(),
                variant="mean_fedback")


class RecordingModel:
    """Stands in for a PECNet of horizon 3: every sample is the constant-velocity path moved by
    the sample's own offset, sigma z[:2] with z drawn from `generator` or given (`latent`);
    records every call's inputs and output."""

    n_past, n_future, latent_dim = N_PAST, N_FUTURE, 2

    def __init__(self):
        self.calls = []

    def draw_latent(self, n, k, generator):
        return torch.randn(n, k, self.latent_dim, generator=generator)

    def sample(self, past, groups, k, generator, latent=None, origin=None):
        z = self.draw_latent(len(past), k, generator) if latent is None else latent
        out = (extrapolate(past, self.n_future)[:, None]
               + 10.0 * z.numpy()[:, :, None, :])  # (N, k, n_f', 2)
        self.calls.append({"past": past.copy(), "k": k, "latent": latent, "origin": origin,
                           "out": out})
        return out


def test_shared_latent_keeps_each_chains_z_for_every_round():
    arrays, stub = straight_tracks(3, 7, seed=14), RecordingModel()
    pred = rollout(stub, arrays.past, np.arange(3), 2, 7, generator(), variant=SHARED_LATENT)
    latents = [call["latent"] for call in stub.calls]
    assert len(latents) == 3 and latents[0].shape == (6, 1, 2)  # N k chains, one z each
    assert all(latent is latents[0] for latent in latents)
    # Every round adds the chain's one offset: chain (window 0, sample 1) is 10 z off each round's
    # constant-velocity continuation of its own input.
    offset = 10.0 * latents[0][1, 0].numpy()
    for call in stub.calls:
        np.testing.assert_allclose(call["out"][1, 0] - extrapolate(call["past"][1:2], 3)[0],
                                   np.tile(offset, (3, 1)), atol=1e-9)
    np.testing.assert_allclose(pred[0, 1, :3] - arrays.future[0, :3], np.tile(offset, (3, 1)),
                               atol=1e-9)
    rollout(independent := RecordingModel(), arrays.past, np.arange(3), 2, 7, generator())
    assert all(call["latent"] is None for call in independent.calls)  # drawn every round


def test_mean_fed_back_shares_the_mean_track_and_varies_only_the_last_round():
    arrays, stub = straight_tracks(3, 7, seed=15), RecordingModel()
    pred = rollout(stub, arrays.past, np.arange(3), 4, 7, generator(), variant=MEAN_FED_BACK)
    assert pred.shape == (3, 4, 7, 2) and len(stub.calls) == 3
    assert all(call["k"] == 4 and len(call["past"]) == 3 for call in stub.calls)  # one context
    means = [call["out"].mean(axis=1) for call in stub.calls]  # (N, 3, 2) per round
    for k in range(4):  # steps 0-5: the two rounds' means; step 6: round 3's own sample k
        np.testing.assert_allclose(pred[:, k, :6], np.concatenate(means[:2], axis=1))
        np.testing.assert_allclose(pred[:, k, 6], stub.calls[2]["out"][:, k, 0])
    np.testing.assert_allclose(stub.calls[1]["past"][:, -3:], means[0])  # the mean is fed back
    assert not np.allclose(pred[:, 0, 6], pred[:, 1, 6])


def test_original_frame_keeps_the_observed_windows_origin_every_round():
    arrays, stub = straight_tracks(3, 7, seed=16), RecordingModel()
    rollout(stub, arrays.past, np.arange(3), 2, 7, generator(), variant=ORIGINAL_FRAME)
    for call in stub.calls:  # chains as rows (window i, sample s) at i * 2 + s
        np.testing.assert_array_equal(call["origin"], np.repeat(arrays.past[:, 0], 2, axis=0))
    # On a PECNet: round 1's input starts at that origin anyway, so it is the headline's round 1;
    # from round 2 the inputs sit off the origin and the paths part.
    model, groups = small_pecnet(), common.co_occurrence_groups(arrays)
    slip = rollout(model, arrays.past, groups, 2, 7, generator(4), variant=ORIGINAL_FRAME)
    headline = rollout(model, arrays.past, groups, 2, 7, generator(4))
    np.testing.assert_array_equal(slip[:, :, :N_FUTURE], headline[:, :, :N_FUTURE])
    assert not np.allclose(slip[:, :, N_FUTURE:], headline[:, :, N_FUTURE:])


# ---------------------------------------------------------------------------------------------
# Scores and the choice


def test_best_of_k_scores_on_the_3_4_5_example():
    # tests/test_scoring.py's example: min-ADE (2, 0) -> 1, min-FDE (3, 0) -> 1.5: ratio 1.5.
    truth = np.array([[[1.0, 0.0], [2.0, 0.0]], [[3.0, 4.0], [6.0, 8.0]]])
    pred = np.array([[[[1.0, 0.0], [2.0, 4.0]], [[1.0, 3.0], [2.0, 3.0]]],
                     [[[0.0, 0.0], [0.0, 0.0]], [[3.0, 4.0], [6.0, 8.0]]]])
    assert rr.best_of_k_scores(pred, truth) == {"ade": 1.0, "fde": 1.5, "fde_over_ade": 1.5}
    exact = rr.best_of_k_scores(np.repeat(truth[:, None], 2, axis=1), truth)
    assert exact["ade"] == 0.0 and math.isnan(exact["fde_over_ade"])


def test_the_choice_is_the_ratio_nearest_the_target():
    record = {"independent": {"ade": 94.0, "fde": 184.0, "fde_over_ade": 184 / 94},  # 1.957
              "shared_latent": {"ade": 120.0, "fde": 330.0, "fde_over_ade": 2.75},  # 0.122 off
              "mean_fed_back": {"ade": 150.0, "fde": 450.0, "fde_over_ade": 3.0},  # 0.128 off
              "original_frame": {"ade": 0.0, "fde": 0.0, "fde_over_ade": float("nan")}}
    assert rr.choose_variant(record, 2.872) == ("shared_latent", pytest.approx(0.122))
    assert rr.choose_variant(record, 2.9)[0] == "mean_fed_back"  # 0.15 against 0.1
    tie = {"b": {"fde_over_ade": 2.5}, "a": {"fde_over_ade": 3.5}}
    assert rr.choose_variant(tie, 3.0) == ("b", 0.5)  # equal distances: the first listed
    with pytest.raises(ValueError, match="no variant with a finite FDE / ADE"):
        rr.choose_variant({"x": {"fde_over_ade": float("nan")}}, 2.9)


def test_unknown_variants_in_params_are_named():
    assert rr.check_variants(["mean_fed_back"]) == ["mean_fed_back"]
    with pytest.raises(ValueError, match=r"unknown roll-out\(s\) \['shared_z'\]"):
        rr.check_variants(["independent", "shared_z"])


# ---------------------------------------------------------------------------------------------
# The stage end to end


def test_stage_chooses_on_validation_and_scores_only_the_chosen_on_test(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = dataclasses.replace(TINY_PECNET, epochs=2)
    Pecnet.fit(straight_tracks(8, N_FUTURE, seed=1), straight_tracks(4, N_FUTURE, seed=2), config,
               tmp_path / "pecnet_tf3", seed=0)
    arrays = straight_tracks(12, 7, seed=7)
    (tmp_path / "hw").mkdir()
    window_table(arrays, ["train"] * 4 + ["val"] * 5 + ["test"] * 3).to_parquet("hw/tf7.parquet")
    params = {"windows": {"n_past": N_PAST}, "runtime": {"device": "cpu", "max_minutes": 0},
              "evaluate_baseline": {"k": 3, "split": "test", "rounds": 1, "seed": 0, "threads": 1,
                                    "epoch_selection": "raw"},
              "rpecnet_rollouts": {"variants": list(VARIANTS), "horizons": [7], "k": 3, "seed": 0,
                                   "split_for_choice": "val", "target_fde_over_ade": 2.872,
                                   "threads": 1}}
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    stage.main(["--horizon-windows", "hw", "--checkpoint-dir", "pecnet_tf3", "--out", "m.json"])
    record = json.loads((tmp_path / "m.json").read_text())
    assert record["variants"] == list(VARIANTS) and record["k"] == 3
    assert record["device"].startswith("cpu") and record["epoch_selection"] == "raw"
    tf7 = record["horizons"]["tf7"]
    choice = tf7["choice"]
    assert choice["split"] == "val" and choice["n_windows"] == 5
    assert list(choice["variants"]) == list(VARIANTS)
    for scores in choice["variants"].values():
        assert scores["fde_over_ade"] == pytest.approx(scores["fde"] / scores["ade"])
    assert (tf7["chosen"], tf7["distance_to_target"]) == rr.choose_variant(choice["variants"],
                                                                           2.872)
    assert set(tf7["test"]) == {"variant", "n_windows", "ade", "fde", "fde_over_ade", "seconds"}
    assert tf7["test"]["variant"] == tf7["chosen"] and tf7["test"]["n_windows"] == 3
    # The validation scores are those of the roll-out on the val windows, seed 0.
    model = RecurrentPecnet.load(tmp_path / "pecnet_tf3")
    val = select_split(load_windows(tmp_path / "hw" / "tf7.parquet", N_PAST, 7), "val")
    again = rr.best_of_k_scores(model.predict(val, 3, generator(0), variant=MEAN_FED_BACK),
                                val.future)
    assert {k: choice["variants"][MEAN_FED_BACK][k] for k in again} == again
