"""One list of models: `pipeline.model_list` (the paper's) and params.yaml `models` (the
registered). dvc.yaml cannot import Python, so its matrices and plots write the names out; these
tests hold them to the list, and the list's derived views to each other."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
import yaml

from pipeline.config.loading import read_params
from pipeline.dataset_list import SHORT_TERM_DATASETS
from pipeline.model_list import (BASELINES, BY_NAME, OURS, PAPER_MODEL_NAMES, PAPER_MODELS,
                                 SEEDED_BASELINES, SHORT_TERM_MODELS, SHORT_TERM_MODELS_OURS_FIRST,
                                 TRAINED_BASELINES, label, ours_first)
from pipeline.models import RESERVED_MODEL_NAMES, all_models, load_models
from pipeline.report.common import horizon_models, model_colours, table_models

ROOT = Path(__file__).resolve().parents[1]

# A model named in a string of its own, outside `pipeline/model_list.py`: every spelling the paper's
# and the registered models go by (name, label, and the ways a file name or an abbreviation spells
# them), each as a whole string constant; prose that mentions a model is not one.
OTHER_SPELLINGS = ("s_gan", "r_pecnet", "y_net", "cv")
# Calls whose string arguments are params.yaml section keys (`load_profile(YnetSettings, "ynet",
# params)`): the keys stay as params.yaml spells them.
PARAMS_KEY_READERS = ("load_profile", "load_section", "profile_entry")
# The strings equal to a model's name that are left, and why each is not the model.
LEFT = {
    ("pipeline/code_graph.py", "ynet"): "the package ynet/, which imports nothing of pipeline",
    ("pipeline/config/fetch.py", "sgan"): "fetch source data/raw/sgan, the S-GAN authors' data",
    ("pipeline/benchmarks/ethucy.py", "sgan"): "windows' `source` tag: cut from that release",
}
MOST_LEFT = 10


@pytest.fixture(scope="module")
def stages() -> dict:
    return yaml.safe_load((ROOT / "dvc.yaml").read_text())["stages"]


@pytest.fixture(scope="module")
def params() -> dict:
    return read_params(ROOT / "params.yaml")


def matrix_models(stage: dict) -> list[str]:
    return stage["matrix"]["model"]


@pytest.mark.parametrize("name", ["train_baseline", "evaluate_baseline", "train_baseline_seed",
                                  "evaluate_baseline_seed"])
def test_the_long_term_baseline_matrices_are_the_trained_baselines(stages, name):
    assert matrix_models(stages[name]) == list(TRAINED_BASELINES)


@pytest.mark.parametrize("name", ["fit_model", "predict_model"])
def test_the_registered_model_matrices_are_params_models(stages, name):
    assert stages[name]["matrix"]["model"] == "${models}"


@pytest.mark.parametrize("name", ["train_short_term_baseline", "evaluate_short_term_baseline"])
def test_every_short_term_baseline_runs_on_every_benchmark(stages, name):
    runs = stages[name]["foreach"]
    expected = {f"{dataset}-{model}" for dataset in SHORT_TERM_DATASETS
                for model in TRAINED_BASELINES}
    assert set(runs) == expected
    assert all(f"{run['dataset']}-{run['model']}" == key for key, run in runs.items())


def test_the_horizon_figure_plot_lists_every_model_as_the_report_orders_them(stages, params):
    dvc = yaml.safe_load((ROOT / "dvc.yaml").read_text())
    plot = next(p for p in dvc["plots"] if "reports/plots/horizon_ade.json" in p)
    shown = [key for key, _ in horizon_models(load_models(params))]
    assert plot["reports/plots/horizon_ade.json"]["y"] == shown


@pytest.mark.parametrize("name", ["train_ynet_horizon", "evaluate_ynet_horizon"])
def test_the_y_net_horizon_stages_run_every_horizon_but_the_main_model_s(stages, params, name):
    windows = params["windows"]
    assert stages[name]["foreach"] == [t for t in windows["horizons"]
                                       if t != windows["release_horizon"]]


def test_the_derived_lists_agree():
    assert PAPER_MODEL_NAMES == ("sgan", "pecnet", "rpecnet", "ynet")  # the paper's Table 3 order
    assert RESERVED_MODEL_NAMES == PAPER_MODEL_NAMES
    assert set(TRAINED_BASELINES) <= set(SEEDED_BASELINES) <= set(BASELINES)
    assert OURS not in BASELINES and BY_NAME["rpecnet"].trained_as in TRAINED_BASELINES
    assert SHORT_TERM_MODELS_OURS_FIRST == ("ynet", "sgan", "pecnet")  # Y-net first
    assert set(SHORT_TERM_MODELS) == set(SHORT_TERM_MODELS_OURS_FIRST)
    short_term_models = read_params(ROOT / "params.yaml")["short_term_models"]
    for profile in ("cpu", "paper"):  # the keys of short_term_models.<profile>.epochs
        assert set(short_term_models[profile]["epochs"]) == set(SHORT_TERM_MODELS)
    assert [label(m.name) for m in PAPER_MODELS] == ["S-GAN", "PECNet", "R-PECNet", "Y-net"]
    assert label("constant_velocity") == "constant_velocity"  # not the paper's: its own name


def test_registered_models_follow_the_paper_s_with_their_own_labels_and_colours(params):
    registered = load_models(params)
    shown = all_models(registered)
    assert [m.name for m in shown] == [*PAPER_MODEL_NAMES, *registered]
    assert table_models(registered)[:4] == tuple((m.name, m.label) for m in PAPER_MODELS)
    assert horizon_models(registered)[0] == ("ynet", "Y-net")
    colours = model_colours(registered)
    assert len(set(colours.values())) == len(colours), "two models share a colour"
    assert colours["constant_velocity"] == registered["constant_velocity"].colour


def test_ours_first_keeps_the_others_in_order():
    assert ours_first(["sgan", "pecnet", "ynet", "cv"]) == ["ynet", "sgan", "pecnet", "cv"]
    assert ours_first([("a", 1), ("ynet", 2)], key=lambda item: item[0]) == [("ynet", 2), ("a", 1)]
    assert ours_first(["sgan"]) == ["sgan"]


def model_spellings(params: dict) -> set[str]:
    registered = load_models(params)
    return {*PAPER_MODEL_NAMES, *(m.label for m in PAPER_MODELS), *registered,
            *(entry.label for entry in registered.values()), *OTHER_SPELLINGS}


def model_name_strings(root: Path, spellings: set[str]) -> list[tuple[str, int, str]]:
    """(file, line, string) of every string constant in `root`/pipeline equal to one of
    `spellings`, but in `pipeline/model_list.py` and the params keys of `PARAMS_KEY_READERS`."""
    found = []
    for path in sorted((root / "pipeline").rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel == "pipeline/model_list.py":
            continue
        tree = ast.parse(path.read_text(), rel)
        params_keys = {id(arg) for node in ast.walk(tree) if isinstance(node, ast.Call)
                       and getattr(node.func, "id", getattr(node.func, "attr", None))
                       in PARAMS_KEY_READERS for arg in node.args}
        found += [(rel, node.lineno, node.value) for node in ast.walk(tree)
                  if isinstance(node, ast.Constant) and node.value in spellings
                  and id(node) not in params_keys]
    return sorted(found)


def unexplained(found: list[tuple[str, int, str]]) -> list[str]:
    return [f"{rel}:{line}: {value!r}" for rel, line, value in found if (rel, value) not in LEFT]


def test_code_names_a_model_through_the_model_list(params):
    """`pipeline.model_list` names the paper's models (SGAN, ..., `label`, the lists), the model's
    module a registered one (constant_velocity.NAME): a string of a model's name elsewhere is a
    second spelling of it, which the list does not change."""
    found = model_name_strings(ROOT, model_spellings(params))
    assert not unexplained(found), "name the model through pipeline.model_list: " + ", ".join(
        unexplained(found))
    assert {(rel, value) for rel, _, value in found} == set(LEFT), "LEFT is stale"
    assert len(found) <= MOST_LEFT


def test_a_model_named_by_a_string_is_found_but_not_a_params_key(tmp_path, params):
    module = tmp_path / "pipeline" / "stages" / "bad.py"
    module.parent.mkdir(parents=True)
    module.write_text('"""PECNet\'s stage: "pecnet" in prose."""\n'
                      'settings = load_profile(PecnetConfig, "pecnet", params)\n'
                      'MODEL = "pecnet"\nSHOWN = f"{label} vs Y-net"\nOTHER = "S-GAN"\n')
    found = model_name_strings(tmp_path, model_spellings(params))
    assert unexplained(found) == ["pipeline/stages/bad.py:3: 'pecnet'",
                                  "pipeline/stages/bad.py:5: 'S-GAN'"]
