"""The contract of a registered long-term model (`pipeline.models`, README "Your model here"): the
registry line, what the harness shows the model and checks of what it returns, constant velocity
through the contract, the DVC stages a registry line gives, and a toy model registered in a
temporary copy of the repository, run by `dvc repro` and found in the report."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import yaml

from pipeline.benchmarks.ind import IND
from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import ParamsError, load_section, read_params
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.data.window_table import conform, load_windows
from pipeline.harness.model_runs import FIT_FACTS, fit_to_workdir, predict_to_files, registered
from pipeline.harness.predictions import prediction_arrays, read_predictions, write_no_predictions
from pipeline.io import write_parquet
from pipeline.models import (ModelEntry, WindowSet, check_predictions, load_model, load_models,
                             model_file, window_set)
from pipeline.models.constant_velocity import extrapolate
from ynet.segmentation import CLASS_NAMES

REPO = Path(__file__).resolve().parents[1]
N_PAST = 5
SCENES = ("gates_2", "hyang_0")  # two SDD videos (their masks and scales: `write_scene_inputs`)


def horizon_table(horizon: int, per_split: dict[str, int], seed: int = 0) -> pd.DataFrame:
    """A window table of gently turning tracks, `per_split` windows of each split, in the schema
    of `pipeline.data.window_table` (pixels, 1 FPS, n_past = 5). Windows 2i and 2i + 1 co-occur."""
    rng = np.random.default_rng(seed)
    rows, window = [], 0
    for split, n in per_split.items():
        for i in range(n):
            start = rng.uniform(100, 900, 2)
            heading, turn = rng.uniform(0, 2 * np.pi), rng.uniform(-0.05, 0.05)
            speed = rng.uniform(8, 20)
            angles = heading + turn * np.arange(N_PAST + horizon)
            xy = start + np.cumsum(speed * np.stack([np.cos(angles), np.sin(angles)], 1), axis=0)
            first = 30 * 100 * (window // 2)
            for step, (x, y) in enumerate(xy):
                rows.append({"window_id": window, "scene_id": SCENES[window // 2 % 2],
                             "track_id": window, "step": step, "frame": first + 30 * step,
                             "x": x, "y": y, "split": split, "t_f": horizon, "source": "raw"})
            window += 1
    return conform(pd.DataFrame(rows))


def params_with(models: dict, **sections) -> dict:
    return {"windows": {"n_past": N_PAST, "horizons": [7]},
            "train_baseline": {"seed": 3, "threads": 1},
            "evaluate_baseline": {"k": 4, "split": "test", "rounds": 2, "seed": 10, "threads": 1},
            "runtime": {"device": "cpu", "max_minutes": 0}, "models": models, **sections}


def fit(name: str, horizon: int, table: Path, workdir: Path, params: dict) -> dict:
    """`fit_to_workdir` under the settings stage `fit_model` reads from `params`."""
    return fit_to_workdir(registered(name, load_models(params)), horizon, table, workdir,
                          load_section(TrainBaselineParams, "train_baseline", params),
                          load_section(WindowParams, "windows", params).n_past)


def predict(name: str, horizon: int, table: Path, workdir: Path, metrics: Path, predictions: Path,
            params: dict) -> dict:
    """`predict_to_files` under the settings stage `predict_model` reads from `params`."""
    evaluation = load_section(EvaluateBaselineParams, "evaluate_baseline", params)
    return predict_to_files(registered(name, load_models(params)), horizon, table, workdir, metrics,
                            predictions, evaluation,
                            load_section(WindowParams, "windows", params).n_past)


CV_LINE = {"class": "ConstantVelocity", "label": "Constant velocity", "colour": "#7f7f7f",
           "settings": {}}


# ---------------------------------------------------------------------------------------------
# The registry line


def test_the_repositorys_registry_has_constant_velocity_as_its_worked_example():
    models = load_models(read_params(REPO / "params.yaml"))
    assert models["constant_velocity"] == ModelEntry("constant_velocity", "ConstantVelocity",
                                                     "Constant velocity", "#7f7f7f", {})
    for name in models:
        assert (REPO / model_file(name)).is_file(), name


@pytest.mark.parametrize("section, match", [
    ({"Bad-Name": CV_LINE}, "lower-case letters"),
    ({"pecnet": CV_LINE}, "one of the paper's models"),
    ({"toy": {k: v for k, v in CV_LINE.items() if k != "settings"}}, r"missing key\(s\) \['settings'\]"),
    ({"toy": {**CV_LINE, "epochs": 3}}, r"unknown key\(s\) \['epochs'\]"),
    ({"toy": {**CV_LINE, "colour": "grey"}}, "#rrggbb"),
    ({"toy": {**CV_LINE, "class": "not a class"}}, "name of a class"),
    ({"toy": {**CV_LINE, "settings": None}}, "settings: expected a mapping"),
    ({"toy": {**CV_LINE, "label": ""}}, "label: expected a non-empty string"),
    ([CV_LINE], "expected a mapping of model name"),
])
def test_a_bad_registry_line_is_named(section, match):
    with pytest.raises(ParamsError, match=match):
        load_models({"models": section})


def test_no_models_section_is_an_error_and_an_empty_one_registers_none():
    with pytest.raises(ParamsError, match="missing section 'models'"):
        load_models({})
    assert load_models({"models": {}}) == {} == load_models({"models": None})


# ---------------------------------------------------------------------------------------------
# The contract: loading, what the model is shown, what it may return


@pytest.fixture
def models_dir(monkeypatch, tmp_path):
    """A place for model files of the tests, as `pipeline/models/<name>.py` is for real ones."""
    import pipeline.models as package
    folder = tmp_path / "models"
    folder.mkdir()
    monkeypatch.setattr(package, "FOLDER", folder)
    monkeypatch.setattr(package, "__path__", [str(folder), *package.__path__])
    yield folder
    for name in [m for m in sys.modules if m.startswith("pipeline.models.")
                 and m != "pipeline.models.constant_velocity"]:
        del sys.modules[name]


SPY = '''
import json
from pathlib import Path
import numpy as np

class Spy:
    """Records what it is shown; predicts the last position moved by `shift` px per step."""
    def __init__(self, settings):
        self.shift = float(settings.get("shift", 0.0))
        self.calls = []

    def fit(self, train, val, workdir, seed):
        record = {"seed": seed, "n_train": len(train), "n_val": len(val),
                  "train_future": train.future.shape, "val_future": val.future.shape,
                  "n_future": train.n_future}
        (Path(workdir) / "state.json").write_text(json.dumps(record))

    def predict(self, test, k, workdir, seed):
        state = json.loads((Path(workdir) / "state.json").read_text())
        self.calls.append({"seed": seed, "k": k, "future": test.future, "state": state,
                           "ids": test.window_id.tolist(), "scenes": test.scene_id.tolist()})
        rng = np.random.default_rng(seed)
        steps = np.arange(1, test.n_future + 1)[None, None, :, None]
        jitter = rng.normal(0, 1, (len(test), k, 1, 2))
        return test.past[:, None, -1:, :] + self.shift * steps + jitter
'''


def test_the_harness_shows_train_and_val_futures_never_the_test_ones(models_dir, tmp_path,
                                                                      monkeypatch):
    (models_dir / "spy.py").write_text(SPY)
    table = tmp_path / "tf7.parquet"
    write_parquet(horizon_table(7, {"train": 6, "val": 4, "test": 5}), table)
    params = params_with({"spy": {"class": "Spy", "label": "Spy", "colour": "#123456",
                                  "settings": {"shift": 2.5}}})
    facts = fit("spy", 7, table, tmp_path / "wd", params)
    state = json.loads((tmp_path / "wd" / "state.json").read_text())
    assert state == {"seed": 3, "n_train": 6, "n_val": 4, "train_future": [6, 7, 2],
                     "val_future": [4, 7, 2], "n_future": 7}
    assert json.loads((tmp_path / "wd" / FIT_FACTS).read_text()) == facts
    assert facts["settings"] == {"shift": 2.5} and facts["seed"] == 3

    from pipeline.harness import model_runs
    shown = []

    def keep(entry):  # the instance predict_to_files builds, to read what it was shown
        shown.append(load_model(entry))
        return shown[-1]

    monkeypatch.setattr(model_runs, "load_model", keep)
    record = predict("spy", 7, table, tmp_path / "wd", tmp_path / "m.json",
                     tmp_path / "p.parquet", params)
    calls = shown[0].calls
    assert [c["seed"] for c in calls] == [10, 11]  # evaluate_baseline.seed + round
    assert all(c["future"] is None and c["k"] == 4 and c["state"] == state for c in calls)
    assert calls[0]["ids"] == list(range(10, 15))  # the test split's windows, in table order
    assert record["k"] == 4 and record["rounds"] == 2 and record["n_windows"] == 5
    assert record["train_seconds"] == facts["fit_seconds"]
    stored, metadata = read_predictions(tmp_path / "p.parquet")
    assert metadata["seeds"] == [10, 11] and metadata["model"] == "spy"
    assert metadata["checkpoint_dir"] == str(tmp_path / "wd")
    assert record["ade"]["std"] > 0  # the rounds differ: the seeds reached the model


def test_constant_velocity_through_the_contract_stores_its_extrapolation(tmp_path):
    """The registered constant velocity (the one constant velocity: the baselines score it through
    the same contract) stores the extrapolated path k times per round, scored as a baseline is
    (the keys of metrics/baselines/<model>_tf<H>.json, an exact path on a straight track)."""
    table = tmp_path / "tf7.parquet"
    write_parquet(horizon_table(7, {"train": 4, "val": 2, "test": 9}, seed=5), table)
    params = params_with({"constant_velocity": CV_LINE})
    fit("constant_velocity", 7, table, tmp_path / "wd", params)
    assert sorted(p.name for p in (tmp_path / "wd").iterdir()) == [FIT_FACTS]  # nothing learned
    ours = predict("constant_velocity", 7, table, tmp_path / "wd", tmp_path / "m.json",
                   tmp_path / "p.parquet", params)
    assert json.loads((tmp_path / "m.json").read_text()) == ours
    assert list(ours) == ["model", "horizon", "split", "seed", "ade", "fde", "ade_joint",
                          "fde_joint", "rounds", "k", "n_windows", "eval_seconds",
                          "eval_seconds_per_round", "per_round", "train_seconds"]
    stored, metadata = read_predictions(tmp_path / "p.parquet")
    test = window_set(load_windows(table, N_PAST, 7), "test", with_future=False)
    order = np.argsort(test.window_id)  # stored in ascending window_id order
    expected = np.repeat(extrapolate(test.past, 7)[order, None], metadata["k"], axis=1)
    for round_index in range(len(metadata["seeds"])):
        arrays = prediction_arrays(stored, round_index)
        np.testing.assert_array_equal(arrays.window_ids, test.window_id[order])
        np.testing.assert_array_equal(arrays.samples, expected)


def nan_at(window: int, sample: int, step: int) -> np.ndarray:
    array = np.zeros((5, 4, 7, 2))
    array[window, sample, step, 1] = np.nan
    array[4, 3, 6, 0] = np.inf
    return array


@pytest.mark.parametrize("returned, match", [
    (np.zeros((3, 4, 7, 2)), r"shape \(3, 4, 7, 2\), expected \(N, k, n_f, 2\) = \(5, 4, 7, 2\)"),
    (np.zeros((5, 4, 7)), r"shape \(5, 4, 7\)"),
    (nan_at(1, 2, 3), "2 non-finite value\\(s\\), first at window index 1, sample 2, step 3"),
    (np.full((5, 4, 7, 2), "x"), "an array of <U1, expected float pixels"),
    (None, "an array of object"),
])
def test_what_predict_returns_is_checked_and_the_error_names_the_model(returned, match):
    with pytest.raises(ValueError, match=f"model 'toy': predict returned {match}"):
        check_predictions("toy", returned, 5, 4, 7)
    ints = check_predictions("toy", np.ones((5, 4, 7, 2), np.int32), 5, 4, 7)
    assert ints.dtype == np.float64 and ints.shape == (5, 4, 7, 2)


def test_a_model_that_cannot_be_loaded_says_why(models_dir):
    def entry(name, cls="Toy", settings=None):
        return ModelEntry(name, cls, name, "#000000", settings or {})
    with pytest.raises(ValueError, match=r"model 'absent' \(pipeline/models/absent.py\): no such file"):
        load_model(entry("absent"))
    (models_dir / "toy.py").write_text("class Other:\n    pass\n")
    with pytest.raises(ValueError, match="defines no class 'Toy'"):
        load_model(entry("toy"))
    (models_dir / "half.py").write_text("class Toy:\n    def __init__(self, s):\n        pass\n"
                                        "    def fit(self, *a):\n        pass\n")
    with pytest.raises(ValueError, match="has no predict method"):
        load_model(entry("half"))


def test_constant_velocity_takes_no_settings():
    entry = ModelEntry("constant_velocity", "ConstantVelocity", "CV", "#7f7f7f", {"speed": 1})
    with pytest.raises(ValueError, match=r"ConstantVelocity\(settings=.*takes no settings, got \['speed'\]"):
        load_model(entry)


def test_a_failed_fit_leaves_the_previous_workdir(models_dir, tmp_path):
    (models_dir / "broken.py").write_text(
        "class Broken:\n    def __init__(self, s):\n        pass\n"
        "    def fit(self, train, val, workdir, seed):\n        (workdir / 'half').write_text('x')\n"
        "        raise RuntimeError('diverged')\n"
        "    def predict(self, *a):\n        pass\n")
    table = tmp_path / "tf7.parquet"
    write_parquet(horizon_table(7, {"train": 2, "val": 1, "test": 1}), table)
    (tmp_path / "wd").mkdir()
    (tmp_path / "wd" / "kept").write_text("previous fit")
    params = params_with({"broken": {"class": "Broken", "label": "B", "colour": "#000000",
                                     "settings": {}}})
    with pytest.raises(RuntimeError, match="diverged"):
        fit("broken", 7, table, tmp_path / "wd", params)
    assert sorted(p.name for p in (tmp_path / "wd").iterdir()) == ["kept"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".wd")] == []
    with pytest.raises(ValueError, match=r"wd/fit.json: no fit record.*fit_model@broken-7"):
        predict("broken", 7, table, tmp_path / "wd", tmp_path / "m.json",
                tmp_path / "p.parquet", params)
    with pytest.raises(ParamsError, match=r"no model 'other'; registered: \['broken'\]"):
        fit("other", 7, table, tmp_path / "wd", params)
    with pytest.raises(ValueError, match="windows of horizon\\(s\\) \\[7\\], expected 9"):
        fit("broken", 9, table, tmp_path / "wd", params)


def test_a_window_set_holds_the_documented_arrays():
    from pipeline.data.window_table import to_arrays
    from pipeline.models import window_set
    arrays = to_arrays(horizon_table(3, {"train": 2, "test": 3}), N_PAST)
    test = window_set(arrays, "test", with_future=False)
    assert isinstance(test, WindowSet) and len(test) == 3 and test.future is None
    assert test.past.shape == (3, N_PAST, 2) and test.past.dtype == np.float64
    assert test.n_future == 3 and test.window_id.tolist() == [2, 3, 4]
    assert test.scene_id.tolist() == ["hyang_0", "hyang_0", "gates_2"]  # windows 2i, 2i + 1 co-occur
    train = window_set(arrays, "train", with_future=True)
    assert train.future.shape == (2, 3, 2) and train.first_frame.tolist() == [0, 0]


# ---------------------------------------------------------------------------------------------
# The stages a registry line gives


def test_every_registered_model_has_a_fit_and_a_predict_stage_per_horizon():
    """dvc.yaml's matrix takes the registry's names (a mapping's keys): one stage per (model,
    horizon), depending on the fingerprint of the model's file (what it imports included) and
    reading only its own registry line."""
    from dvc.repo import Repo
    params = read_params(REPO / "params.yaml")
    horizons, models = params["windows"]["horizons"], load_models(params)
    stages = {s.addressing: s for s in Repo(str(REPO)).index.stages}
    for kind in ("fit_model", "predict_model"):
        names = sorted(n for n in stages if n.startswith(f"{kind}@"))
        assert names == sorted(f"{kind}@{m}-{h}" for m in models for h in horizons)
        for name in models:
            stage = stages[f"{kind}@{name}-{horizons[0]}"]
            assert f"data/code_fingerprints/models/{name}.json" in [d.def_path for d in stage.deps]
            declared = {k for p in stage.deps if hasattr(p, "params") for k in p.params}
            assert {f"models.{name}.class", f"models.{name}.settings"} <= declared
            assert not any(k == "models" or k == f"models.{name}" for k in declared)


# ---------------------------------------------------------------------------------------------
# End to end: a toy model registered in a copy of the repository, dvc repro, the report


TOY = '''"""Walks on at the mean speed of the training futures, along the last observed heading, each
sample turned by a seeded random angle: a toy model for tests/test_models.py."""

import json

import numpy as np


class MeanSpeed:
    def __init__(self, settings):
        self.spread = float(settings["spread"])

    def fit(self, train, val, workdir, seed):
        speed = np.linalg.norm(np.diff(train.future, axis=1), axis=-1).mean()
        (workdir / "speed.json").write_text(json.dumps({"speed": float(speed)}))

    def predict(self, test, k, workdir, seed):
        speed = json.loads((workdir / "speed.json").read_text())["speed"]
        last = test.past[:, -1] - test.past[:, -2]
        heading = np.arctan2(last[:, 1], last[:, 0])[:, None]
        angle = heading + np.random.default_rng(seed).normal(0, self.spread, (len(test), k))
        step = speed * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
        steps = np.arange(1, test.n_future + 1)[None, None, :, None]
        return test.past[:, None, -1:] + steps * step[:, :, None]
'''
TOY_LINE = ('  mean_speed: {class: MeanSpeed, label: Mean-speed walker, colour: "#17becf", '
            'settings: {spread: 0.2}}\n')


def tracked_files() -> list[str]:
    out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"],
                         cwd=REPO, capture_output=True, text=True, check=True).stdout
    return [p for p in out.splitlines() if (REPO / p).is_file()]


def write_scene_inputs(repo: Path, horizons: list[int]) -> None:
    """What score_predictions reads besides the predictions: the horizon tables, the release's
    table, hand-label masks and SDD's scales for the two fixture videos."""
    for h in horizons:
        write_parquet(horizon_table(h, {"train": 8, "val": 4, "test": 6}, seed=h),
                      repo / f"data/horizon_windows/tf{h}.parquet")
    release = horizon_table(30, {"test": 6}, seed=30)
    write_parquet(release.assign(window_id=release["window_id"] + 1000),
                  repo / "data/windows/release_tf30.parquet")
    write_no_predictions(repo / "data/predictions/long_term/release_tf30/ynet.parquet",
                         {"model": "ynet", "benchmark": "sdd_long_term_release_tf30", "unit": "px",
                          "seeds": []}, "Y-net is not run in this test")
    labels = repo / "data/labels"
    (labels / "maps").mkdir(parents=True)
    mask = np.full((1500, 1500), CLASS_NAMES.index("pavement"), np.uint8)
    mask[:, 1200:] = CLASS_NAMES.index("structure")
    for video in SCENES:
        cv2.imwrite(str(labels / "maps" / f"{video}.png"), mask)
    (labels / "index.json").write_text(json.dumps({
        "classes": list(CLASS_NAMES), "pad_class": 0,
        "videos": {v: {"split": "test", "height": 1500, "width": 1500} for v in SCENES}}))
    scales = repo / "data/raw/sdd/estimated_scales.yaml"
    scales.parent.mkdir(parents=True)
    scales.write_text(yaml.safe_dump({"gates": {"video2": {"scale": 0.04, "certainty": 1.0}},
                                      "hyang": {"video0": {"scale": 0.03, "certainty": 1.0}}}))


def dvc(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "DVC_NO_ANALYTICS": "1", "OMP_NUM_THREADS": "1", "PYTHONPATH": str(cwd)}
    return subprocess.run([sys.executable, "-m", "dvc", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_a_toy_model_registered_in_a_copy_of_the_repo_reaches_the_report(tmp_path):
    """One file (pipeline/models/mean_speed.py) and one line (params.yaml `models`) in a copy of
    the repository; `dvc repro` of its stages, score_predictions and the report on fixture
    windows; the model is in Table 3, Figure 4 and "Beyond the paper's tables". The committed
    dvc.lock is left out of the copy: dvc rewrote its 375 KB after each of the six stages, half
    the test's time, and these stages run either way (their code or inputs are new here)."""
    t0 = time.perf_counter()
    repo = tmp_path / "repo"
    for rel in tracked_files():
        if rel == "dvc.lock":
            continue
        (repo / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO / rel, repo / rel)
    subprocess.run(["git", "init", "-q"], cwd=repo, check=True)

    # the one file and the one line; one horizon keeps the run short
    (repo / "pipeline/models/mean_speed.py").write_text(TOY)
    text = (repo / "params.yaml").read_text()
    cv = next(line for line in text.splitlines(keepends=True)
              if line.startswith("  constant_velocity: {class:"))
    text = text.replace(cv, cv + TOY_LINE, 1)
    text = re.sub(r"(?m)^  horizons: \[.*\]$", "  horizons: [30]", text, count=1)
    (repo / "params.yaml").write_text(text)
    write_scene_inputs(repo, [30])
    # the report's inputs from stages not run here: explained on the page as absent or broken
    (repo / "data/ynet_predictions").mkdir(parents=True)
    (repo / "data/ynet_predictions/qualitative.npz").write_bytes(b"")
    for folder in ("reports/figures/segmentation/predictions", "reports/figures/animations",
                   "reports/figures/horizons"):
        (repo / folder).mkdir(parents=True, exist_ok=True)
    for rel in ("metrics/baseline_seed_spread.json", "metrics/beyond/short_term.json"):
        (repo / rel).parent.mkdir(parents=True, exist_ok=True)
        (repo / rel).write_text("{}\n")
    write_no_predictions(repo / "data/predictions/ind/ynet.parquet", IND.prediction_metadata("ynet"),
                         "inD not provided")  # as evaluate_ind writes it without inD

    stages = ["code_fingerprints", "fit_model@mean_speed-30", "predict_model@mean_speed-30", "ind_windows",
              "score_predictions", "report"]
    result = dvc(["repro", "--single-item", *stages], repo)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]

    lock = yaml.safe_load((repo / "dvc.lock").read_text())["stages"]
    assert lock["fit_model@mean_speed-30"]["params"]["params.yaml"] == {
        "models.mean_speed.class": "MeanSpeed", "models.mean_speed.settings": {"spread": 0.2},
        "train_baseline": {"seed": 0, "threads": 1}, "windows.n_past": 5}
    assert (repo / "checkpoints/models/mean_speed_tf30/speed.json").is_file()
    metrics = json.loads((repo / "metrics/baselines/mean_speed_tf30.json").read_text())
    assert metrics["model"] == "mean_speed" and metrics["k"] == 20 and metrics["rounds"] == 3
    assert metrics["n_windows"] == 6 and metrics["ade"]["std"] > 0
    beyond = json.loads((repo / "metrics/beyond/long_term.json").read_text())
    assert beyond["tables"]["tf30"]["models"]["mean_speed"]["metrics"]["ade"]["mean"] == \
        pytest.approx(metrics["ade"]["mean"])  # score_predictions found the stored rounds

    html = (repo / "reports/index.html").read_text()
    table3 = html[html.index('data-table="sdd_long"'):]
    table3 = table3[:table3.index("</table>")]
    assert "<th>Mean-speed walker</th>" in table3
    assert f"{metrics['ade']['mean']:,.2f}" in table3 and "not in the paper" in table3
    horizon = html[html.index('<h2 id="fig-horizon">'):html.index('<h2 id="seed-spread">')]
    assert "<tr><th>Mean-speed walker</th>" in horizon
    plots = json.loads((repo / "reports/plots/horizon_ade.json").read_text())
    assert [row["t_f"] for row in plots if "mean_speed" in row] == [30]
    section = html[html.index('<h2 id="beyond">'):html.index('<h2 id="data">')]
    assert "<tr><th>Mean-speed walker</th>" in section
    assert (repo / "reports/headline/table3_sdd_long/sdd_mean_speed_ka1.json").is_file()
    assert "release_tf30/ynet: Y-net is not run in this test" in section
    assert time.perf_counter() - t0 < 120
