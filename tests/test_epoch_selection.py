"""Epoch selection rules (pipeline.harness.epoch_selection) and their split-half study
(pipeline.studies.epoch_selection), the rules kept by the training loop while it runs, evaluation
scoring the kept weights of the chosen rule, and the stage over real checkpoint folders."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml

from pipeline.config.loading import read_params
from pipeline.harness import epoch_selection
from pipeline.runners import baseline_runs
from pipeline.runners.baselines import common
from pipeline.runners.baselines.pecnet import Pecnet
from pipeline.runners.baselines.sgan import SocialGan
from pipeline.runners.baselines.training import run_training
from pipeline.harness.epoch_selection import centred_mean, selected_epoch
from pipeline.stages import epoch_selection as stage
from pipeline.studies.epoch_selection import long_term_runs, split_half_study, summarise
from tests.test_baselines import TINY_PECNET, TINY_SGAN, straight_tracks

torch.set_num_threads(1)
REPO = Path(__file__).resolve().parents[1]


def test_centred_mean_is_cut_at_the_ends():
    curve = np.array([4.0, 2.0, 6.0, 8.0])
    assert centred_mean(curve, 0, 1) == 3.0  # (4 + 2) / 2
    assert centred_mean(curve, 1, 1) == 4.0  # (4 + 2 + 6) / 3
    assert centred_mean(curve, 3, 2) == pytest.approx(16 / 3)  # (2 + 6 + 8) / 3


def test_raw_keeps_the_lowest_epoch_and_smoothing_keeps_the_lowest_stretch():
    # A lucky dip at epoch 1 inside a high stretch; a low plateau at epochs 5-7.
    curve = np.array([10, 3, 10, 10, 10, 5, 4, 5, 9, 9], dtype=float)
    assert selected_epoch(curve, "raw") == 1
    assert selected_epoch(curve, "mean3") == 6  # (5 + 4 + 5) / 3 = 4.67 beats (10 + 3 + 10) / 3
    assert selected_epoch(curve, "mean5") == 7  # (5 + 4 + 5 + 9 + 9) / 5 = 6.4 beats 6.6 at epoch 6
    # The first of equal values wins, as the training loop's strict "<" does.
    assert selected_epoch(np.array([2.0, 1.0, 1.0, 3.0]), "raw") == 1


def test_the_last_epochs_are_no_candidates_until_their_window_is_complete():
    curve = np.array([5.0, 4.0, 3.0, 2.0, 1.0])
    assert selected_epoch(curve, "mean3") == 3  # epoch 4 has no epoch after it yet
    assert selected_epoch(curve, "mean5") == 2
    # No window complete yet: every epoch is a candidate, its window cut short (here each holds
    # both epochs, a tie the first wins).
    assert selected_epoch(curve[:2], "mean7") == 0
    with pytest.raises(ValueError, match="unknown epoch selection rule 'median'"):
        selected_epoch(curve, "median")


def test_split_half_study_by_hand():
    # Two windows, three epochs: every halving puts one window on each side.
    curves = np.array([[1.0, 9.0], [5.0, 2.0], [3.0, 3.0]])  # (E, N)
    study = split_half_study(curves, n_splits=5, seed=0, rules=("raw",))
    # Window 0 chooses epoch 0 (1.0): window 1 scores 9.0 there. Window 1 chooses epoch 1 (2.0):
    # window 0 scores 5.0 there. Mean 7.0; each held-out window's own best: 1.0 and 2.0.
    assert study["held_out"]["raw"] == pytest.approx(7.0)
    assert study["oracle"] == pytest.approx(1.5)
    with pytest.raises(ValueError, match=">= 2 windows"):
        split_half_study(curves[:, :1], 3, 0)


def test_smoothing_wins_the_study_when_epochs_differ_by_noise_around_a_trend():
    # Twenty windows whose true error falls then rises smoothly; each epoch's error is noisy per
    # window. Choosing on half the windows, raw chases the noise; a centred mean does not.
    rng = np.random.default_rng(1)
    epochs = np.arange(30)
    trend = 10 + 0.02 * (epochs - 15) ** 2
    curves = trend[:, None] + rng.normal(0, 3, (30, 20))
    study = split_half_study(curves, n_splits=100, seed=0)
    assert study["held_out"]["mean5"] < study["held_out"]["raw"]
    assert study["oracle"] <= min(study["held_out"].values())


def test_summarise_pools_ratios_to_raw_per_horizon():
    runs = [{"horizon": 5, "held_out": {"raw": 10.0, "mean3": 9.0}},
            {"horizon": 5, "held_out": {"raw": 10.0, "mean3": 10.0}},
            {"horizon": 60, "held_out": {"raw": 20.0, "mean3": 23.0}}]
    summary = summarise(runs, rules=("raw", "mean3"))
    assert summary["overall"]["mean3"]["mean_ratio_to_raw"] == pytest.approx((0.9 + 1.0 + 1.15) / 3)
    assert summary["per_horizon"]["5"]["mean3"] == {"mean_ratio_to_raw": pytest.approx(0.95),
                                                    "runs_better_than_raw": 1, "runs_worse_than_raw": 0,
                                                    "runs": 2}
    assert summary["recommended"] == "raw"  # mean3's 1.0167 loses overall
    assert summarise(runs[:2], rules=("raw", "mean3"))["recommended"] == "mean3"


# ---------------------------------------------------------------------------------------------
# The training loop keeps every rule's epoch


SCRIPTED_CURVE = [9.0, 4.0, 8.0, 6.0, 5.0, 5.5, 7.0, 3.0, 9.0]  # mean validation ADE per epoch


def scripted_run(folder, epochs: int) -> common.FitResult:
    """`run_training` on a one-weight module whose weight is the epoch's number after its training,
    validated on two windows whose mean follows SCRIPTED_CURVE."""
    net = torch.nn.Linear(1, 1, bias=False)
    optimizer = torch.optim.SGD(net.parameters(), lr=0.0)
    epoch_of = {"next": 0}

    def train_batch(index):
        with torch.no_grad():
            net.weight.fill_(float(epoch_of["next"]))
        return np.zeros(1)

    def validate():
        value = SCRIPTED_CURVE[epoch_of["next"]]
        epoch_of["next"] += 1
        return np.array([value - 1.0, value + 1.0])

    def epoch_batches(epoch):
        epoch_of["next"] = epoch
        return [np.array([0])]

    return run_training(
        name="scripted", modules={"net": net}, optimizers={"net": optimizer},
        epoch_batches=epoch_batches, train_batch=train_batch, loss_names=("loss",), validate=validate,
        epochs=epochs, config={"epochs": epochs}, meta={"n_past": 1, "n_future": 1, "seed": 0},
        data_fingerprint="scripted", checkpoint_dir=folder, generator=torch.Generator().manual_seed(0))


def kept_weight(folder, rule) -> tuple[int, float]:
    saved = common.load_checkpoint(common.best_path(folder, rule))
    return saved["epoch"], float(saved["modules"]["net"]["weight"])


def test_each_rule_keeps_the_weights_of_the_epoch_it_selects(tmp_path):
    result = scripted_run(tmp_path / "straight", epochs=len(SCRIPTED_CURVE))
    curve = np.array(SCRIPTED_CURVE)
    assert result.window_curves().shape == (len(curve), 2)
    for rule in epoch_selection.RULES:
        expected = selected_epoch(curve, rule)
        assert result.selected[rule] == expected
        assert kept_weight(tmp_path / "straight", rule) == (expected, float(expected))
    assert result.selected["raw"] == result.best_epoch == 7
    assert result.selected["mean3"] == 6  # (5.5 + 7 + 3) / 3 = 5.17 beats (6 + 5 + 5.5) / 3 at 4


def test_a_run_extended_in_pieces_keeps_what_a_straight_run_keeps(tmp_path):
    straight = scripted_run(tmp_path / "straight", epochs=len(SCRIPTED_CURVE))
    for epochs in (2, 5, len(SCRIPTED_CURVE)):  # the weights of the last few epochs cross resumes
        pieces = scripted_run(tmp_path / "pieces", epochs=epochs)
    assert pieces.selected == straight.selected and pieces.history == straight.history
    for rule in epoch_selection.RULES:
        assert kept_weight(tmp_path / "pieces", rule) == kept_weight(tmp_path / "straight", rule)


def test_evaluation_scores_the_weights_of_the_chosen_rule(tmp_path):
    train, val = straight_tracks(16, 5, seed=7), straight_tracks(6, 5, seed=8)
    Pecnet.fit(train, val, dataclasses.replace(TINY_PECNET, epochs=5), tmp_path, seed=0)
    result = common.fit_result_from(tmp_path)
    curve = np.array([epoch["val_ade"] for epoch in result.history])
    assert np.allclose(result.window_curves().mean(axis=1), curve)
    for rule in ("raw", "mean5"):
        facts = baseline_runs.training_facts("pecnet", tmp_path, rule)
        assert facts["best_epoch"] == selected_epoch(curve, rule) and facts["epoch_selection"] == rule
        assert facts["best_val_ade"] == pytest.approx(curve[facts["best_epoch"]])
        loaded = Pecnet.load(tmp_path, selection=rule)
        saved = common.load_checkpoint(common.best_path(tmp_path, rule))["modules"]["net"]
        assert all(torch.equal(loaded.net.state_dict()[k], v) for k, v in saved.items())
    with pytest.raises(ValueError, match="unknown epoch selection rule"):
        Pecnet.load(tmp_path, selection="best_ever")


def test_dvc_yaml_lists_the_checkpoint_folders_of_every_run_the_stage_reads():
    """The stage's deps are written out by hand in dvc.yaml (DVC cannot loop over params there):
    they must be exactly the folders `long_term_runs` gives under params.yaml."""
    params = read_params(REPO / "params.yaml")
    runs = long_term_runs(Path("checkpoints"), params["windows"]["horizons"],
                                        params["train_baseline"]["seed"], params["baseline_seeds"]["extra"])
    deps = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]["epoch_selection"]["deps"]
    assert sorted(d for d in deps if d.startswith("checkpoints/")) == sorted(str(run[3]) for run in runs)
    assert len(runs) == 2 * len(params["windows"]["horizons"]) * (1 + len(params["baseline_seeds"]["extra"]))


def test_stage_studies_every_run_and_names_a_run_without_curves(tmp_path, monkeypatch):
    params = read_params()
    params["windows"]["horizons"], params["baseline_seeds"]["extra"] = [5], [1]
    params["epoch_selection_study"] = {"n_splits": 20, "seed": 0}
    monkeypatch.setattr(stage, "read_params", lambda: params)
    train, val = straight_tracks(16, 5, seed=7), straight_tracks(6, 5, seed=8)
    for cls, config in ((SocialGan, TINY_SGAN), (Pecnet, TINY_PECNET)):
        for seed, folder in ((0, f"{cls.name}_tf5"), (1, f"seeds/{cls.name}_tf5_seed1")):
            cls.fit(train, val, dataclasses.replace(config, epochs=3), tmp_path / "ck" / folder, seed=seed)
    stage.main(["--checkpoints", str(tmp_path / "ck"), "--out", str(tmp_path / "study.json")])
    record = json.loads((tmp_path / "study.json").read_text())
    assert [(run["model"], run["seed"]) for run in record["runs"]] == [
        ("sgan", 0), ("sgan", 1), ("pecnet", 0), ("pecnet", 1)]
    assert all(run["n_windows"] == 6 and run["n_epochs"] == 3 for run in record["runs"])
    assert record["summary"]["overall"]["raw"]["mean_ratio_to_raw"] == 1.0
    assert record["summary"]["recommended"] in epoch_selection.RULES
    last = tmp_path / "ck" / "pecnet_tf5" / common.LAST  # a run recorded before the per-window curves
    saved = torch.load(last, weights_only=True)
    for epoch in saved["state"]["history"]:
        del epoch["val_window_ade"]
    torch.save(saved, last)
    with pytest.raises(ValueError, match="pecnet_tf5/last.pt: no per-window validation errors"):
        stage.main(["--checkpoints", str(tmp_path / "ck"), "--out", str(tmp_path / "again.json")])
    assert not (tmp_path / "again.json").exists()
