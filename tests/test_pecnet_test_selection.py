"""The compat diagnostic of upstream PECNet's epoch selection on test (stage
`pecnet_test_selection`): the per-epoch hook of the training loop changes nothing, both scoring
protocols and the compat summary on hand-made cases, and the stage retraining exactly the model
`train_baseline` trained (its epoch's test scores are `evaluate_baseline`'s first round)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml

from pipeline import checkpoints
from pipeline.config.loading import from_dict, read_params
from pipeline.config.pecnet_test_selection import PecnetTestSelectionParams
from pipeline.studies import pecnet_test_selection as diagnostic
from pipeline.runners.baselines import common
from pipeline.runners.baselines.pecnet import Pecnet
from pipeline.report import compat
from pipeline.stages import evaluate_baseline, pecnet_test_selection, train_baseline
from tests.test_baselines import N_PAST, TINY_PECNET, straight_tracks, window_table

torch.set_num_threads(1)
REPO = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------------------------------------
# The per-epoch hook


def module_weights(state: dict) -> dict[str, torch.Tensor]:
    return {f"{m}.{name}": t for m, weights in state["modules"].items() for name, t in weights.items()}


def same_tensors(a: dict[str, torch.Tensor], b: dict[str, torch.Tensor]) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_the_hook_sees_each_epochs_weights_and_changes_nothing(tmp_path):
    """Training with the hook (sampling the model after every epoch, as the diagnostic does) keeps
    what training without one keeps, checkpoint for checkpoint; the hook sees every epoch once, with
    the weights that epoch ended with."""
    train, val, test = (straight_tracks(16, 5, seed=s) for s in (7, 8, 9))
    config = dataclasses.replace(TINY_PECNET, epochs=4)
    plain = Pecnet.fit(train, val, config, tmp_path / "plain", seed=0)
    seen: dict[int, dict[str, torch.Tensor]] = {}

    def hook(model: Pecnet, epoch: int) -> None:
        assert not torch.is_grad_enabled() and not model.net.training
        seen[epoch] = {f"net.{k}": v.clone() for k, v in model.net.state_dict().items()}
        model.predict(test, 5, torch.Generator().manual_seed(123))

    hooked = Pecnet.fit(train, val, config, tmp_path / "hooked", seed=0, after_epoch=hook)
    assert sorted(seen) == [0, 1, 2, 3]
    assert hooked.fit_result.history == plain.fit_result.history
    assert hooked.fit_result.selected == plain.fit_result.selected
    for rule in plain.fit_result.selected:  # every rule's kept weights
        a, b = (common.load_checkpoint(common.best_path(tmp_path / run, rule)) for run in ("plain", "hooked"))
        assert a["epoch"] == b["epoch"] and same_tensors(module_weights(a), module_weights(b)), rule
    last = [checkpoints.read(tmp_path / run / common.LAST).state for run in ("plain", "hooked")]
    assert same_tensors(module_weights(last[0]), module_weights(last[1]))  # and the resumable state
    assert torch.equal(last[0]["rng"]["generator"], last[1]["rng"]["generator"])
    kept = common.load_checkpoint(tmp_path / "hooked" / common.BEST)
    assert same_tensors(seen[kept["epoch"]], module_weights(kept))  # the kept epoch's own weights
    assert not same_tensors(seen[0], seen[3])  # weights do change: the comparison can fail


def test_training_without_a_hook_is_the_plain_loop(tmp_path):
    """`after_epoch=None` (what every training stage passes, by default) runs exactly the loop
    without the hook: the same history and kept weights as a run given an empty hook."""
    train, val = straight_tracks(16, 5, seed=7), straight_tracks(6, 5, seed=8)
    config = dataclasses.replace(TINY_PECNET, epochs=3)
    calls = []
    none = Pecnet.fit(train, val, config, tmp_path / "none", seed=0, after_epoch=None)
    empty = Pecnet.fit(train, val, config, tmp_path / "empty", seed=0,
                       after_epoch=lambda model, epoch: calls.append(epoch))
    assert calls == [0, 1, 2]
    assert none.fit_result.history == empty.fit_result.history
    assert same_tensors(module_weights(common.load_checkpoint(tmp_path / "none" / common.BEST)),
                        module_weights(common.load_checkpoint(tmp_path / "empty" / common.BEST)))


# ---------------------------------------------------------------------------------------------
# Scoring and the summary, by hand


def test_both_protocols_by_hand():
    truth = np.array([[[0.0, 0.0], [10.0, 0.0]],
                      [[0.0, 0.0], [0.0, 10.0]]])  # (N=2, n_f=2, 2)
    pred = np.array([
        # window 0: sample 0 ADE (0 + 6) / 2 = 3, FDE 6; sample 1 ADE (8 + 2) / 2 = 5, FDE 2
        [[[0.0, 0.0], [4.0, 0.0]], [[0.0, 8.0], [10.0, 2.0]]],
        # window 1: sample 0 exact; sample 1 ADE (5 + 10) / 2 = 7.5, FDE 10
        [[[0.0, 0.0], [0.0, 10.0]], [[5.0, 0.0], [0.0, 0.0]]],
    ])  # (N=2, K=2, n_f=2, 2)
    scores = diagnostic.epoch_test_scores(pred, truth)
    # ours: min ADE 3 and min FDE 2 (different samples) on window 0, 0 and 0 on window 1
    assert scores["headline"] == {"ade": pytest.approx(1.5), "fde": pytest.approx(1.0)}
    # PECNet's: the best endpoint's ADE, 5 on window 0 (sample 1), 0 on window 1; FDE the same
    assert scores["pecnet"] == {"ade": pytest.approx(2.5), "fde": pytest.approx(1.0)}


def hand_curve() -> list[dict]:
    """Six epochs: validation keeps epoch 2; test ADE is lowest at epoch 3 (ours) or 5 (PECNet's
    protocol), test FDE at epoch 5."""
    val = [9.0, 7.0, 5.0, 8.0, 6.0, 7.0]
    ade = [90.0, 85.0, 84.0, 80.0, 83.0, 82.0]
    pecnet_ade = [95.0, 88.0, 86.0, 84.0, 85.0, 81.0]
    fde = [200.0, 190.0, 185.0, 181.0, 183.0, 170.0]
    return [{"epoch": e, "val_ade": val[e],
             "test": {"headline": {"ade": ade[e], "fde": fde[e]},
                      "pecnet": {"ade": pecnet_ade[e], "fde": fde[e]}}} for e in range(6)]


def test_compat_summary_of_a_hand_made_curve():
    summary = diagnostic.compat_summary(hand_curve())
    kept = summary["validation_selected"]
    assert (kept["rule"], kept["epoch"], kept["val_ade"]) == ("raw", 2, 5.0)
    assert kept["test"] == {"headline": {"ade": 84.0, "fde": 185.0}, "pecnet": {"ade": 86.0, "fde": 185.0}}
    assert summary["compat"] == {
        "headline": {"best_ade": {"value": 80.0, "epoch": 3}, "best_fde": {"value": 170.0, "epoch": 5}},
        "pecnet": {"best_ade": {"value": 81.0, "epoch": 5}, "best_fde": {"value": 170.0, "epoch": 5}}}
    assert summary["compat_minus_validation_selected"] == {
        "headline": {"ade": -4.0, "fde": -15.0}, "pecnet": {"ade": -5.0, "fde": -15.0}}
    # a smoothed rule keeps another epoch: (5 + 8 + 6) / 3 at epoch 3 is the lowest mean of three
    assert diagnostic.compat_summary(hand_curve(), "mean3")["validation_selected"]["epoch"] == 3


def test_ties_go_to_the_first_epoch():
    curve = hand_curve()
    curve[4]["test"]["headline"]["ade"] = 80.0  # as low as epoch 3
    assert diagnostic.lowest_over_epochs(curve, "headline", "ade") == {"value": 80.0, "epoch": 3}


def test_a_record_out_of_order_or_incomplete_is_refused():
    shuffled = hand_curve()
    shuffled[1], shuffled[2] = shuffled[2], shuffled[1]
    with pytest.raises(ValueError, match="expected 0, 1"):
        diagnostic.compat_summary(shuffled)
    incomplete = hand_curve()
    del incomplete[3]["test"]["pecnet"]["fde"]
    with pytest.raises(ValueError, match=r"epoch 3: missing \['pecnet.fde'\]"):
        diagnostic.compat_summary(incomplete)
    with pytest.raises(ValueError, match="no epochs"):
        diagnostic.compat_summary([])


def test_params_section_validates_and_refuses_bad_values():
    params = read_params(REPO / "params.yaml")
    section = from_dict(PecnetTestSelectionParams, params["pecnet_test_selection"], "pecnet_test_selection")
    assert section.horizons and section.k >= 1
    for bad in ({"horizons": []}, {"horizons": [30, 30]}, {"horizons": [1]}, {"k": 0}):
        with pytest.raises(Exception, match="horizons|k must"):
            from_dict(PecnetTestSelectionParams, {"horizons": [30], "k": 20, "seed": 0, **bad}, "x")


def test_dvc_yaml_lists_the_table_and_training_facts_of_every_horizon():
    """The cmd and deps are written out by hand (DVC cannot loop over a params list there): one
    window table and one train_baseline facts file per horizon of `pecnet_test_selection.horizons`."""
    horizons = read_params(REPO / "params.yaml")["pecnet_test_selection"]["horizons"]
    stage = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]["pecnet_test_selection"]
    files = sorted([f"data/horizon_windows/tf{h}.parquet" for h in horizons]
                   + [f"metrics/baselines/train_pecnet_tf{h}.json" for h in horizons])
    assert sorted(stage["deps"][1:]) == files
    assert sorted(t for t in stage["cmd"].split() if t.endswith((".parquet", ".json"))
                  and not t.startswith("metrics/pecnet_test_selection")) == files


def test_files_are_matched_to_the_horizons_or_refused():
    tables = [Path("d/tf30.parquet"), Path("d/tf5.parquet")]
    assert diagnostic.by_horizon(tables, "tf", [5, 30], "window table") == {5: tables[1], 30: tables[0]}
    with pytest.raises(ValueError, match=r"t_f \[5, 30\], pecnet_test_selection.horizons is \[30\]"):
        diagnostic.by_horizon(tables, "tf", [30], "window table")
    with pytest.raises(ValueError, match="train_pecnet_tf5.json: not one"):
        diagnostic.by_horizon([Path("train_pecnet_tf5.json")] * 2, "train_pecnet_tf", [5], "facts file")
    with pytest.raises(ValueError, match="sgan_tf5.json: not one"):
        diagnostic.by_horizon([Path("sgan_tf5.json")], "train_pecnet_tf", [5], "facts file")


# ---------------------------------------------------------------------------------------------
# The stage, end to end on a tiny table


def test_the_stage_retrains_the_headline_model_and_scores_its_epoch_as_evaluate_baseline(
        tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    arrays = straight_tracks(24, 5, seed=5)
    window_table(arrays, ["train"] * 12 + ["val"] * 6 + ["test"] * 6).to_parquet("tf5.parquet")
    config = dataclasses.asdict(dataclasses.replace(TINY_PECNET, epochs=4))
    params = {
        "profile": "cpu", "windows": {"n_past": N_PAST}, "train_baseline": {"seed": 0, "threads": 1},
        "runtime": {"device": "cpu", "max_minutes": 0}, "pecnet": {"cpu": config, "paper": config},
        "evaluate_baseline": {"k": 6, "split": "test", "rounds": 2, "seed": 3, "threads": 1},
        "pecnet_test_selection": {"horizons": [5], "k": 6, "seed": 3},
    }
    Path("params.yaml").write_text(yaml.safe_dump(params))
    table = ["--model", "pecnet", "--horizon", "5", "--table", "tf5.parquet",
             "--checkpoint-dir", "ck/pecnet_tf5"]
    train_baseline.main([*table, "--metrics", "m/train_pecnet_tf5.json"])
    evaluate_baseline.main([*table, "--metrics", "m/pecnet_tf5.json", "--predictions", "p/pecnet.parquet"])
    before = {p.name: p.stat().st_mtime_ns for p in Path("ck/pecnet_tf5").iterdir()}
    pecnet_test_selection.main(["--tables", "tf5.parquet", "--training-facts", "m/train_pecnet_tf5.json",
                                "--out", "out.json"])

    record = json.loads(Path("out.json").read_text())
    assert "never a headline" in record["diagnostic"] and set(record["protocols"]) == {"headline", "pecnet"}
    row = record["per_horizon"]["tf5"]
    assert (row["n_train"], row["n_val"], row["n_test"], row["epochs"]) == (12, 6, 6, 4)
    assert [e["epoch"] for e in row["per_epoch"]] == [0, 1, 2, 3]
    assert row["training_reproduced"]["same"] is True
    assert row["training_reproduced"]["retrain"] == row["training_reproduced"]["train_baseline"]
    facts, scores = (json.loads(Path(f"m/{n}.json").read_text()) for n in ("train_pecnet_tf5", "pecnet_tf5"))
    kept = row["validation_selected"]
    assert (kept["epoch"], kept["val_ade"]) == (facts["best_epoch"], facts["best_val_ade"])
    # the same model, K and seed: the kept epoch's test numbers are evaluate_baseline's first round
    assert kept["test"]["headline"] == {key: scores["per_round"][0][key] for key in ("ade", "fde")}
    assert kept["test"]["pecnet"]["ade"] >= kept["test"]["headline"]["ade"]
    for protocol in ("headline", "pecnet"):
        for metric in ("ade", "fde"):
            best = row["compat"][protocol][f"best_{metric}"]
            assert best["value"] == min(e["test"][protocol][metric] for e in row["per_epoch"])
            assert best["value"] <= kept["test"][protocol][metric]
    # the stage's checkpoints are untouched and nothing is left in the working folder
    assert {p.name: p.stat().st_mtime_ns for p in Path("ck/pecnet_tf5").iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "ck", "m", "out.json", "p", "params.yaml", "tf5.parquet"]


# ---------------------------------------------------------------------------------------------
# The report's rows


def test_report_rows_of_a_hand_made_record():
    record = {"per_horizon": {"tf30": diagnostic.compat_summary(hand_curve())}}
    rows = compat.compat_rows(record, paper={30: {"ade": 72.0, "fde": 160.0}})
    assert [(r["protocol"], r["selection"]) for r in rows] == [
        ("headline", "validation"), ("headline", "test"), ("pecnet", "validation"), ("pecnet", "test")]
    assert rows[0]["label"] == "PECNet t_f=30 s: epoch kept on validation"
    assert rows[1]["label"] == "PECNet t_f=30 s: upstream's test-set selection (compat)"
    assert {k: rows[0][k] for k in ("ade", "ade_epoch", "fde", "fde_epoch")} == {
        "ade": 84.0, "ade_epoch": 2, "fde": 185.0, "fde_epoch": 2}
    assert {k: rows[3][k] for k in ("ade", "ade_epoch", "fde", "fde_epoch")} == {
        "ade": 81.0, "ade_epoch": 5, "fde": 170.0, "fde_epoch": 5}
    # FDE 185 -> 170 of the gap 185 -> 160: 15 / 25; ADE (PECNet's) 86 -> 81 of 86 -> 72: 5 / 14
    assert rows[3]["fde_gap_share"] == pytest.approx(0.6)
    assert rows[3]["ade_gap_share"] == pytest.approx(5 / 14)
    assert rows[0]["fde_gap_share"] is None and rows[2]["ade_gap_share"] is None
    assert compat.compat_rows(record)[1]["fde_gap_share"] is None  # no paper value
    assert compat.compat_rows(None) == [] and compat.compat_rows({}) == []


def test_gap_share_by_hand():
    assert compat.gap_share(175.0, 165.0, 125.0) == pytest.approx(0.2)
    assert compat.gap_share(100.0, 100.0, 90.0) == 0.0
    assert compat.gap_share(100.0, 95.0, 110.0) is None  # already below the paper: no gap
    assert compat.gap_share(None, 95.0, 90.0) is None
