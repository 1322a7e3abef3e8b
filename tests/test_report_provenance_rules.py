"""The rules of `pipeline.report.provenance` at their boundaries: the training-seed range (its
ends included, one seed giving none, the model, horizon and metric it is read for), the `far` band
(its edge within), which number decides a cell and in which order causes are tried, the AVG of
Table 2 under a protocol (the mean of five different scenes), the metric key of each protocol, and
how causes are counted and listed. The cause named where nothing explains a cell is
`provenance.CAUSES[-1]`."""

from __future__ import annotations

import pytest

from pipeline.report import provenance
from pipeline.report.lookups import Absent, Measured, MetricsStore

QUOTED = provenance.CellSource("quoted", "a paper", "pecnet_best_endpoint")
AUTHORS = provenance.CellSource("ynet_authors", "Y-net authors' run", "independent_min")
NO_CAUSE = provenance.CAUSES[-1]


def entry(model: str, horizon: int, ade: dict[int, float], fde: dict[int, float]) -> dict:
    """A seed-spread entry as stage baseline_seed_spread writes it (min / max per metric; one seed
    gives min = max and std 0)."""
    def summary(values: dict[int, float]) -> dict:
        return {"mean": sum(values.values()) / len(values), "std": 0.0,
                "min": min(values.values()), "max": max(values.values())}
    return {"model": model, "horizon": horizon, "seeds": list(ade),
            "over_training_seeds": {"ade": summary(ade), "fde": summary(fde)}}


def seeds_store(*entries: dict) -> MetricsStore:
    return MetricsStore("metrics", {provenance.SEED_SPREAD_FILE: {"entries": list(entries)}})


# ---------------------------------------------------------------------------------------------
# The range over training seeds


def test_the_seed_range_is_read_for_its_model_horizon_and_metric():
    metrics = seeds_store(entry("pecnet", 20, {0: 40.0, 1: 44.0}, {0: 80.0, 1: 90.0}),
                          entry("pecnet", 30, {0: 80.0, 1: 76.0, 2: 89.0}, {0: 175.0, 1: 149.0, 2: 199.0}),
                          entry("sgan", 30, {0: 93.0, 1: 99.0}, {0: 168.0, 1: 178.0}))
    assert provenance.seed_range(metrics, "pecnet", 30, "ade") == (76.0, 89.0, 3)
    assert provenance.seed_range(metrics, "pecnet", 30, "fde") == (149.0, 199.0, 3)
    assert provenance.seed_range(metrics, "pecnet", 20, "fde") == (80.0, 90.0, 2)
    assert provenance.seed_range(metrics, "sgan", 30, "ade") == (93.0, 99.0, 2)
    assert provenance.seed_range(metrics, "rpecnet", 30, "ade") is None
    assert provenance.seed_range(metrics, "pecnet", 40, "ade") is None


def test_one_training_seed_has_no_range_even_where_its_entry_has_a_min_and_max():
    """A baseline trained with one seed gets min = max = its value from the stage: no range."""
    metrics = seeds_store(entry("pecnet", 30, {0: 82.64}, {0: 175.14}))
    assert provenance.seed_range(metrics, "pecnet", 30, "ade") is None
    assert provenance.why_differs(82.64, 0.5, None, 0.2, AUTHORS,
                                  provenance.seed_range(metrics, "pecnet", 30, "ade")).verdict == NO_CAUSE
    assert provenance.seed_range(MetricsStore("metrics", {}), "pecnet", 30, "ade") is None


@pytest.mark.parametrize("paper, inside", [
    (90.0, True),  # the range's ends are in it
    (110.0, True),
    (100.0, True),
    (89.99, False),
    (110.01, False),
])
def test_the_seed_range_includes_its_ends(paper, inside):
    why = provenance.why_differs(paper, 0.5, None, 0.2, AUTHORS, (90.0, 110.0, 3))
    assert why.verdict == ("seed spread" if inside else NO_CAUSE)
    if inside:
        assert f"paper {paper:g} within our 3 training seeds' range" in why.detail


# ---------------------------------------------------------------------------------------------
# The far band and which number decides


@pytest.mark.parametrize("diff, far, inside", [
    (0.25, 0.25, True), (-0.25, 0.25, True), (0.2500001, 0.25, False), (-0.2500001, 0.25, False),
    (0.0, 0.0, True), (None, 0.25, False),
])
def test_the_far_bands_edge_is_within(diff, far, inside):
    assert provenance.within(diff, far) is inside


def test_a_headline_on_the_bands_edge_is_a_match():
    assert provenance.why_differs(100.0, 0.25, None, 0.25, AUTHORS) == provenance.Why("match")
    assert provenance.why_differs(100.0, -0.25, None, 0.25, AUTHORS) == provenance.Why("match")
    found = provenance.why_differs(100.0, 0.5, 0.25, 0.25, QUOTED)
    assert found.verdict == "protocol" and "+25.0 %" in found.detail


def test_the_cells_own_protocol_decides_where_ours_is_scored_under_it():
    """The headline within the band is no match when the cell's own protocol is far; under the
    headline or an unknown protocol the headline decides."""
    found = provenance.why_differs(100.0, 0.1, 0.4, 0.2, QUOTED)
    assert found.verdict == NO_CAUSE and "+40.0 % under PECNet best endpoint" in found.detail
    assert provenance.why_differs(100.0, 0.1, 0.4, 0.2, AUTHORS).verdict == "match"
    unknown = provenance.CellSource("quoted", "c paper", "unknown")
    assert provenance.why_differs(100.0, 0.1, 0.4, 0.2, unknown).verdict == "match"


def test_causes_are_tried_in_order_seeds_then_epochs_selected_on_test():
    """The training-seed range before upstream's epoch selection on the test set (compat), which
    names `protocol` only within the band; nothing else: no cause."""
    seeds = (90.0, 110.0, 3)
    assert provenance.why_differs(100.0, 0.5, None, 0.2, QUOTED, seeds, 0.1).verdict == "seed spread"
    found = provenance.why_differs(100.0, 0.5, None, 0.2, QUOTED, None, 0.2)
    assert found.verdict == "protocol" and "+20.0 %" in found.detail
    found = provenance.why_differs(100.0, 0.5, None, 0.2, QUOTED, None, 0.3)
    assert found.verdict == NO_CAUSE and "+30.0 % with epochs selected on the test set" in found.detail


# ---------------------------------------------------------------------------------------------
# Table 2's AVG under a protocol, and the protocols' keys


def measured(value: float) -> Measured:
    return Measured(value, None, 1, "x")


def test_the_avg_under_a_protocol_is_the_mean_of_five_different_scenes():
    scenes = [measured(v) for v in (0.40, 0.10, 0.20, 0.15, 0.15)]
    found = provenance.mean_of(scenes, "AVG")
    assert isinstance(found, Measured)
    assert found.mean == pytest.approx(0.20) and found.note == "mean of 5 scenes" and found.source == "AVG"
    assert provenance.mean_of([*scenes[:4], None], "AVG") is None  # a scene not scored that way
    missing = Absent("not scored yet")
    assert provenance.mean_of([*scenes[:2], missing, *scenes[3:]], "AVG") is missing


@pytest.mark.parametrize("protocol, metric, key", [
    ("independent_min", "ade", "ade"), ("independent_min", "fde", "fde"),
    ("pecnet_best_endpoint", "ade", "ade_best_endpoint"), ("pecnet_best_endpoint", "fde", "fde"),
    ("sgan_sequence", "ade", "ade_sgan_sequence"), ("sgan_sequence", "fde", "fde_sgan_sequence"),
    ("unknown", "ade", None),
])
def test_each_protocols_key(protocol, metric, key):
    assert provenance.metric_key(protocol, metric) == key


def test_under_protocol_reads_only_for_another_protocol_than_the_headlines():
    asked: list[str] = []

    def find(key: str) -> Measured:
        asked.append(key)
        return measured(1.0)
    assert provenance.under_protocol("independent_min", "ade", find) is None
    assert provenance.under_protocol("unknown", "ade", find) == Absent("compared with our headline",
                                                                         "unknown")
    assert provenance.under_protocol("sgan_sequence", "fde", find) == measured(1.0)
    assert asked == ["fde_sgan_sequence"]


# ---------------------------------------------------------------------------------------------
# Counting and listing the causes


def test_glance_counts_list_every_verdict_and_count_each_cell_once():
    counts = provenance.glance_counts(["match", "seed spread", "match", NO_CAUSE])
    assert list(counts) == list(provenance.VERDICTS)
    assert counts == {v: {"match": 2, "seed spread": 1, NO_CAUSE: 1}.get(v, 0) for v in provenance.VERDICTS}


def test_differences_are_grouped_by_cause_and_detail_in_the_order_of_causes():
    cells = [("a", provenance.Why(NO_CAUSE, "x")), ("b", provenance.Why("match")),
             ("c", provenance.Why("seed spread", "r")), ("d", provenance.Why(NO_CAUSE, "x")),
             ("e", provenance.Why("protocol", "p")), ("f", provenance.Why(NO_CAUSE, "y"))]
    assert provenance.difference_lines(cells) == (
        ("protocol", "p", ("e",)), ("seed spread", "r", ("c",)),
        (NO_CAUSE, "x", ("a", "d")), (NO_CAUSE, "y", ("f",)))


def test_source_notes_mark_quoted_and_authors_cells_apart_in_reading_order():
    other = provenance.CellSource("quoted", "another paper", "unknown")
    notes, marks = provenance.source_notes([("PECNet*", QUOTED), ("Y-net", AUTHORS), ("TNT*", other),
                                            ("PECNet", QUOTED)])
    assert [(n.mark, n.labels) for n in notes] == [("q1", ("PECNet*", "PECNet")), ("a1", ("Y-net",)),
                                                   ("q2", ("TNT*",))]
    assert marks == {QUOTED: "q1", AUTHORS: "a1", other: "q2"}
