"""The benchmark registry (`pipeline.benchmarks.registry`): which benchmarks there are, what each
short-term one says about itself (unit, truth columns, table, prediction benchmark, the raw
sources it reads) and the params keys its settings come from (`settings_key`: sdd or ethucy), and
what the report asks of every one (its names in the paper and the studies, where its records
are)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from pipeline.benchmarks.ethucy import FOLDS, EthUcyFold
from pipeline.benchmarks.ind import IND
from pipeline.benchmarks.registry import (BENCHMARKS, SHORT_TERM, get, long_term, scored,
                                         short_term, studied)
from pipeline.benchmarks.short_term import ScoringSources
from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.benchmarks.trajnet_sdd import TRAJNET_SDD, TrajnetSdd
from pipeline.config.loading import load_profile, read_params
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.ynet import YnetSettings
from pipeline.dataset_list import SHORT_TERM_DATASETS
from pipeline.runners.short_term import missing_raw_source
from pipeline.splits import FOLD_TEST_SCENES

REPO = Path(__file__).resolve().parents[1]
FOLD_NAMES = ("eth", "hotel", "univ", "zara1", "zara2")
N_FUTURE = 12


@pytest.fixture(scope="module")
def params() -> dict:
    return read_params(REPO / "params.yaml")


@pytest.fixture(scope="module")
def short(params) -> ShortTermModelsParams:
    """`short_term_models.<profile>` of the repository's params.yaml, with every per-benchmark
    value told apart (SDD's differs from ETH/UCY's), so reading the wrong key fails."""
    loaded = load_profile(ShortTermModelsParams, "short_term_models", params)
    epochs = {model: {"sdd": 10 + i, "ethucy": 20 + i} for i, model in enumerate(loaded.epochs)}
    return replace(loaded, epochs=epochs, k_sdd=[20, 5], k_ethucy=[7],
                   rel_threshold={"sdd": 0.01, "ethucy": 0.002})


def test_the_registry_lists_every_benchmark_once_under_its_name():
    assert list(BENCHMARKS) == ["sdd_long_term", "trajnet_sdd",
                                *(f"ethucy_{fold}" for fold in FOLD_NAMES), "ind"]
    names = [benchmark.name for benchmark in BENCHMARKS.values()]
    assert len(set(names)) == len(names)
    for key, benchmark in BENCHMARKS.items():
        assert benchmark.name == key and get(key) is benchmark
    assert BENCHMARKS["sdd_long_term"] is SDD_LONG_TERM and BENCHMARKS["ind"] is IND
    assert BENCHMARKS["trajnet_sdd"] is TRAJNET_SDD
    with pytest.raises(KeyError, match="no benchmark 'nope'"):
        get("nope")


def test_every_dataset_has_its_short_term_benchmark_in_order():
    assert list(SHORT_TERM) == list(SHORT_TERM_DATASETS) == ["sdd", *FOLD_TEST_SCENES]
    for dataset in SHORT_TERM_DATASETS:
        benchmark = short_term(dataset)
        assert benchmark.dataset == dataset and BENCHMARKS[benchmark.name] is benchmark
    assert isinstance(short_term("sdd"), TrajnetSdd) and short_term("sdd").settings_key == "sdd"
    for fold in FOLD_NAMES:
        assert isinstance(short_term(fold), EthUcyFold) and short_term(fold) is FOLDS[fold]
        assert short_term(fold).settings_key == "ethucy"


def test_units_truth_columns_and_tables():
    sdd = short_term("sdd")
    assert (sdd.unit, sdd.truth_columns) == ("px", ("x", "y"))
    assert sdd.table(Path("w")) == Path("w/sdd_trajnet.parquet")
    assert sdd.prediction_benchmark() == "short_term_sdd_trajnet"
    for fold in FOLD_NAMES:
        benchmark = short_term(fold)
        assert (benchmark.unit, benchmark.truth_columns) == ("m", ("x_m", "y_m"))
        assert benchmark.table(Path("w")) == Path(f"w/ethucy_{fold}.parquet")
        assert benchmark.prediction_benchmark() == f"short_term_ethucy_{fold}"
        assert benchmark.maps(Path("w")) == Path("w/ethucy_semantic")
    assert (SDD_LONG_TERM.unit, IND.unit) == ("px", "px")


def test_prediction_metadata_names_the_table_and_its_columns():
    metadata = short_term("zara1").prediction_metadata(Path("w"), "sgan", [20, 5], extra=1)
    assert metadata == {"model": "sgan", "benchmark": "short_term_ethucy_zara1", "unit": "m",
                        "truth_columns": ["x_m", "y_m"], "split": "test",
                        "window_table": str(Path("w/ethucy_zara1.parquet")), "k": 20,
                        "ks_scored": [20, 5], "extra": 1}
    assert "k" not in short_term("sdd").prediction_metadata(Path("w"), "ynet")
    assert SDD_LONG_TERM.prediction_benchmark(Path("h/tf30.parquet")) == "sdd_long_term_tf30"
    assert IND.prediction_metadata("ynet")["benchmark"] == IND.prediction_benchmark() \
        == "ind_long_term"


def test_an_unknown_dataset_names_the_known_ones():
    with pytest.raises(KeyError, match=r"no short-term dataset 'nope'; known: \['sdd', 'eth', "
                                       r"'hotel', 'univ', 'zara1', 'zara2'\]"):
        short_term("nope")


def test_ynet_settings_take_the_benchmarks_scale_and_epochs(params, short):
    base = load_profile(YnetSettings, "ynet", params)
    assert short.ynet_sdd.resize != short.ynet_ethucy.resize  # else the check below cannot fail
    for dataset in SHORT_TERM_DATASETS:
        benchmark = short_term(dataset)
        scale = short.ynet_sdd if dataset == "sdd" else short.ynet_ethucy
        settings = benchmark.ynet_settings(base, short, N_FUTURE, 3)
        assert (settings.resize, settings.kernel_size, settings.sigma, settings.crop) \
            == (scale.resize, scale.kernel_size, scale.sigma, scale.crop), dataset
        assert settings.waypoints == [N_FUTURE - 1] and settings.semantic_classes == 3
        assert settings.epochs == short.epochs["ynet"][benchmark.settings_key] \
            == (10 if dataset == "sdd" else 20)
        assert settings.steps_per_epoch == short.ynet_steps_per_epoch


def test_ks_threshold_and_epochs_read_the_benchmarks_key(short):
    assert short_term("sdd").ks(short) == [20, 5]
    assert short_term("sdd").rel_threshold(short) == 0.01
    for fold in FOLD_NAMES:
        assert short_term(fold).ks(short) == [7]
        assert short_term(fold).rel_threshold(short) == 0.002
    for i, model in enumerate(short.epochs):
        assert short_term("sdd").epochs(short, model) == 10 + i
        assert short_term("zara2").epochs(short, model) == 20 + i


def test_each_benchmark_says_how_the_paper_the_studies_and_the_records_name_it():
    assert long_term("sdd") is SDD_LONG_TERM and long_term("ind") is IND
    with pytest.raises(KeyError, match="no long-term benchmark 'eth'"):
        long_term("eth")
    assert studied("sdd_long") is SDD_LONG_TERM and studied("sdd") is TRAJNET_SDD
    assert studied("zara2") is FOLDS["zara2"] and studied("ind") is None and studied("") is None
    assert scored("ind") is IND and scored("sdd") is TRAJNET_SDD and scored("nope") is None
    assert [b.label for b in SHORT_TERM.values()] == ["SDD (TrajNet)", "ETH", "Hotel", "Univ",
                                                     "Zara1", "Zara2"]
    assert FOLDS["hotel"].in_paper == "Table 2, HOTEL fold" and FOLDS["hotel"].paper_key == "hotel"


def test_each_benchmark_says_where_its_records_are():
    assert [b.summary_file for b in SHORT_TERM.values()] == [
        "sdd.json", *(f"ethucy_{fold}.json" for fold in FOLD_NAMES)]
    assert TRAJNET_SDD.table_k is None and {f.table_k for f in FOLDS.values()} == {20}
    assert (SDD_LONG_TERM.metrics_file, IND.metrics_file) == ("ynet_eval.json",
                                                              "ind_benchmark.json")
    assert SDD_LONG_TERM.baseline_metrics("sgan", 30) == ("baselines/sgan_tf30.json", ())
    assert IND.baseline_metrics("sgan", 30) == ("ind_benchmark.json", ("baselines", "sgan"))
    assert SDD_LONG_TERM.stored_scores("sgan", "tf30") == (
        "beyond/long_term.json", ("tables", "tf30", "models", "sgan"))
    assert IND.stored_scores("sgan", "tf30") == (
        "beyond/ind.json", ("benchmarks", "ind", "models", "sgan"))


def test_ynet_stages_ask_the_benchmark_which_raw_sources_it_reads():
    sdd, eth = short_term("sdd"), short_term("eth")
    assert sdd.raw_sources(images=True) == sdd.raw_sources(images=False) == ("sdd",)
    assert eth.raw_sources(images=True) == ("ethucy-scenes",) and not eth.raw_sources(images=False)
    given = {"sdd": None, "ethucy_scenes": Path("scenes")}  # a stage's vars(args)
    assert missing_raw_source(sdd, given, images=False) == "Y-net on sdd needs --sdd"
    assert missing_raw_source(eth, given, images=True) is None
    assert missing_raw_source(eth, {"sdd": Path("sdd")}, images=True) == \
        "Y-net on eth needs --ethucy-scenes"
    assert missing_raw_source(eth, {}, images=False) is None


def test_the_folds_read_the_road_maps_once(tmp_path):
    reads = []
    sources = ScoringSources(tmp_path, 8)
    for fold in FOLDS.values():
        assert sources.masks(fold.maps(tmp_path), lambda folder: reads.append(folder) or "maps") \
            == "maps"
    assert reads == [tmp_path / "ethucy_semantic"]
