"""The baselines with extra training seeds (issue 24, item 5): the seed stages train other models and
score them exactly as the main ones; the spread over seeds is hand-checked; bad inputs are named.
Tiny configs on synthetic tracks, one thread."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
import torch
import yaml

from pipeline.config.baseline_seeds import BaselineSeedsParams
from pipeline.config.loading import ParamsError, from_dict
from pipeline.studies import seed_spread
from pipeline.runners.baselines import common
from pipeline.io import IntermediateError
from pipeline.model_list import BY_NAME
from pipeline.stages import (baseline_seed_spread, evaluate_baseline, evaluate_baseline_seed,
                             evaluate_rpecnet, evaluate_rpecnet_seed, train_baseline,
                             train_baseline_seed)
from tests.test_baselines import N_PAST, TINY_PECNET, TINY_SGAN, straight_tracks, window_table

torch.set_num_threads(1)
MAIN_TRAIN_KEYS = {"model", "horizon", "profile", "seed", "threads", "device", "wall_seconds", "n_train",
                   "n_val", "epochs", "best_epoch", "best_val_ade", "selected_epochs", "train_seconds",
                   "seconds_per_epoch"}


def weights(checkpoint_dir: Path) -> dict[str, torch.Tensor]:
    modules = common.load_checkpoint(checkpoint_dir / common.BEST)["modules"]
    return {f"{m}.{name}": t for m, state in modules.items() for name, t in state.items()}


def same_weights(a: Path, b: Path) -> bool:
    wa, wb = weights(a), weights(b)
    return wa.keys() == wb.keys() and all(torch.equal(wa[k], wb[k]) for k in wa)


def test_seed_stages_train_other_models_scored_alike_and_summarized(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    arrays = straight_tracks(12, 5, seed=5)
    window_table(arrays, ["train"] * 6 + ["val"] * 3 + ["test"] * 3).to_parquet("tf5.parquet")
    config = {"sgan": dataclasses.asdict(TINY_SGAN), "pecnet": dataclasses.asdict(TINY_PECNET)}
    params = {
        "profile": "cpu", "windows": {"n_past": N_PAST, "horizons": [5]},
        "train_baseline": {"seed": 0, "threads": 1}, "baseline_seeds": {"extra": [1, 2]},
        "runtime": {"device": "cpu", "max_minutes": 0},
        **{m: {"cpu": c, "paper": c} for m, c in config.items()},
        "evaluate_baseline": {"k": 3, "split": "test", "rounds": 2, "seed": 0, "threads": 1},
    }
    Path("params.yaml").write_text(yaml.safe_dump(params))
    table = ["--horizon", "5", "--table", "tf5.parquet"]
    for model in ("sgan", "pecnet"):  # the main models, as train_baseline / evaluate_baseline do
        train_baseline.main(["--model", model, *table, "--checkpoint-dir", f"ck/{model}_tf5",
                             "--metrics", f"m/baselines/train_{model}_tf5.json"])
        evaluate_baseline.main(["--model", model, *table, "--checkpoint-dir", f"ck/{model}_tf5",
                                "--metrics", f"m/baselines/{model}_tf5.json",
                                "--predictions", f"p/{model}.parquet"])
        for seed in (1, 2):
            ck = f"ck/seeds/{model}_tf5_seed{seed}"
            train_baseline_seed.main(["--model", model, *table, "--seed", str(seed), "--checkpoint-dir", ck,
                                      "--metrics", f"m/baselines/seeds/train_{model}_tf5_seed{seed}.json"])
            evaluate_baseline_seed.main(["--model", model, *table, "--checkpoint-dir", ck,
                                         "--metrics", f"m/baselines/seeds/{model}_tf5_seed{seed}.json"])
    evaluate_rpecnet.main([*table, "--checkpoint-dir", "ck/pecnet_tf5", "--metrics", "m/baselines/rpecnet_tf5.json",
                           "--predictions", "p/rpecnet.parquet"])
    for seed in (1, 2):
        evaluate_rpecnet_seed.main([*table, "--checkpoint-dir", f"ck/seeds/pecnet_tf5_seed{seed}",
                                    "--metrics", f"m/baselines/seeds/rpecnet_tf5_seed{seed}.json"])
    assert sorted(p.name for p in Path("p").iterdir()) == ["pecnet.parquet", "rpecnet.parquet", "sgan.parquet"]

    def read(rel: str) -> dict:
        return json.loads((tmp_path / "m" / "baselines" / rel).read_text())

    for model in ("sgan", "pecnet"):
        # the seed stage is train_baseline with another seed: at seed 0 it trains the very same model
        train_baseline_seed.main(["--model", model, *table, "--seed", "0", "--checkpoint-dir", f"ck/again_{model}",
                                  "--metrics", "again.json"])
        assert same_weights(Path(f"ck/again_{model}"), Path(f"ck/{model}_tf5"))
        # other seeds: other weights (initialisation, batches, noise)
        one, two = (Path(f"ck/seeds/{model}_tf5_seed{s}") for s in (1, 2))
        assert not same_weights(one, two) and not same_weights(one, Path(f"ck/{model}_tf5"))
        assert set(read(f"train_{model}_tf5.json")) == MAIN_TRAIN_KEYS  # the main layout unchanged
        for seed in (1, 2):
            facts = read(f"seeds/train_{model}_tf5_seed{seed}.json")
            assert set(facts) == MAIN_TRAIN_KEYS | {"val_ade_per_epoch"} and facts["seed"] == seed
            curve = facts["val_ade_per_epoch"]
            assert len(curve) == facts["epochs"] == 2
            assert min(curve) == facts["best_val_ade"] and curve.index(min(curve)) == facts["best_epoch"]
    for model in ("sgan", "pecnet", "rpecnet"):
        main, seeds = read(f"{model}_tf5.json"), [read(f"seeds/{model}_tf5_seed{s}.json") for s in (1, 2)]
        assert "training_seed" not in main
        assert [r["training_seed"] for r in seeds] == [1, 2]
        for record in seeds:  # scored alike: same split, K, rounds and round seeds, same windows
            assert {k: record[k] for k in ("split", "k", "rounds", "seed", "n_windows", "horizon")} == {
                k: main[k] for k in ("split", "k", "rounds", "seed", "n_windows", "horizon")}
            assert len(record["per_round"]) == 2
        assert len({r["ade"]["mean"] for r in (main, *seeds)}) == 3  # other models, other errors

    # the stage's baseline part (the stage itself, Y-net's row included: tests/test_ynet_seeds.py)
    spread = seed_spread.seed_spread(Path("m"), [5], [1, 2])
    assert spread["extra_seeds"] == [1, 2] and len(spread["entries"]) == 3
    for entry in spread["entries"]:
        model = entry["model"]
        records = [read(f"{model}_tf5.json"), *(read(f"seeds/{model}_tf5_seed{s}.json") for s in (1, 2))]
        assert entry["seeds"] == [0, 1, 2] and entry["main_seed"] == 0
        ades = [r["ade"]["mean"] for r in records]
        assert [s["ade"] for s in entry["per_seed"]] == ades
        assert entry["over_training_seeds"]["ade"]["mean"] == pytest.approx(sum(ades) / 3)
        assert entry["main_round_std"]["ade"] == records[0]["ade"]["std"]
        assert [s["best_epoch"] for s in entry["per_seed"]] == [r["best_epoch"] for r in records]


# ---------------------------------------------------------------------------------------------
# The summary, hand-checked


def record(ade: float, fde: float, *, round_std: float = 0.5, eval_seed: int = 0, training_seed: int | None = None,
           best_epoch: int = 3) -> dict:
    """A metrics record as evaluate_baseline(_seed) writes it (only the keys the summary reads)."""
    out = {"split": "test", "k": 20, "rounds": 3, "seed": eval_seed, "n_windows": 66, "horizon": 50,
           "best_epoch": best_epoch, "best_val_ade": 100.0 + best_epoch, "trained_epochs": 40,
           **{key: {"mean": value, "std": round_std} for key, value in
              (("ade", ade), ("fde", fde), ("ade_joint", ade), ("fde_joint", fde + 1.0))}}
    return out if training_seed is None else {**out, "training_seed": training_seed}


def write_records(folder: Path, model: str, horizon: int, main_seed: int, records: dict[int, dict]) -> None:
    (folder / "baselines" / "seeds").mkdir(parents=True, exist_ok=True)
    trained = BY_NAME[model].trained_as or model
    for seed, content in records.items():
        content = {**content, "trained_horizon": 5 if model == "rpecnet" else horizon}
        path = (seed_spread.main_record_path(folder, model, horizon) if seed == main_seed
                else seed_spread.seed_record_path(folder, model, horizon, seed))
        path.write_text(json.dumps(content))
    train_h = 5 if model == "rpecnet" else horizon
    (folder / "baselines" / f"train_{trained}_tf{train_h}.json").write_text(json.dumps({"seed": main_seed}))


def three_seeds() -> dict[int, dict]:
    # ADE 10, 12, 14: mean 12, population std sqrt((4 + 0 + 4) / 3) = 1.632993
    # FDE 20, 20, 26: mean 22, population std sqrt((4 + 4 + 16) / 3) = 2.828427
    return {0: record(10.0, 20.0, round_std=0.25, best_epoch=7),
            1: record(12.0, 20.0, training_seed=1, best_epoch=30),
            2: record(14.0, 26.0, training_seed=2, best_epoch=12)}


def test_spread_over_seeds_hand_checked(tmp_path):
    for model in seed_spread.MODELS:
        write_records(tmp_path, model, 50, 0, three_seeds())
    result = seed_spread.seed_spread(tmp_path, [50], [1, 2])
    assert [(e["model"], e["horizon"]) for e in result["entries"]] == [("sgan", 50), ("pecnet", 50), ("rpecnet", 50)]
    entry = result["entries"][1]
    over = entry["over_training_seeds"]
    assert over["ade"]["mean"] == pytest.approx(12.0) and over["ade"]["std"] == pytest.approx(1.632993, abs=1e-6)
    assert over["fde"]["mean"] == pytest.approx(22.0) and over["fde"]["std"] == pytest.approx(2.828427, abs=1e-6)
    assert (over["ade"]["min"], over["ade"]["max"]) == (10.0, 14.0)
    assert over["fde_joint"]["mean"] == pytest.approx(23.0)
    assert entry["main_round_std"] == {"ade": 0.25, "fde": 0.25}  # the main (seed 0) model's rounds
    assert [(s["seed"], s["best_epoch"], s["best_val_ade"]) for s in entry["per_seed"]] == [
        (0, 7, 107.0), (1, 30, 130.0), (2, 12, 112.0)]
    assert entry["evaluation"] == {"split": "test", "k": 20, "rounds": 3, "seed": 0, "n_windows": 66}


def test_one_seed_has_no_spread(tmp_path):
    for model in seed_spread.MODELS:
        write_records(tmp_path, model, 50, 0, {0: three_seeds()[0]})
    entry = seed_spread.seed_spread(tmp_path, [50], [])["entries"][0]
    assert entry["seeds"] == [0] and entry["over_training_seeds"]["ade"] == {
        "mean": 10.0, "std": 0.0, "min": 10.0, "max": 10.0}


@pytest.mark.parametrize("change, message", [
    (lambda rs: rs[1].update(seed=5), r"pecnet_tf50_seed1\.json: scored with .*'seed': 5.*differ only in training"),
    (lambda rs: rs[2].update(training_seed=1), r"pecnet_tf50_seed2\.json: model trained with seed 1, expected 2"),
    (lambda rs: rs[1].pop("best_epoch"), r"pecnet_tf50_seed1\.json: best_epoch: missing"),
    (lambda rs: rs.pop(2), r"pecnet_tf50_seed2\.json: missing"),
])
def test_a_bad_seed_record_is_named(tmp_path, change, message):
    records = three_seeds()
    change(records)
    write_records(tmp_path, "pecnet", 50, 0, records)
    with pytest.raises(IntermediateError, match=message):
        seeds, main_seed = seed_spread.read_seeds(tmp_path, "pecnet", 50, [1, 2])
        seed_spread.spread_entry("pecnet", 50, seeds, main_seed)


def test_the_main_seed_among_the_extra_ones_is_refused(tmp_path):
    write_records(tmp_path, "rpecnet", 50, 1, {1: record(1.0, 2.0), 2: record(1.0, 2.0, training_seed=2)})
    with pytest.raises(IntermediateError, match=r"train_pecnet_tf5\.json: the main model's seed 1 is also"):
        seed_spread.read_seeds(tmp_path, "rpecnet", 50, [1, 2])


def test_the_stage_names_the_file_and_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("params.yaml").write_text(yaml.safe_dump({
        "profile": "cpu", "windows": {"horizons": [50]}, "baseline_seeds": {"extra": [1]},
        "ynet": {"cpu": {"seed": 0}}, "ynet_seeds": {"slots": [1], "cpu": {"seeds": [], "why_not": "x"}}}))
    with pytest.raises(SystemExit, match=r"baseline_seed_spread: .*ynet_eval\.json: missing"):
        baseline_seed_spread.main(["--metrics", "m", "--out", "spread.json"])
    assert not Path("spread.json").exists()


@pytest.mark.parametrize("extra", [[1, 1], [-1], [True], [1.5]])
def test_extra_seeds_are_distinct_non_negative_integers(extra):
    assert from_dict(BaselineSeedsParams, {"extra": [3, 1]}, "b").extra == [3, 1]
    with pytest.raises(ParamsError):
        from_dict(BaselineSeedsParams, {"extra": extra}, "b")


def test_params_yaml_has_at_least_two_extra_seeds_apart_from_the_main_one():
    params = yaml.safe_load((Path(__file__).resolve().parents[1] / "params.yaml").read_text())
    extra = from_dict(BaselineSeedsParams, params["baseline_seeds"], "baseline_seeds").extra
    assert len(extra) >= 2 and params["train_baseline"]["seed"] not in extra
