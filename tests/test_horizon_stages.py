"""The Y-net horizon stages (`train_ynet_horizon`, `evaluate_ynet_horizon`) run as DVC runs them, on
a fixture with params.yaml's real `cpu` settings (one epoch): a horizon the profile trains, scored
twice with identical metrics and its stored predictions scoring to the same numbers, and one it
does not train, which says why (in its metrics and in an empty predictions file)."""

import json
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
import yaml

from pipeline.config.loading import from_dict
from pipeline.config.ynet import YnetSettings
from pipeline.data.window_table import to_arrays
from pipeline.harness.metrics import window_errors
from pipeline.harness.predictions import prediction_arrays, read_predictions
from pipeline.harness.scoring import min_ade_fde
from pipeline.stages import evaluate_ynet_horizon, train_ynet_horizon, ynet_slot_scoring
from tests.fixtures import write_walker_scenes
from ynet.model import YNet, weights_for_horizon

REPO = Path(__file__).resolve().parents[1]
IMAGE_HW = (512, 640)  # original pixels; the cpu profile's resize 0.0625 gives 32 x 40 maps
N_PAST, HORIZON, UNTRAINED = 5, 10, 5


def walkers(scene_id: str, split: str, n: int, first_id: int, rng) -> pd.DataFrame:
    """`n` walkers crossing the scene in straight lines at 1 FPS, N_PAST + HORIZON steps each."""
    steps = np.arange(N_PAST + HORIZON)
    rows = []
    for i in range(n):
        start = rng.uniform([40, 40], [IMAGE_HW[1] / 3, IMAGE_HW[0] - 40])
        xy = start + steps[:, None] * rng.uniform([8, -4], [12, 4])
        rows.append(pd.DataFrame({
            "window_id": first_id + i, "scene_id": scene_id, "track_id": i, "step": steps,
            "frame": 30 * steps, "x": xy[:, 0], "y": xy[:, 1], "split": split, "t_f": HORIZON,
            "source": "raw"}))
    return pd.concat(rows)


def write_fixture(root: Path) -> None:
    write_walker_scenes(root, root / f"tf{HORIZON}.parquet", IMAGE_HW, walkers)


def stage_args(horizon: int, *outputs: str) -> list[str]:
    return ["--horizon", str(horizon), "--table", f"tf{HORIZON}.parquet", "--semantic-maps",
            "semantic_maps", "--sdd", "sdd", "--checkpoint-dir", f"ck/tf{horizon}", *outputs]


def training_args(horizon: int, *outputs: str) -> list[str]:
    return [*stage_args(horizon, *outputs), "--main-model", "main.pt"]


def write_main_model(path: Path, params: dict, seed: int = 7, **changes) -> dict[str, torch.Tensor]:
    """A main (30-s) Y-net model file as `train_ynet` writes it, with random weights; returns them."""
    settings = replace(from_dict(YnetSettings, params["ynet"]["cpu"], "ynet.cpu"), **changes)
    torch.manual_seed(seed)
    model = YNet(settings.model_config(N_PAST, 30))
    torch.save({"model": model.state_dict(), "config": asdict(model.config), "settings": asdict(settings),
                "epoch": 1}, path)
    return model.state_dict()


def evaluation_args(horizon: int, *outputs: str) -> list[str]:
    return [*stage_args(horizon, *outputs), "--scoring", f"slots/tf{horizon}.json"]


def test_a_trained_horizon_is_scored_reproducibly_and_an_untrained_one_says_why(tmp_path, monkeypatch):
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params["profile"] = "cpu"
    params["ynet"]["cpu"].update(threads=1)
    params["ynet_horizons"]["cpu"]["epochs"] = {HORIZON: 1}
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    write_fixture(tmp_path)
    monkeypatch.chdir(tmp_path)
    ynet_slot_scoring.main(["--out", "slots"])

    write_main_model(Path("main.pt"), params)
    train_ynet_horizon.main(training_args(HORIZON, "--metrics", "train.json"))
    trained = json.loads(Path("train.json").read_text())
    assert trained["trained"] and trained["t_f"] == HORIZON and trained["epochs"] == 1
    assert trained["init"] == ("main model" if params["ynet_horizons"]["cpu"]["init_from_main"] else "random")
    assert trained["waypoints"] == [4, 9]  # the 30-s waypoints [14, 29] scaled to 10 steps
    assert trained["train_windows"] == 6 and np.isfinite(trained["best_val_ade"])

    scored = []
    for name in ("a", "b"):
        evaluate_ynet_horizon.main(evaluation_args(HORIZON, "--train-metrics", "train.json", "--metrics",
                                              f"{name}.json", "--predictions", f"{name}.parquet"))
        scored.append(json.loads(Path(f"{name}.json").read_text()))
    first, again = ({k: v for k, v in record.items() if "seconds" not in k} for record in scored)
    assert first == again  # bit-identical metrics from the same checkpoint and seeds
    assert first["t_f"] == HORIZON and first["n_windows"] == 3
    rounds = params["ynet_horizons"]["cpu"]["rounds"]
    assert first["rounds"] == rounds and len(first["main"]["per_round"]) == rounds
    assert first["main"]["k_e"] == params["eval"]["cpu"]["k_e"] and first["main"]["k_a"] == 1
    assert 0 < first["main"]["ade"]["mean"] and first["main"]["fde"]["mean"] <= first["main"]["fde_joint"]["mean"]

    # every round's paths and sampled goals stored: scored from the file, the same numbers
    stored, metadata = read_predictions(Path("a.parquet"))
    assert stored.equals(read_predictions(Path("b.parquet"))[0])
    assert metadata["model"] == "ynet" and metadata["benchmark"] == f"sdd_long_term_tf{HORIZON}"
    assert metadata["seeds"] == [params["eval"]["cpu"]["seed"] + r for r in range(rounds)]
    assert metadata["k"] == params["eval"]["cpu"]["k_e"] and metadata["unit"] == "px"
    test = to_arrays(pd.read_parquet(f"tf{HORIZON}.parquet").query("split == 'test'"), N_PAST)
    for r, in_memory in enumerate(first["main"]["per_round"]):
        arrays = prediction_arrays(stored, round=r)
        assert arrays.goals is not None  # and TTST's goal masses, summing to 1 per window
        np.testing.assert_allclose(arrays.weights.sum(axis=1), 1.0)
        np.testing.assert_array_equal(arrays.window_ids, test.window_id)
        from_file = min_ade_fde(arrays.samples, test.future, arrays.goals)
        assert {key: float(value.mean()) for key, value in from_file.items()} == in_memory
        # FDE is on the goals: without them the paths' last points give other numbers
        assert window_errors(arrays.samples, test.future).fde.mean() != in_memory["fde"]

    train_ynet_horizon.main(training_args(UNTRAINED, "--metrics", "train_untrained.json"))
    evaluate_ynet_horizon.main(evaluation_args(UNTRAINED, "--train-metrics", "train_untrained.json",
                                          "--metrics", "untrained.json", "--predictions",
                                          "untrained.parquet"))
    untrained = json.loads(Path("untrained.json").read_text())
    assert untrained["trained"] is False and "cpu profile" in untrained["not_run_reason"]
    nothing, why = read_predictions(Path("untrained.parquet"))
    assert len(nothing) == 0 and why["not_run_reason"] == untrained["not_run_reason"]
    assert not any(Path("ck", f"tf{UNTRAINED}").iterdir())


def horizon_fixture(tmp_path, monkeypatch, init_from_main: bool) -> dict:
    """One epoch at learning rate 0 (Adam then moves nothing): the kept weights are the initial ones."""
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params["profile"] = "cpu"
    params["ynet"]["cpu"].update(threads=1, learning_rate=0.0)
    params["ynet_horizons"]["cpu"].update(epochs={HORIZON: 1}, init_from_main=init_from_main)
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(params))
    write_fixture(tmp_path)
    monkeypatch.chdir(tmp_path)
    return params


def kept_weights() -> dict[str, torch.Tensor]:
    return torch.load(Path("ck", f"tf{HORIZON}", "best.pt"), weights_only=True)["model"]


def test_a_horizon_starts_from_the_main_model_with_init_from_main(tmp_path, monkeypatch):
    params = horizon_fixture(tmp_path, monkeypatch, init_from_main=True)
    main = write_main_model(Path("main.pt"), params)
    train_ynet_horizon.main(training_args(HORIZON, "--metrics", "train.json"))
    kept, wanted = kept_weights(), weights_for_horizon(main, HORIZON)
    assert kept.keys() == wanted.keys() and all(torch.equal(kept[k], wanted[k]) for k in kept)
    assert json.loads(Path("train.json").read_text())["init"] == "main model"


def test_without_init_from_main_the_horizon_starts_from_its_own_seeded_init(tmp_path, monkeypatch):
    params = horizon_fixture(tmp_path, monkeypatch, init_from_main=False)
    main = write_main_model(Path("main.pt"), params)
    train_ynet_horizon.main(training_args(HORIZON, "--metrics", "train.json"))
    kept = kept_weights()
    assert not torch.equal(kept["encoder.stem.0.weight"], main["encoder.stem.0.weight"])
    assert json.loads(Path("train.json").read_text())["init"] == "random"


def test_a_main_model_of_other_settings_is_refused_naming_it(tmp_path, monkeypatch):
    params = horizon_fixture(tmp_path, monkeypatch, init_from_main=True)
    write_main_model(Path("main.pt"), params, encoder_channels=[16, 16, 32, 32, 32])
    with pytest.raises(SystemExit, match=r"^train_ynet_horizon: main.pt: its model differs from this "
                                         r"horizon's in \['encoder_channels'\]"):
        train_ynet_horizon.main(training_args(HORIZON, "--metrics", "train.json"))
    assert not Path("train.json").exists() and not Path("ck").exists()
    Path("main.pt").write_bytes(b"not a model")
    with pytest.raises(SystemExit, match=r"^train_ynet_horizon: main.pt: not a Y-net model file"):
        train_ynet_horizon.main(training_args(HORIZON, "--metrics", "train.json"))
