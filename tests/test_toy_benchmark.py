"""A new benchmark needs its module and one registry line: the toy short-term benchmark of
tests/toy_benchmark.py, registered here, goes through the short-term stages as dvc.yaml runs them.

Besides its module and registry line it brings what any benchmark brings: its name among the
short-term datasets (`pipeline.dataset_list`, which the params' `ynet_datasets` is checked
against), its params (the tiny ones of tests/test_short_term_models.py, Y-net trained on it) and
its dvc.yaml entries (`TOY_RUNS`: the foreach items of the training and scoring stages). Each
stage runs in-process (the registry is patched in this process only), with the command dvc.yaml
gives it for those items, in a project folder laid out as the pipeline's: Y-net and PECNet train
and score on it, `short_term_tables` merges its runs into its own file and
`score_short_term_predictions` scores its stored predictions beside the other benchmarks' (here
"not run" files). Its windows are written with the fixtures' writer: `short_term_windows` builds
the paper's tables from their raw sources alone.
"""

from __future__ import annotations

import importlib
import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml

from pipeline import dataset_list
from pipeline.benchmarks import registry
from pipeline.config.loading import read_params
from pipeline.harness.predictions import write_no_predictions
from tests.test_score_predictions import write_labels
from tests.test_short_term_models import tiny_params, tracks, window_table, write_ethucy, write_maps
from tests.toy_benchmark import SCENE_HW, TOY
from ynet.segmentation import CLASS_NAMES

REPO = Path(__file__).resolve().parents[1]
TOY_MAPS = "data/short_term/toy_semantic"
# The toy's dvc.yaml entries: its item in each foreach of the short-term training and scoring
# stages (as sdd's and eth's are written there).
TOY_RUNS = {"train_short_term_ynet": ("toy", {"maps": TOY_MAPS, "benchmark": "ethucy"}),
            "evaluate_short_term_ynet": ("toy", {"maps": TOY_MAPS, "benchmark": "ethucy"}),
            "train_short_term_baseline": ("toy-pecnet", {"dataset": "toy", "model": "pecnet",
                                                         "benchmark": "ethucy"}),
            "evaluate_short_term_baseline": ("toy-pecnet", {"dataset": "toy", "model": "pecnet",
                                                            "benchmark": "ethucy"}),
            "short_term_tables": None, "score_short_term_predictions": None}


def stage_argv(stage: dict, entry: tuple[str, dict] | None) -> tuple[str, list[str]]:
    """(module, arguments) of a dvc.yaml stage's command, for the foreach `entry` (key, item)."""
    cmd = " ".join(str(stage.get("do", stage)["cmd"]).split())
    if entry is not None:
        key, item = entry
        cmd = re.sub(r"\$\{item\.(\w+)\}", lambda m: str(item[m.group(1)]), cmd)
        cmd = cmd.replace("${key}", key)
    tokens = shlex.split(cmd.replace("${keep_freed_memory}", ""))
    at = tokens.index("-m")
    return tokens[at + 1], tokens[at + 2:]


def write_project(root: Path) -> None:
    """params.yaml, the toy's windows and Y-net maps, and what scoring reads of the others: SDD's
    labels and scales, the ETH/UCY road maps, a "not run" predictions file per benchmark."""
    real = read_params(REPO / "params.yaml")
    params = tiny_params()
    for profile in ("cpu", "paper"):
        params["short_term_models"][profile]["ynet_datasets"] = [TOY.dataset]
    params["score_predictions"] = real["score_predictions"]
    (root / "params.yaml").write_text(yaml.safe_dump(params))
    windows = root / "data" / "short_term"
    write_ethucy(windows)  # the ETH/UCY road maps scoring reads
    rng = np.random.default_rng(2)
    scenes = [f"toy_{i}" for i in range(3)]
    table = window_table([(scene, split, tracks(n, rng, SCENE_HW)) for scene, split, n
                          in zip(scenes, ("train", "val", "test"), (12, 4, 5))])
    table.to_parquet(TOY.table(windows), index=False)
    write_maps(root / TOY_MAPS, scenes, CLASS_NAMES)
    write_labels(root / "data" / "labels")
    (root / "data" / "raw" / "sdd").mkdir(parents=True)
    (root / "data" / "raw" / "sdd" / "estimated_scales.yaml").write_text(yaml.safe_dump(
        {"gates": {"video2": {"scale": 0.1, "certainty": 1.0}}}))
    for dataset, benchmark in registry.SHORT_TERM.items():
        if benchmark is not TOY:
            write_no_predictions(root / "data" / "predictions" / "short_term" / dataset
                                 / "ynet.parquet", benchmark.prediction_metadata(windows, "ynet"),
                                 "not run in this test")


@pytest.fixture
def toy(monkeypatch):
    """The toy registered: its registry line, and its name among the short-term datasets."""
    monkeypatch.setitem(registry.SHORT_TERM, TOY.dataset, TOY)
    monkeypatch.setitem(registry.BENCHMARKS, TOY.name, TOY)
    monkeypatch.setattr(dataset_list, "SHORT_TERM_DATASETS",
                        (*dataset_list.SHORT_TERM_DATASETS, TOY.dataset))
    return TOY


def test_a_toy_benchmark_runs_through_the_short_term_stages(toy, tmp_path, monkeypatch):
    write_project(tmp_path)
    monkeypatch.chdir(tmp_path)  # stages read ./params.yaml and the paths dvc.yaml gives
    torch.set_num_threads(1)
    stages = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]
    for name, entry in TOY_RUNS.items():
        module, argv = stage_argv(stages[name], entry)
        assert module == f"pipeline.stages.{name}"
        importlib.import_module(module).main(argv)

    runs = Path("metrics/short_term/runs")
    for model in ("ynet", "pecnet"):
        record = json.loads((runs / f"toy_{model}.json").read_text())
        assert (record["dataset"], record["trained"], record["unit"]) == ("toy", True, "px")
        assert record["ks"] == [20] and record["n_windows"] == 5  # ETH/UCY's K, the toy's tests
    summary = json.loads(Path("metrics/short_term/toy.json").read_text())
    assert (summary["dataset"], summary["unit"]) == ("toy", "px")
    assert set(summary["models"]) == {"ynet", "pecnet"}
    assert summary["models"]["ynet"]["ade"]["mean"] > 0  # the one K of its table, unnested

    scored = json.loads(Path("metrics/beyond/short_term.json").read_text())["benchmarks"]
    assert list(scored) == list(registry.SHORT_TERM)  # the paper's benchmarks, then the toy
    assert scored["toy"]["benchmark"] == "short_term_toy" and scored["toy"]["unit"] == "px"
    assert scored["toy"]["n_windows"] == 5
    for model in ("ynet", "pecnet"):
        assert scored["toy"]["models"][model]["metrics"]["ade"]["mean"] > 0
    assert "not_run_reason" in scored["sdd"]["models"]["ynet"]
    assert Path("data/predictions/short_term/toy/ynet_qualitative.npz").exists()
