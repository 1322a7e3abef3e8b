"""Tables 1-2's training-seed spread (`pipeline.report.short_term_seeds`) and the study that makes
its runs (studies/dvc.yaml, `pipeline.stages.short_term_seed`, tools/run_study.py)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pipeline.report.lookups import MetricsStore
from pipeline.report.short_term_seeds import (average_range, seed_rows, seed_runs, short_term_seeds,
                                              value_range)
from pipeline.runners.studies import with_overrides

REPO = Path(__file__).resolve().parents[1]


def run_record(ade20: float, fde20: float, seed: int | None = None, ade5: float | None = None) -> dict:
    record = {"ks": [20] + ([5] if ade5 is not None else []),
              "k20": {"ade": {"mean": ade20}, "fde": {"mean": fde20}}}
    if ade5 is not None:
        record["k5"] = {"ade": {"mean": ade5}, "fde": {"mean": 2 * ade5}}
    if seed is not None:
        record |= {"training_seed": seed, "machine": {"cpu": "test CPU"}}
    return record


def stores(headline: dict, study: dict) -> tuple[MetricsStore, MetricsStore]:
    return MetricsStore("metrics", headline), MetricsStore("studies/short_term_seeds", study)


def test_the_headline_run_comes_first_and_a_study_run_of_its_own_seed_is_not_counted_twice():
    metrics, studies = stores({"short_term/runs/sdd_pecnet.json": run_record(10.0, 16.0, ade5=14.0)},
                              {"sdd_pecnet_seed2.json": run_record(10.5, 16.5, 2),
                               "sdd_pecnet_seed1.json": run_record(9.5, 17.0, 1),
                               "sdd_pecnet_seed0.json": run_record(11.0, 15.0, 0),  # the headline's
                               "sdd_sgan_seed1.json": run_record(13.0, 23.0, 1),
                               "sdd_pecnet_seed3.json": run_record(1.0, 1.0, 4)})  # misnamed
    runs = seed_runs(metrics, studies, "sdd", "pecnet", headline_seed=0)
    assert [(run.seed, run.headline) for run in runs] == [(0, True), (1, False), (2, False)]
    assert runs[0].values == {"k20.ade": 10.0, "k20.fde": 16.0, "k5.ade": 14.0, "k5.fde": 28.0}
    assert runs[1].cpu == "test CPU" and runs[1].source == "studies/short_term_seeds/sdd_pecnet_seed1.json"
    seeds = short_term_seeds(metrics, studies, headline_seed=0)
    assert seeds.range("sdd", "pecnet", 20, "ade") == (9.5, 10.5, 3)
    assert seeds.range("sdd", "pecnet", 20, "fde") == (16.0, 17.0, 3)
    assert seeds.range("sdd", "pecnet", 5, "ade") is None  # K = 5 scored by the headline alone
    assert seeds.range("sdd", "sgan", 20, "ade") is None  # one seed, no range
    assert seeds.range("eth", "sgan", 20, "ade") is None  # nothing run
    rows = seed_rows(seeds)
    assert [(r["dataset"], r["model"], len(r["runs"])) for r in rows] == [("sdd", "sgan", 1),
                                                                          ("sdd", "pecnet", 3)]


@pytest.mark.parametrize("values, expected", [([], None), ([3.0], None), ([3.0, 1.0], (1.0, 3.0, 2)),
                                              ([2.0, 2.0, 5.0], (2.0, 5.0, 3))])
def test_a_range_needs_two_seeds(values, expected):
    assert value_range(values) == expected


def test_the_average_range_is_over_the_seeds_run_on_every_fold():
    metrics, studies = stores(
        {f"short_term/runs/{fold}_sgan.json": run_record(0.1 * i, 1.0) for i, fold in
         enumerate(("eth", "hotel", "univ", "zara1", "zara2"), 1)},
        {**{f"{fold}_sgan_seed1.json": run_record(0.1 * i + 0.05, 1.0, 1) for i, fold in
            enumerate(("eth", "hotel", "univ", "zara1", "zara2"), 1)},
         "eth_sgan_seed2.json": run_record(9.0, 9.0, 2)})  # seed 2 on one fold only: left out
    seeds = short_term_seeds(metrics, studies, headline_seed=0)
    low, high, count = seeds.average("sgan", "ade")
    assert (low, high, count) == (pytest.approx(0.3), pytest.approx(0.35), 2)  # seeds 0 and 1
    assert seeds.range("eth", "sgan", 20, "ade") == (0.1, 9.0, 3)  # the fold's own range has it
    per_fold = {"eth": seeds.runs[("eth", "sgan")], "hotel": []}
    assert average_range(per_fold, "k20.ade") is None  # a fold without runs: no common seed


def test_the_seed_run_changes_only_the_training_seed():
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    changed = with_overrides(params, {"train_baseline.seed": 7})
    assert changed["train_baseline"] == {**params["train_baseline"], "seed": 7}
    assert {k: v for k, v in changed.items() if k != "train_baseline"} == \
        {k: v for k, v in params.items() if k != "train_baseline"}
    assert params["train_baseline"]["seed"] != 7  # the original is left as it was


def test_every_study_stage_is_frozen_and_writes_only_committed_records_the_report_reads():
    studies = yaml.safe_load((REPO / "studies/dvc.yaml").read_text())["stages"]
    report = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]["report"]
    for name, stage in studies.items():
        body = stage.get("do", stage)
        assert body.get("frozen") is True, f"{name}: not frozen, so make repro would run it"
        outs = body["outs"]
        assert all(isinstance(out, dict) and next(iter(out.values())) == {"cache": False}
                   for out in outs), f"{name}: an output not committed to git"
        folders = {Path(next(iter(out))).parent.as_posix() for out in outs}
        assert folders <= set(report["deps"]), f"{name}: the report does not depend on {folders}"
    gitignore = (REPO / ".gitignore").read_text()
    assert "/studies" not in gitignore


def test_every_study_run_listed_has_its_record_committed():
    """`dvc repro` stops on a frozen stage whose output is missing: list only made runs."""
    from dvc.repo import Repo
    stages = Repo(str(REPO)).stage.collect(str(REPO / "studies/dvc.yaml"))
    missing = [f"{stage.addressing}: {out}" for stage in stages for out in stage.outs
               if not (REPO / str(out)).is_file()]
    assert stages and missing == []
