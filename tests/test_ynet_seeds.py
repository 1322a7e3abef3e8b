"""The main Y-net with extra training seeds (issue 24, item 5): `train_ynet_seed` is `train_ynet` with
another seed (seed 0 through it gives the main model bit for bit, other seeds other weights),
`evaluate_ynet_seed` scores exactly as `evaluate_ynet`'s main setting, a slot the profile does not
train says why and trains nothing, and the spread's Y-net row is hand-checked. Stages run as DVC
runs them, on a small t_f = 30 fixture with params.yaml's real `cpu` settings (one epoch, one
thread)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
import yaml

from pipeline.config.loading import ParamsError, from_dict, load_profile
from pipeline.config.ynet_seeds import YnetSeedsParams, ynet_seed_slots
from pipeline.studies import seed_spread
from pipeline.io import IntermediateError
from pipeline.runners import ynet_training
from pipeline.stages import (baseline_seed_spread, evaluate_ynet, evaluate_ynet_seed, train_ynet,
                             train_ynet_seed, ynet_slot_scoring)
from tests.fixtures import write_walker_scenes
from tests.test_baseline_seeds import three_seeds, write_records

REPO = Path(__file__).resolve().parents[1]
IMAGE_HW = (512, 640)  # original pixels; the cpu profile's resize 0.0625 gives 32 x 40 maps
N_PAST, T_F = 5, 30


def walkers(scene_id: str, split: str, n: int, first_id: int, rng) -> pd.DataFrame:
    """`n` walkers crossing the scene in straight lines at 1 FPS, N_PAST + T_F steps each."""
    steps = np.arange(N_PAST + T_F)
    rows = []
    for i in range(n):
        start = rng.uniform([40, 120], [180, IMAGE_HW[0] - 120])
        xy = start + steps[:, None] * rng.uniform([8, -2], [12, 2])
        rows.append(pd.DataFrame({
            "window_id": first_id + i, "scene_id": scene_id, "track_id": i, "step": steps,
            "frame": 30 * steps, "x": xy[:, 0], "y": xy[:, 1], "split": split, "t_f": T_F,
            "source": "release"}))
    return pd.concat(rows)


def write_fixture(root: Path, seeds: list[int]) -> dict:
    """Windows (6 train, 2 val, 3 test), scene images and maps; params.yaml's cpu profile with one
    epoch and one thread, Y-net's extra seeds `seeds` (slots 0, 1, 2). Returns the params."""
    write_walker_scenes(root, root / "release_tf30.parquet", IMAGE_HW, walkers)
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params["profile"] = "cpu"
    params["runtime"] = {"device": "cpu", "max_minutes": 0}
    params["ynet"]["cpu"].update(threads=1, epochs=1)
    params["ynet_seeds"]["slots"] = [0, 1, 2]
    params["ynet_seeds"]["cpu"] = {"seeds": seeds, "why_not": "" if seeds else "too slow here"}
    (root / "params.yaml").write_text(yaml.safe_dump(params))
    return params


INPUTS = ["--windows", "release_tf30.parquet", "--semantic-maps", "semantic_maps", "--sdd", "sdd",
          "--n-past", str(N_PAST)]


def train_seed(seed: int) -> None:
    train_ynet_seed.main(["--seed", str(seed), *INPUTS, "--checkpoint-dir", f"ck/seed{seed}",
                          "--metrics", f"m/ynet_seeds/train_seed{seed}.json"])


def evaluate_seed(seed: int) -> dict:
    evaluate_ynet_seed.main([*INPUTS, "--checkpoint-dir", f"ck/seed{seed}",
                             "--scoring", f"slots/seed{seed}.json", "--train-metrics",
                             f"m/ynet_seeds/train_seed{seed}.json",
                             "--metrics", f"m/ynet_seeds/seed{seed}.json"])
    return json.loads(Path(f"m/ynet_seeds/seed{seed}.json").read_text())


def weights(path: Path) -> dict[str, torch.Tensor]:
    return torch.load(path, weights_only=True)["model"]


def same_weights(a: Path, b: Path) -> bool:
    wa, wb = weights(a), weights(b)
    return wa.keys() == wb.keys() and all(torch.equal(wa[k], wb[k]) for k in wa)


def test_seed_stages_train_other_models_and_score_them_as_the_main_one(tmp_path, monkeypatch):
    params = write_fixture(tmp_path, seeds=[0, 1, 2])
    monkeypatch.chdir(tmp_path)
    ynet_slot_scoring.main(["--out", "slots"])
    train_ynet.main([*INPUTS, "--checkpoint-dir", "ck/main", "--model", "model.pt",
                     "--history", "history.csv", "--metrics", "m/ynet_train.json"])
    evaluate_ynet.main([*INPUTS, "--model", "model.pt", "--metrics", "m/ynet_eval.json",
                        "--predictions", "ynet.parquet", "--main-only"])
    main_eval = json.loads(Path("m/ynet_eval.json").read_text())
    main_train = json.loads(Path("m/ynet_train.json").read_text())
    for seed in (0, 1, 2):
        train_seed(seed)

    # seed 0 (the main seed) through the seed stage: the main model, bit for bit
    assert same_weights(Path("ck/seed0/best.pt"), Path("model.pt"))
    assert same_weights(Path("ck/seed0/best.pt"), Path("ck/main/best.pt"))
    # other seeds: other initial weights, batch order and augmentation draws, so other weights
    assert not same_weights(Path("ck/seed1/best.pt"), Path("ck/seed2/best.pt"))
    assert not same_weights(Path("ck/seed1/best.pt"), Path("model.pt"))
    main_settings = torch.load("model.pt", weights_only=True)["settings"]
    for seed in (0, 1, 2):
        settings = torch.load(f"ck/seed{seed}/best.pt", weights_only=True)["settings"]
        assert settings == {**main_settings, "seed": seed}  # only the seed differs
        facts = json.loads(Path(f"m/ynet_seeds/train_seed{seed}.json").read_text())
        assert facts["trained"] and facts["seed"] == seed and facts["profile"] == "cpu"
        assert set(main_train) - {"profile"} <= set(facts)
        assert facts["val_ade_per_epoch"] == [facts["best_val_ade"]]  # one epoch: the kept one
        assert sorted(p.name for p in Path(f"ck/seed{seed}").iterdir()) == ["best.pt", "history.csv",
                                                                            "last.pt"]
    assert json.loads(Path("m/ynet_seeds/train_seed0.json").read_text())["best_val_ade"] == \
        main_train["best_val_ade"]

    records = {seed: evaluate_seed(seed) for seed in (0, 1, 2)}
    # seed 0 scored by the seed stage: evaluate_ynet's main setting, round for round
    assert records[0]["main"] == main_eval["main"]
    eval_cpu = params["eval"]["cpu"]
    for seed, record in records.items():
        assert record["training_seed"] == seed and record["trained"]
        assert {k: record[k] for k in ("t_f", "n_windows", "rounds")} == {
            k: main_eval[k] for k in ("t_f", "n_windows", "rounds")} == {
            "t_f": T_F, "n_windows": 3, "rounds": eval_cpu["rounds"]}
        assert (record["main"]["k_e"], record["main"]["k_a"]) == (eval_cpu["k_e"], eval_cpu["k_a"])
        assert len(record["main"]["per_round"]) == eval_cpu["rounds"]
        assert "ablation" not in record and "ka_grid" not in record
        assert record["best_epoch"] == 1 and record["epochs"] == 1
    assert records[1]["main"]["ade"] != records[2]["main"]["ade"]  # other models, other errors

    # the spread's Y-net row, from these very files (seed 0 stands for the main model's)
    spec = seed_spread.YnetSeeds("cpu", 0, [1, 2], YnetSeedsParams(seeds=[1, 2]))
    entry = seed_spread.seed_spread(Path("m"), [], [], spec)["entries"][0]
    ades = [main_eval["main"]["ade"]["mean"], records[1]["main"]["ade"]["mean"],
            records[2]["main"]["ade"]["mean"]]
    assert entry["model"] == "ynet" and entry["seeds"] == [0, 1, 2]
    assert [s["ade"] for s in entry["per_seed"]] == ades
    assert entry["over_training_seeds"]["ade"]["mean"] == pytest.approx(np.mean(ades))
    assert entry["over_training_seeds"]["ade"]["std"] == pytest.approx(np.std(ades))
    assert entry["main_round_std"]["ade"] == main_eval["main"]["ade"]["std"]


def test_a_slot_the_profile_does_not_train_says_why_and_trains_nothing(tmp_path, monkeypatch):
    write_fixture(tmp_path, seeds=[])
    monkeypatch.chdir(tmp_path)
    ynet_slot_scoring.main(["--out", "slots"])

    def never(*args, **kwargs):
        raise AssertionError("a slot the profile does not list must not train")

    monkeypatch.setattr(ynet_training, "train", never)
    monkeypatch.setattr("pipeline.runners.ynet_main.train", never)
    train_seed(1)
    record = evaluate_seed(1)
    assert record == json.loads(Path("m/ynet_seeds/train_seed1.json").read_text())
    assert record["trained"] is False and record["seed"] == 1 and record["profile"] == "cpu"
    assert record["not_run_reason"] == ("Y-net is not trained with seed 1 in the cpu profile "
                                        "(its extra seeds here: none): too slow here")
    assert not any(Path("ck/seed1").iterdir())  # the declared output, empty


def test_the_cpu_profile_trains_no_extra_seed_and_says_why_and_paper_trains_two():
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    slots = ynet_seed_slots(params)
    cpu = load_profile(YnetSeedsParams, "ynet_seeds", {**params, "profile": "cpu"})
    paper = load_profile(YnetSeedsParams, "ynet_seeds", {**params, "profile": "paper"})
    assert cpu.seeds == [] and "30 min" in cpu.why_not and "paper" in cpu.why_not
    assert paper.seeds == [1, 2] and set(paper.seeds) <= set(slots)
    for profile, section in (("cpu", cpu), ("paper", paper)):
        assert params["ynet"][profile]["seed"] not in section.seeds + slots
    reason = cpu.not_run_reason("cpu")
    assert reason.startswith("Y-net is not trained with extra training seeds in the cpu profile "
                             "(its extra seeds here: none): on 2 CPU cores")


@pytest.mark.parametrize("values", [{"seeds": [1, 1]}, {"seeds": [-1]}, {"seeds": [True]},
                                    {"seeds": []}, {"seeds": [], "why_not": "  "}])
def test_bad_ynet_seeds_params_fail(values):
    with pytest.raises(ParamsError):
        from_dict(YnetSeedsParams, values, "ynet_seeds.cpu")
    with pytest.raises(ParamsError, match="slots"):
        ynet_seed_slots({"ynet_seeds": {"slots": [2, 2]}})


# ---------------------------------------------------------------------------------------------
# The Y-net row of the spread, hand-checked


def ynet_record(ade: float, fde: float, *, round_std: float = 0.5, k_e: int = 20,
                training_seed: int | None = None, best_epoch: int = 3) -> dict:
    """A Y-net metrics record as evaluate_ynet_seed writes it (only the keys the spread reads);
    without `training_seed`, evaluate_ynet's (whose training facts are in ynet_train.json)."""
    main = {**{key: {"mean": value, "std": round_std} for key, value in
               (("ade", ade), ("fde", fde), ("ade_joint", ade), ("fde_joint", fde + 1.0))},
            "k_e": k_e, "k_a": 1, "rounds": 3, "per_round": []}
    record = {"profile": "paper", "t_f": 30, "n_windows": 382, "rounds": 3, "main": main}
    if training_seed is None:
        return record
    return {**record, "trained": True, "training_seed": training_seed, "epochs": 300,
            "best_epoch": best_epoch, "best_val_ade": 100.0 + best_epoch}


def write_ynet(folder: Path, records: dict[int, dict], not_run: tuple[int, ...] = ()) -> None:
    (folder / "ynet_seeds").mkdir(parents=True, exist_ok=True)
    for seed, record in records.items():
        if seed == 0:
            (folder / "ynet_eval.json").write_text(json.dumps(record))
            (folder / "ynet_train.json").write_text(json.dumps(
                {"epochs": 300, "best_epoch": 7, "best_val_ade": 107.0, "profile": "paper"}))
        else:
            seed_spread.ynet_seed_path(folder, seed).write_text(json.dumps(record))
    for seed in not_run:
        seed_spread.ynet_seed_path(folder, seed).write_text(json.dumps(
            {"seed": seed, "profile": "cpu", "trained": False, "not_run_reason": "no time"}))


def paper_seeds() -> dict[int, dict]:
    # ADE 10, 12, 14: mean 12, population std sqrt(8 / 3) = 1.632993
    # FDE 20, 20, 26: mean 22, population std sqrt(24 / 3) = 2.828427
    return {0: ynet_record(10.0, 20.0, round_std=0.25),
            1: ynet_record(12.0, 20.0, training_seed=1, best_epoch=30),
            2: ynet_record(14.0, 26.0, training_seed=2, best_epoch=12)}


PAPER = seed_spread.YnetSeeds("paper", 0, [1, 2], YnetSeedsParams(seeds=[1, 2]))


def test_ynet_spread_over_seeds_hand_checked(tmp_path):
    write_ynet(tmp_path, paper_seeds())
    entry = seed_spread.ynet_entry(tmp_path, PAPER)
    assert (entry["model"], entry["horizon"], entry["seeds"], entry["main_seed"]) == ("ynet", 30, [0, 1, 2], 0)
    over = entry["over_training_seeds"]
    assert over["ade"]["mean"] == pytest.approx(12.0) and over["ade"]["std"] == pytest.approx(1.632993, abs=1e-6)
    assert over["fde"]["mean"] == pytest.approx(22.0) and over["fde"]["std"] == pytest.approx(2.828427, abs=1e-6)
    assert (over["ade"]["min"], over["ade"]["max"]) == (10.0, 14.0)
    assert over["fde_joint"]["mean"] == pytest.approx(23.0)
    assert entry["main_round_std"] == {"ade": 0.25, "fde": 0.25}  # the main model's evaluation rounds
    assert [(s["seed"], s["best_epoch"], s["best_val_ade"], s["trained_epochs"]) for s in entry["per_seed"]] == [
        (0, 7, 107.0, 300), (1, 30, 130.0, 300), (2, 12, 112.0, 300)]
    assert entry["evaluation"] == {"t_f": 30, "n_windows": 382, "rounds": 3, "k_e": 20, "k_a": 1}
    assert "not_run_reason" not in entry


def test_ynet_row_says_why_when_the_profile_trains_no_extra_seed(tmp_path):
    write_ynet(tmp_path, {0: paper_seeds()[0]}, not_run=(1, 2))
    spec = seed_spread.YnetSeeds("cpu", 0, [1, 2], YnetSeedsParams(seeds=[], why_not="no time"))
    entry = seed_spread.ynet_entry(tmp_path, spec)
    assert entry["not_run_reason"] == ("Y-net is not trained with extra training seeds in the cpu "
                                       "profile (its extra seeds here: none): no time")
    assert "over_training_seeds" not in entry and entry["seeds"] == [0]
    assert [(s["seed"], s["ade"]) for s in entry["per_seed"]] == [(0, 10.0)]
    assert entry["main_round_std"] == {"ade": 0.25, "fde": 0.25}


@pytest.mark.parametrize("change, spec, message", [
    (lambda rs: rs[1]["main"].update(k_e=10), PAPER,
     r"ynet_seeds/seed1\.json: scored with .*'k_e': 10.*differ only in training"),
    (lambda rs: rs[2].update(training_seed=1), PAPER, r"seed2\.json: model trained with seed 1, expected 2"),
    (lambda rs: rs[1].pop("best_epoch"), PAPER, r"seed1\.json: best_epoch: missing"),
    (lambda rs: rs[2]["main"].pop("fde"), PAPER, r"seed2\.json: main\.fde: missing"),
    (lambda rs: rs.pop(2), PAPER, r"seed2\.json: missing"),
    (lambda rs: None, seed_spread.YnetSeeds("paper", 0, [1, 2], YnetSeedsParams(seeds=[1], why_not="x")),
     r"seed2\.json: trained, but params\.yaml:ynet_seeds\.paper\.seeds \[1\] does not list seed 2"),
    (lambda rs: rs.update({2: {"trained": False}}), PAPER,
     r"seed2\.json: not trained, but params\.yaml:ynet_seeds\.paper\.seeds \[1, 2\] lists seed 2"),
    (lambda rs: None, seed_spread.YnetSeeds("paper", 0, [1], YnetSeedsParams(seeds=[1, 2])),
     r"seeds \[2\] are not in ynet_seeds\.slots \[1\], so no stage trains them"),
    (lambda rs: None, seed_spread.YnetSeeds("paper", 1, [1, 2], YnetSeedsParams(seeds=[1, 2])),
     r"holds ynet\.paper\.seed 1, the main model's"),
])
def test_a_bad_ynet_seed_record_or_list_is_named(tmp_path, change, spec, message):
    records = paper_seeds()
    change(records)
    write_ynet(tmp_path, records)
    with pytest.raises(IntermediateError, match=message):
        seed_spread.ynet_entry(tmp_path, spec)


def test_the_spread_stage_puts_ynet_first_and_the_cpu_profile_says_why(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    metrics = Path("m")
    for model in seed_spread.MODELS:
        write_records(metrics, model, 50, 0, three_seeds())
    write_ynet(metrics, {0: paper_seeds()[0]}, not_run=(1, 2))
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    Path("params.yaml").write_text(yaml.safe_dump({
        "profile": "cpu", "windows": {"horizons": [50]}, "baseline_seeds": {"extra": [1, 2]},
        "ynet": {"cpu": {"seed": 0}}, "ynet_seeds": params["ynet_seeds"]}))
    baseline_seed_spread.main(["--metrics", "m", "--out", "spread.json"])
    spread = json.loads(Path("spread.json").read_text())
    assert spread["models"] == ["ynet", "sgan", "pecnet", "rpecnet"]
    assert (spread["profile"], spread["ynet_extra_seeds"], spread["extra_seeds"]) == ("cpu", [], [1, 2])
    assert [e["model"] for e in spread["entries"]] == ["ynet", "sgan", "pecnet", "rpecnet"]
    ynet = spread["entries"][0]
    assert ynet["not_run_reason"].startswith("Y-net is not trained with extra training seeds in the "
                                             "cpu profile (its extra seeds here: none): on 2 CPU cores")
    assert spread["entries"][2]["over_training_seeds"]["ade"]["mean"] == pytest.approx(12.0)
