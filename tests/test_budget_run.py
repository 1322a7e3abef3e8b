"""The budget study (`pipeline.runners.budget`, stages `budget_run` and `budget_run_ynet`): what
each kind runs, the epochs key it multiplies, what it needs, and the validation curve it reads from
either training's checkpoint."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pipeline import checkpoints
from pipeline.runners.budget import BudgetPoint, epochs_key, stage_commands, validation_curve
from pipeline.runners.studies import dotted
from pipeline.stages import budget_run, budget_run_ynet

REPO = Path(__file__).resolve().parents[1]
COMMON = ["--factor", "2", "--windows", "w", "--scratch", "s", "--result", "r"]
YNET = ["--maps", "maps", "--sdd", "sdd"]


@pytest.mark.parametrize("kind, model, dataset, key", [
    ("long_term_baseline", "pecnet", None, "pecnet.cpu.epochs"),
    ("short_term_baseline", "sgan", "zara2", "short_term_models.cpu.epochs.sgan.ethucy"),
    ("short_term_ynet", "ynet", "sdd", "short_term_models.cpu.epochs.ynet.sdd"),
    ("short_term_ynet", "ynet", "eth", "short_term_models.cpu.epochs.ynet.ethucy"),
    ("long_term_ynet", "ynet", None, "ynet.cpu.epochs"),
])
def test_each_kind_multiplies_an_epochs_key_params_yaml_has(kind, model, dataset, key):
    assert epochs_key(kind, model, "cpu", dataset) == key
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    assert isinstance(dotted(params, key), int)


@pytest.mark.parametrize("stage, argv, message", [
    (budget_run, ["--kind", "long_term_baseline", "--model", "pecnet"], "needs --horizon"),
    (budget_run, ["--kind", "long_term_baseline", "--model", "pecnet", "--horizon", "30",
                  "--dataset", "eth"], "takes no --dataset"),
    (budget_run, ["--kind", "short_term_baseline", "--model", "pecnet"], "needs --dataset"),
    (budget_run, ["--kind", "short_term_ynet", "--model", "pecnet", "--dataset", "sdd"], "invalid choice"),
    (budget_run_ynet, ["--kind", "short_term_ynet", "--dataset", "sdd", *YNET], "needs --ethucy-scenes"),
    (budget_run_ynet, ["--kind", "long_term_ynet", "--dataset", "eth", *YNET], "takes no --dataset"),
    (budget_run_ynet, ["--kind", "long_term_ynet", *YNET, "--ethucy-scenes", "e"], "takes no --ethucy-scenes"),
    (budget_run_ynet, ["--kind", "long_term_ynet", "--maps", "m"], "--sdd"),
])
def test_a_kind_refuses_what_it_lacks_or_does_not_use(stage, argv, message, capsys):
    with pytest.raises(SystemExit) as stopped:
        stage.parse_arguments([*COMMON, *argv])
    assert stopped.value.code == 2 and message in capsys.readouterr().err


def test_a_factor_below_one_is_refused(capsys):
    with pytest.raises(SystemExit):
        budget_run.parse_arguments(["--kind", "short_term_baseline", "--model", "sgan",
                                    "--dataset", "eth", *COMMON[2:], "--factor", "0"])
    assert "at least 1" in capsys.readouterr().err


def test_the_ynet_kinds_run_the_ynet_stages_with_the_scratch_paths(tmp_path):
    short = BudgetPoint("short_term_ynet", "ynet", 2, Path("w"), dataset="sdd", maps=Path("maps"),
                        sdd=Path("sdd"), ethucy_scenes=Path("scenes"))
    (train, train_args), (score, score_args) = stage_commands(short, tmp_path, 8)
    assert (train, score) == ("train_short_term_ynet", "evaluate_short_term_ynet")
    assert train_args[train_args.index("--checkpoint-dir") + 1] == str(tmp_path / "model")
    assert score_args[score_args.index("--metrics") + 1] == str(tmp_path / "run.json")
    for flag in ("--windows", "--maps", "--sdd", "--ethucy-scenes"):
        assert Path(score_args[score_args.index(flag) + 1]).is_absolute(), flag
    long = BudgetPoint("long_term_ynet", "ynet", 2, Path("w"), maps=Path("maps"), sdd=Path("sdd"))
    (train, train_args), (score, score_args) = stage_commands(long, tmp_path, 5)
    assert (train, score) == ("train_ynet", "evaluate_ynet")
    model = str(tmp_path / "model.pt")
    assert train_args[train_args.index("--model") + 1] == model == score_args[score_args.index("--model") + 1]
    assert train_args[train_args.index("--n-past") + 1] == "5"
    assert score_args[score_args.index("--metrics") + 1] == str(tmp_path / "run.json")


def test_the_baseline_kinds_run_as_before(tmp_path):
    point = BudgetPoint("long_term_baseline", "pecnet", 4, Path("t.parquet"), horizon=30)
    (train, train_args), (score, score_args) = stage_commands(point, tmp_path, 5)
    assert (train, score) == ("train_baseline", "evaluate_baseline")
    assert train_args[:4] == ["--model", "pecnet", "--horizon", "30"]
    assert score_args[score_args.index("--predictions") + 1] == str(tmp_path / "predictions.parquet")


def test_the_validation_curve_is_read_from_either_trainings_checkpoint(tmp_path):
    history = [{"epoch": 1, "val_ade": 3.0}, {"epoch": 2, "val_ade": 2.5}, {"epoch": 3}]
    baseline, ynet = tmp_path / "baseline", tmp_path / "ynet"
    for folder, state in ((baseline, {"history": history}),
                          (ynet, {"model": {}, "progress": {"history": history, "best": None}})):
        folder.mkdir()
        checkpoints.save(folder / "last.pt", {"run": "x"}, 3, state)
        assert validation_curve(folder) == [3.0, 2.5]
