"""Y-net training and evaluation stages on a tiny synthetic scene."""

import dataclasses
import os
import signal
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.ttst import TtstParams
from pipeline.config.ynet import YnetSettings
from pipeline.runners import ynet_training as train_ynet

from pipeline.harness.metrics import window_errors
from pipeline.runners.ynet_scoring import (Sampling, evaluate, evaluation_sequence, load_model,
                                           predict_samplings, predict_scenes, sampling_options,
                                           sequence_settings, setting_samplings)
from pipeline.runners.ynet_training import run_fingerprint, scale_waypoints, train
from pipeline.preemption import Preemption, StopRequested
from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import group_by_scene, window_inputs
from pipeline.device import CPU, generator
from ynet.config import upstream_max_distance
from ynet.sampling import predict
from ynet.segmentation import PAD_CLASS

N_PAST, N_FUTURE = 3, 4


def arrays(n: int, split: str, seed: int) -> WindowArrays:
    """Agents walking right at 8 px/step across a 256 x 256 px (original) scene."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(40, 120, size=(n, 1, 2))
    steps = np.arange(N_PAST + N_FUTURE)[None, :, None] * np.array([8.0, 0.0])
    xy = start + steps
    return WindowArrays(past=xy[:, :N_PAST], future=xy[:, N_PAST:], window_id=np.arange(n),
                        scene_id=np.array(["gates_0"] * n), track_id=np.arange(n),
                        first_frame=np.zeros(n), split=np.array([split] * n))


SETTINGS = dict(resize=0.25, epochs=2, batch_size=2, learning_rate=1e-3, augmentations=2,
                kernel_size=7, sigma=1.5, waypoints=[1, 3], encoder_channels=[4, 4, 8, 8, 8],
                decoder_channels=[8, 8, 8, 4, 4], seed=3, threads=1)
MAPS = {"gates_0": np.full((6, 64, 64), 1 / 6, np.float32)}
TTST = TtstParams(temperature=1.8, rel_threshold=0.002)  # the authors' long-term SDD values
SIZES = {"gates_0": (256, 256)}


def run(tmp_path, epochs=None):
    settings = YnetSettings(**SETTINGS)
    summary = train(arrays(6, "train", 0), arrays(2, "val", 1), MAPS, SIZES, settings, N_PAST,
                    tmp_path / "last.pt", tmp_path / "best.pt", tmp_path / "history.csv", epochs)
    return summary, torch.load(tmp_path / "last.pt", weights_only=True)["state"]["model"]


def test_resume_gives_the_same_weights_as_an_uninterrupted_run(tmp_path):
    torch.set_num_threads(1)
    summary, straight = run(tmp_path / "a")
    run(tmp_path / "b", epochs=1)  # "interrupted" after epoch 1
    resumed_summary, resumed = run(tmp_path / "b")
    assert summary["epochs"] == resumed_summary["epochs"] == 2
    for name in straight:
        torch.testing.assert_close(straight[name], resumed[name], rtol=0, atol=0)
    assert (tmp_path / "a" / "history.csv").read_text().count("\n") == 3


@pytest.mark.parametrize("how", ["sigterm", "budget"])
def test_stopped_mid_epoch_then_resumed_gives_the_same_weights(tmp_path, monkeypatch, how):
    """A real SIGTERM (or a spent time budget) in the middle of epoch 2 checkpoints the epoch so
    far and raises; the next call resumes at that step and ends with the uninterrupted weights."""
    torch.set_num_threads(1)
    _, straight = run(tmp_path / "a")
    steps_per_epoch = 6  # 6 train windows, batches of 2, 2 augmentations
    losses_seen = []
    real_loss = train_ynet.ynet_loss

    def loss_then_stop(*args, **kwargs):
        losses_seen.append(1)
        if how == "sigterm" and len(losses_seen) == steps_per_epoch + 2:
            os.kill(os.getpid(), signal.SIGTERM)  # arrives during epoch 2's second step
        return real_loss(*args, **kwargs)

    monkeypatch.setattr(train_ynet, "ynet_loss", loss_then_stop)
    # budget: 1 minute, on a clock that jumps 2 minutes once epoch 2 has taken two steps
    preemption = Preemption(max_minutes=1 if how == "budget" else 0,
                            clock=lambda: 120.0 * (len(losses_seen) >= steps_per_epoch + 2))
    folder = tmp_path / "b"
    with preemption, pytest.raises(StopRequested) as stopped:
        train(arrays(6, "train", 0), arrays(2, "val", 1), MAPS, SIZES, YnetSettings(**SETTINGS),
              N_PAST, folder / "last.pt", folder / "best.pt", folder / "history.csv",
              preemption=preemption)
    assert stopped.value.exit_code == (143 if how == "sigterm" else 75)
    saved = torch.load(folder / "last.pt", weights_only=True)
    assert saved["epoch"] == 1 and len(saved["position"]["losses"]) == 2
    monkeypatch.undo()
    summary, resumed = run(folder)
    assert summary["epochs"] == 2
    for name in straight:
        torch.testing.assert_close(straight[name], resumed[name], rtol=0, atol=0)
    assert ((tmp_path / "a" / "history.csv").read_text().splitlines()[1].split(",")[:2]
            == (folder / "history.csv").read_text().splitlines()[1].split(",")[:2])


def test_time_before_a_mid_epoch_stop_counts_in_train_seconds(tmp_path, monkeypatch):
    """A mid-epoch checkpoint keeps the time the epoch took so far (it used to keep only the
    finished epochs', so a paper run advanced in 10-minute pieces reported a few seconds)."""
    readings = iter(range(0, 10_000, 10))  # a clock that moves 10 s per reading
    monkeypatch.setattr(train_ynet, "time", SimpleNamespace(perf_counter=lambda: next(readings)))
    steps = []
    real_loss = train_ynet.ynet_loss

    def loss_then_stop(*args, **kwargs):
        steps.append(1)
        if len(steps) == 6 + 2:  # epoch 2's second step (6 steps per epoch)
            os.kill(os.getpid(), signal.SIGTERM)
        return real_loss(*args, **kwargs)

    monkeypatch.setattr(train_ynet, "ynet_loss", loss_then_stop)
    folder = tmp_path / "b"
    with Preemption() as preemption, pytest.raises(StopRequested):
        train(arrays(6, "train", 0), arrays(2, "val", 1), MAPS, SIZES, YnetSettings(**SETTINGS),
              N_PAST, folder / "last.pt", folder / "best.pt", folder / "history.csv",
              preemption=preemption)
    progress = torch.load(folder / "last.pt", weights_only=True)["state"]["progress"]
    assert progress["seconds"] > progress["history"][-1]["seconds"] > 0


def test_a_finished_run_rerun_restores_deleted_outputs(tmp_path):
    """DVC deletes model and history before re-running; a resumed finished run writes them again."""
    torch.set_num_threads(1)
    model_path, history_path = tmp_path / "out" / "model.pt", tmp_path / "out" / "history.csv"

    def train_once():
        train(arrays(6, "train", 0), arrays(2, "val", 1), MAPS, SIZES, YnetSettings(**SETTINGS), N_PAST,
              tmp_path / "ckpt" / "last.pt", model_path, history_path)

    train_once()
    model, history = model_path.read_bytes(), history_path.read_text()
    model_path.unlink()
    history_path.unlink()
    train_once()
    assert model_path.read_bytes() == model
    assert history_path.read_text() == history


def test_a_checkpoint_of_other_settings_is_not_resumed(tmp_path, capsys):
    torch.set_num_threads(1)
    run(tmp_path / "b", epochs=1)  # an interrupted run with the old settings
    other = YnetSettings(**{**SETTINGS, "learning_rate": 5e-4})

    def train_other(folder):
        train(arrays(6, "train", 0), arrays(2, "val", 1), MAPS, SIZES, other, N_PAST,
              folder / "last.pt", folder / "best.pt", folder / "history.csv")
        return torch.load(folder / "last.pt", weights_only=True)["state"]["model"]

    capsys.readouterr()
    restarted = train_other(tmp_path / "b")
    assert "starting afresh" in capsys.readouterr().out
    straight = train_other(tmp_path / "a")
    for name in straight:
        torch.testing.assert_close(straight[name], restarted[name], rtol=0, atol=0)


def trained_and_test_scenes(tmp_path):
    """A model trained by `run` (one thread), three test windows and their scene, ready to score."""
    torch.set_num_threads(1)
    run(tmp_path)
    model, settings = load_model(tmp_path / "best.pt")
    test = arrays(3, "test", 2)
    return model, settings, test, group_by_scene(test, MAPS, SIZES, settings.resize)


def test_evaluation_is_bit_identical_for_a_fixed_checkpoint(tmp_path):
    model, settings, test, scenes = trained_and_test_scenes(tmp_path)
    options = sampling_options(3, 2, TTST, CwsParams(), True, True)
    params = EvalParams(k_e=3, k_a=2, rounds=2, batch_size=2)
    first = evaluate(model, scenes, settings, options, params, test.future, 2, "a")
    second = evaluate(model, scenes, settings, options, params, test.future, 2, "b")
    assert first == second
    assert first["ade"]["mean"] > 0 and first["k_e"] == 3 and first["k_a"] == 2
    assert first["fde_joint"]["mean"] >= first["fde"]["mean"]
    # each round is the shared metric of that round's own samples (seed params.seed + r) ...
    for r, scores in enumerate(first["per_round"]):
        paths, goals = predict_scenes(model, scenes, settings, options, params.seed + r, params,
                                      len(test.future), "check")
        errors = window_errors(paths, test.future, goals)
        assert (scores["ade"], scores["fde"]) == (float(errors.ade.mean()), float(errors.fde.mean()))
    assert first["ade"]["mean"] == np.mean([r["ade"] for r in first["per_round"]])
    # ... and other seeds sample other futures
    reseeded = evaluate(model, scenes, settings, options, dataclasses.replace(params, seed=7),
                        test.future, 2, "c")
    assert reseeded["per_round"] != first["per_round"]


def test_the_grid_cell_of_the_main_setting_equals_sampling_it_afresh(tmp_path):
    """The K_a grid takes its (k_e, k_a) = main cell from the main result's first round."""
    model, settings, test, scenes = trained_and_test_scenes(tmp_path)
    params = EvalParams(k_e=3, k_a=1, rounds=2, ablation_rounds=0, ka_grid_k_e=[3], ka_grid_k_a=[1, 2],
                        batch_size=2)
    result = evaluation_sequence(model, scenes, settings, params, TTST, CwsParams(), test.future)
    for cell in result["ka_grid"]:
        options = sampling_options(cell["k_e"], cell["k_a"], TTST, CwsParams(), True, True)
        assert cell == evaluate(model, scenes, settings, options, params, test.future, 1, "fresh")
    assert result["ka_grid"][0]["per_round"] == result["main"]["per_round"][:1]


def test_the_sequence_samples_each_setting_once_per_round():
    """What `evaluation_sequence` samples (`sequence_settings`, the benches' list too): the main
    rounds, the ablation rows, and every grid cell but the main one, seeded round by round."""
    params = EvalParams(k_e=3, k_a=1, rounds=2, ablation_rounds=1, ka_grid_k_e=[2, 3],
                        ka_grid_k_a=[1, 2], seed=7)
    scored = sequence_settings(params, TTST, CwsParams())
    assert [(s.name, s.rounds) for s in scored] == [
        ("main", 2), ("none", 1), ("cws", 1), ("K_e=2 K_a=1", 1), ("K_e=2 K_a=2", 1), ("K_e=3 K_a=2", 1)]
    assert [(s.options.use_ttst, s.options.use_cws) for s in scored[:3]] == [
        (True, True), (False, False), (False, True)]
    assert [s.seed for s in setting_samplings(scored, params.seed)] == [7, 8, 7, 7, 7, 7, 7]
    assert [s.name for s in sequence_settings(params, TTST, CwsParams(), extras=False)] == ["main"]


def separate_pass(model, scenes, settings, options, seed, params, n_windows):
    """One sampling over every window with `ynet.sampling.predict` (encoder included), batch after
    batch: what scoring did before it encoded each batch once for all samplings."""
    draws = generator(CPU, seed)
    paths = np.zeros((n_windows, options.K, N_FUTURE, 2))
    goals = np.zeros((n_windows, options.K, 2))
    for scene in scenes:
        for start in range(0, len(scene), params.batch_size):
            past = scene.past[start:start + params.batch_size]
            inputs, origin = window_inputs(scene.semantic, past, settings.max_distance, 0, PAD_CLASS)
            out = predict(model, inputs, past[:, -1] - origin, options, draws, settings.max_distance,
                          params.chunk_size, params.bf16)
            rows = scene.index[start:start + params.batch_size]
            paths[rows] = (out.trajectory + origin[:, None, None]).numpy() / settings.resize
            goals[rows] = (out.goals + origin[:, None]).numpy() / settings.resize
    return paths, goals


@pytest.mark.parametrize("bf16", [False, True])
@pytest.mark.usefixtures("cpu_bf16_hardware")
def test_samplings_of_one_pass_equal_separate_passes(tmp_path, bf16):
    """Encoding each batch once and sampling it for every setting gives, bit for bit, what one
    full pass per setting gives (each setting's generator is consumed in the same order)."""
    torch.set_num_threads(1)
    run(tmp_path)
    model, settings = load_model(tmp_path / "best.pt")
    test = arrays(5, "test", 2)
    test.scene_id[3:] = "gates_1"  # two scenes, the first of three windows: a partial batch
    maps, sizes = {**MAPS, "gates_1": MAPS["gates_0"][:, :48]}, {**SIZES, "gates_1": (192, 256)}
    scenes = group_by_scene(test, maps, sizes, settings.resize)
    params = EvalParams(k_e=3, k_a=2, batch_size=2, chunk_size=4, bf16=bf16)
    samplings = [Sampling(sampling_options(3, 2, TTST, CwsParams(), True, True), 0),
                 Sampling(sampling_options(3, 2, TTST, CwsParams(), False, False), 0),
                 Sampling(sampling_options(2, 1, dataclasses.replace(TTST, temperature=2.0), CwsParams(), True, True), 5)]
    sampled, shared_seconds = predict_samplings(model, scenes, settings, samplings, params, 5, "one")
    assert shared_seconds > 0
    for sampling, drawn in zip(samplings, sampled):
        paths, goals = separate_pass(model, scenes, settings, sampling.options, sampling.seed, params, 5)
        assert np.array_equal(drawn.paths, paths) and np.array_equal(drawn.goals, goals)
        assert drawn.seconds > 0


def test_the_ablation_of_the_sequence_equals_evaluating_it_alone(tmp_path):
    model, settings, test, scenes = trained_and_test_scenes(tmp_path)
    params = EvalParams(k_e=3, k_a=1, rounds=2, ablation_rounds=2, ka_grid_k_e=[], batch_size=2)
    result = evaluation_sequence(model, scenes, settings, params, TTST, CwsParams(), test.future)
    assert "ka_grid" not in result and result["ablation"]["ttst_cws"] == result["main"]
    assert result["eval_seconds"] >= result["main_seconds"] > 0
    for name, use_ttst, use_cws in (("none", False, False), ("cws", False, True), ("ttst_cws", True, True)):
        options = sampling_options(3, 1, TTST, CwsParams(), use_ttst, use_cws)
        alone = evaluate(model, scenes, settings, options, params, test.future, 2, name)
        assert result["ablation"][name] == alone


@pytest.mark.parametrize("n_future, expected", [(30, [14, 29]), (60, [29, 59]), (5, [2, 4]),
                                                (10, [4, 9])])
def test_waypoints_scale_with_the_horizon(n_future, expected):
    assert scale_waypoints([14, 29], n_future) == expected


def test_distance_gain_steepens_the_maps_and_every_setting_but_epochs_and_threads_is_identity():
    plain = YnetSettings(resize=0.0625)
    steep = YnetSettings(resize=0.0625, distance_gain=8.0)
    assert plain.max_distance == pytest.approx(upstream_max_distance(0.0625))
    assert steep.max_distance == pytest.approx(plain.max_distance / 8)
    with pytest.raises(ValueError, match="distance_gain"):
        YnetSettings(distance_gain=0.0)
    train_arrays = arrays(2, "train", 0)
    base = run_fingerprint(YnetSettings(**SETTINGS), N_PAST, MAPS, train_arrays)
    assert run_fingerprint(YnetSettings(**SETTINGS, distance_gain=8.0), N_PAST, MAPS, train_arrays) != base
    assert run_fingerprint(YnetSettings(**{**SETTINGS, "epochs": 9, "threads": 2}), N_PAST, MAPS,
                           train_arrays) == base


def test_a_model_file_of_the_retired_settings_reads_at_their_only_values():
    saved = {**dataclasses.asdict(YnetSettings(**SETTINGS)), "distance_norm": "upstream",
             "mix_scenes": False, "weight_average_decay": 0.0}
    assert YnetSettings.from_saved(saved) == YnetSettings(**SETTINGS)
    with pytest.raises(ValueError, match="distance_norm"):
        YnetSettings.from_saved({**saved, "distance_norm": "map"})
