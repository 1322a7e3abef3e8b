"""The report's section "The paper's claims, checked" (`pipeline.report.claims`): each rule on
small hand-made metrics, once where the claim holds and once where it does not; a missing file
gives "not measured" with its reason; every quote is in the paper's text."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pipeline.report import claims
from pipeline.report.lookups import MetricsStore
from pipeline.report.provenance import load_paper_values
from tests.test_report import assert_well_formed, full_project, project  # noqa: F401 (a fixture)

REPO = Path(__file__).resolve().parents[1]
PAPER = load_paper_values(REPO / "pipeline" / "report" / "paper_values.yaml")
PAPER_TEX = REPO.parent / "shared" / "paper" / "ynet-paper.tex"
CLAIMS = {claim.id: claim for claim in claims.CLAIMS}


# ---------------------------------------------------------------------------------------------
# Hand-made metrics in the stages' layouts


def stat(mean: float, std: float = 0.5) -> dict:
    return {"mean": mean, "std": std}


def ynet_eval(ade: float = 50.0, fde: float = 75.0, ablation: dict | None = None,
              grid: dict | None = None, ablation_rounds: int = 1) -> dict:
    """ynet_eval.json: the main setting, the ablation {name: (ade, fde)} (TTST + CWS is the main
    setting) and the K_a grid {(k_e, k_a): ade}."""
    main = {"ade": stat(ade), "fde": stat(fde), "k_e": 20, "k_a": 1, "rounds": 3}
    return {"profile": "cpu", "t_f": 30, "rounds": 3, "main": main,
            "ablation": {"ttst_cws": main, **{name: {"ade": stat(a), "fde": stat(f), "rounds": ablation_rounds}
                                               for name, (a, f) in (ablation or {}).items()}},
            "ka_grid": [{"k_e": k_e, "k_a": k_a, "ade": stat(v), "fde": stat(1.5 * v), "rounds": 1}
                        for (k_e, k_a), v in (grid or {}).items()]}


def baseline(model: str, horizon: int, ade: float, fde: float | None = None) -> dict:
    return {"model": model, "horizon": horizon, "k": 20, "rounds": 3, "ade": stat(ade),
            "fde": stat(2 * ade if fde is None else fde)}


def seed_spread(*entries: tuple[str, int, float]) -> dict:
    """baseline_seed_spread.json with (model, horizon, std of ADE and FDE over three seeds)."""
    return {"entries": [{"model": model, "horizon": horizon, "seeds": [0, 1, 2], "evaluation": {"k": 20},
                         "over_training_seeds": {"ade": stat(0.0, std), "fde": stat(0.0, std)}}
                        for model, horizon, std in entries]}


def store(**files: dict) -> MetricsStore:
    """Files by name, '/' written as '__' and '.json' left out (baselines__pecnet_tf30)."""
    return MetricsStore("metrics", {name.replace("__", "/") + ".json": record
                                    for name, record in files.items()})


def horizons(ynet: dict[int, float], pecnet: dict[int, float], rpecnet: dict[int, float] | None = None,
             spread: float | None = None) -> MetricsStore:
    """Y-net per horizon (30 s: ynet_eval.json) and PECNet / R-PECNet per horizon."""
    files = {"ynet_eval.json": ynet_eval(ynet[30])}
    files |= {f"ynet_horizons/tf{h}.json": {"t_f": h, "main": {"ade": stat(v), "fde": stat(2 * v)}}
              for h, v in ynet.items() if h != 30}
    files |= {f"baselines/pecnet_tf{h}.json": baseline("pecnet", h, v) for h, v in pecnet.items()}
    files |= {f"baselines/rpecnet_tf{h}.json": baseline("rpecnet", h, v) for h, v in (rpecnet or {}).items()}
    if spread is not None:
        files["baseline_seed_spread.json"] = seed_spread(
            *((m, h, spread) for m in ("pecnet", "rpecnet") for h in pecnet))
    return MetricsStore("metrics", files)


def short_term(ynet: tuple[float, float], others: dict[str, tuple[float, float]]) -> MetricsStore:
    """short_term/sdd.json (K = 20 and K = 5: the K = 5 errors 1.5 times K = 20's) and the five
    ETH/UCY scenes (every scene the same, in metres: a hundredth of the pixels)."""
    models = {"ynet": ynet, **others}
    sdd = {"rounds": 1, "models": {m: {f"k{k}": {"ade": stat(a * f, 0), "fde": stat(d * f, 0)}
                                       for k, f in ((20, 1.0), (5, 1.5))} for m, (a, d) in models.items()}}
    files = {"short_term/sdd.json": sdd}
    for scene in claims.ETHUCY_SCENES:
        files[f"short_term/ethucy_{scene}.json"] = {"rounds": 1, "models": {
            m: {"ade": stat(a / 100, 0), "fde": stat(d / 100, 0)} for m, (a, d) in models.items()}}
    return MetricsStore("metrics", files)


def check(claim_id: str, metrics: MetricsStore) -> claims.Outcome:
    outcome = CLAIMS[claim_id].check(metrics, PAPER)
    assert outcome.verdict in claims.VERDICTS and outcome.reason
    return outcome


# ---------------------------------------------------------------------------------------------
# Each rule: a case that holds, one that does not


def test_over_50_is_the_papers_percentage_on_ade_beyond_the_seed_spread():
    holds = store(ynet_eval=ynet_eval(50.0, 75.0), baselines__pecnet_tf30=baseline("pecnet", 30, 80.0))
    assert check("sdd-long-over-50", holds).verdict == "holds"  # 80 / 50 - 1 = 60 %
    short = store(ynet_eval=ynet_eval(50.0, 75.0), baselines__pecnet_tf30=baseline("pecnet", 30, 70.0))
    outcome = check("sdd-long-over-50", short)  # 40 %, though a 28.6 % error reduction
    assert outcome.verdict == "does not hold" and "reversed" in outcome.reason
    assert any("+40.0 %" in line for line in outcome.ours)
    noisy = store(ynet_eval=ynet_eval(50.0, 75.0), baselines__pecnet_tf30=baseline("pecnet", 30, 80.0),
                  baseline_seed_spread=seed_spread(("pecnet", 30, 10.0)))
    outcome = check("sdd-long-over-50", noisy)  # margin 80 - 75 = 5 px < 10 px over training seeds
    assert outcome.verdict == "does not hold" and "within the training-seed spread" in outcome.reason
    assert outcome.seeds == "PECNet: 3 training seeds; one training seed: Y-net"


def test_the_introductions_percentages_hold_on_the_papers_own_numbers_as_printed():
    """Table 3's 118.13 and 66.71 px give 77.08 %, which the paper prints as 77.1 %."""
    pecnet = {m: claims.paper_long(PAPER, "sdd", "pecnet", m) for m in claims.METRICS}
    ynet = {m: claims.paper_long(PAPER, "sdd", "ynet", m) for m in claims.METRICS}
    as_measured = store(ynet_eval=ynet_eval(ynet["ade"], ynet["fde"]),
                        baselines__pecnet_tf30=baseline("pecnet", 30, pecnet["ade"], pecnet["fde"]))
    assert check("sdd-long-intro", as_measured).verdict == "holds"
    assert check("sdd-long-over-50", as_measured).verdict == "holds"
    lower = store(ynet_eval=ynet_eval(ynet["ade"], ynet["fde"]),
                  baselines__pecnet_tf30=baseline("pecnet", 30, pecnet["ade"], 1.76 * ynet["fde"]))
    assert check("sdd-long-intro", lower).verdict == "does not hold"


def test_ind_status_record_is_not_measured_with_its_reason():
    metrics = store(ind_benchmark={"status": "not provided", "reason": "inD is licence-restricted"})
    outcome = check("ind-long", metrics)
    assert outcome.verdict == "not measured"
    assert outcome.reason == "inD is licence-restricted (metrics/ind_benchmark.json)"
    record = ynet_eval(15.0, 21.0) | {"baselines": {"pecnet": {"ade": stat(20.0), "fde": stat(33.0)}}}
    assert check("ind-long", store(ind_benchmark=record)).verdict == "holds"
    record = ynet_eval(21.0, 21.0) | {"baselines": {"pecnet": {"ade": stat(20.0), "fde": stat(33.0)}}}
    assert check("ind-long", store(ind_benchmark=record)).verdict == "does not hold"


def test_horizon_gap_must_grow_at_every_step_beyond_the_seed_spread():
    ynet = {5: 10.0, 10: 15.0, 30: 40.0, 60: 70.0}
    growing = {5: 11.0, 10: 20.0, 30: 60.0, 60: 120.0}  # gaps 1, 5, 20, 50
    assert check("horizon-gap", horizons(ynet, growing)).verdict == "holds"
    shrinking = {**growing, 60: 85.0}  # gap 15 at 60 s, below 30 s's 20
    outcome = check("horizon-gap", horizons(ynet, shrinking))
    assert outcome.verdict == "does not hold" and "30\u219260 s" in outcome.reason
    outcome = check("horizon-gap", horizons(ynet, growing, spread=20.0))  # each step: +- 28.3 px
    assert outcome.verdict == "does not hold"
    assert "within the training-seed spread: 5\u219210 s +4.0 \u00b1 28.3 px, 10\u219230 s" in outcome.reason
    assert "30\u219260" not in outcome.reason  # +30 px, beyond sqrt(2) x 20 = 28.3 px


def test_separate_models_against_the_recurrent_one_beyond_5_s():
    ynet = {5: 10.0, 10: 15.0, 30: 40.0}
    pecnet = {5: 11.0, 10: 20.0, 30: 60.0}
    better = {5: 11.0, 10: 25.0, 30: 90.0}  # 5 s: one model, not compared
    assert check("separate-vs-recurrent", horizons(ynet, pecnet, better)).verdict == "holds"
    worse_late = {5: 11.0, 10: 25.0, 30: 55.0}
    outcome = check("separate-vs-recurrent", horizons(ynet, pecnet, worse_late))
    assert outcome.verdict == "does not hold" and "reversed: 30 s" in outcome.reason
    assert outcome.seeds == "one training seed: PECNet, R-PECNet"


def test_ttst_and_cws_each_lower_the_error():
    ablation = {"none": (70.0, 95.0), "cws": (58.0, 95.0)}
    metrics = store(ynet_eval=ynet_eval(50.0, 75.0, ablation))
    assert check("ttst-sdd", metrics).verdict == "holds"
    assert check("cws-ade", metrics).verdict == "holds"
    worse = store(ynet_eval=ynet_eval(50.0, 75.0, {"none": (57.0, 95.0), "cws": (58.0, 70.0)}))
    outcome = check("ttst-sdd", worse)  # TTST raises the FDE from 70 to 75
    assert outcome.verdict == "does not hold" and "FDE" in outcome.reason
    assert check("cws-ade", worse).verdict == "does not hold"


def test_cws_leaves_the_fde_within_the_spread_over_evaluation_rounds():
    unchanged = store(ynet_eval=ynet_eval(50.0, 75.0, {"none": (70.0, 95.0), "cws": (58.0, 95.4)},
                                          ablation_rounds=3))
    assert check("cws-fde", unchanged).verdict == "holds"  # 0.4 px within hypot(0.5, 0.5)
    changed = store(ynet_eval=ynet_eval(50.0, 75.0, {"none": (70.0, 95.0), "cws": (58.0, 99.0)},
                                        ablation_rounds=3))
    assert check("cws-fde", changed).verdict == "does not hold"
    one_round = store(ynet_eval=ynet_eval(50.0, 75.0, {"none": (70.0, 95.0), "cws": (58.0, 95.0)}))
    outcome = check("cws-fde", one_round)
    assert outcome.verdict == "not measured" and "one evaluation round" in outcome.reason


def test_ade_falls_with_k_a_at_every_k_e():
    grid = {(10, 1): 60.0, (10, 2): 55.0, (20, 1): 50.0, (20, 2): 46.0, (20, 5): 40.0}
    assert check("ka-ade", store(ynet_eval=ynet_eval(grid=grid))).verdict == "holds"
    outcome = check("ka-ade", store(ynet_eval=ynet_eval(grid={**grid, (20, 5): 47.0})))
    assert outcome.verdict == "does not hold" and "K_e = 20, K_a 2\u21925" in outcome.reason
    outcome = check("ka-ade", store(ynet_eval=ynet_eval(grid={(20, 1): 50.0})))
    assert outcome.verdict == "not measured" and "two K_a values" in outcome.reason


def test_pecnet_with_more_samples_stays_worse_than_ynet():
    grid = {(20, 1): 50.0, (20, 2): 46.0}

    def pecnet_ka(*ades):
        return [{"k_a": k_a, "k": 20 * k_a, "rounds": 3, "ade": stat(a), "fde": stat(2 * a)}
                for k_a, a in enumerate(ades, start=1)]
    metrics = store(ynet_eval=ynet_eval(grid=grid), baselines__pecnet_ka=pecnet_ka(80.0, 70.0))
    assert check("pecnet-more-samples", metrics).verdict == "holds"
    metrics = store(ynet_eval=ynet_eval(grid=grid), baselines__pecnet_ka=pecnet_ka(80.0, 45.0))
    outcome = check("pecnet-more-samples", metrics)
    assert outcome.verdict == "does not hold" and "K_a = 2" in outcome.reason


def test_short_term_ynet_best_and_ahead_of_pecnet():
    ahead = short_term((9.0, 14.0), {"sgan": (13.0, 23.0), "pecnet": (10.0, 16.0)})
    for claim_id in ("sdd-short-best", "sdd-short-pecnet", "ethucy-best"):
        assert check(claim_id, ahead).verdict == "holds", claim_id
    outcome = check("sdd-short-best", ahead)
    assert "paper only: CF-VAE, DESIRE, P2TIRL, SimAug, TNT*" in outcome.reason
    behind = short_term((9.0, 17.0), {"sgan": (13.0, 23.0), "pecnet": (10.0, 16.0)})
    for claim_id in ("sdd-short-best", "sdd-short-pecnet", "ethucy-best"):
        outcome = check(claim_id, behind)
        assert outcome.verdict == "does not hold" and "PECNet" in outcome.reason, claim_id


def test_trajectron_is_paper_only():
    outcome = check("ethucy-trajectron", short_term((9.0, 14.0), {"pecnet": (10.0, 16.0)}))
    assert outcome.verdict == "not measured" and "Trajectron++ is not run" in outcome.reason
    assert any("+51.9 %" in line for line in outcome.paper)


# ---------------------------------------------------------------------------------------------
# Absences, the whole list, the paper's text


def test_a_missing_metrics_file_is_not_measured_with_its_reason():
    outcome = check("sdd-long-over-50", store(baselines__pecnet_tf30=baseline("pecnet", 30, 80.0)))
    assert outcome.verdict == "not measured"
    assert outcome.reason == "stage not yet run: metrics/ynet_eval.json missing"
    assert outcome.paper  # the paper's numbers are still shown
    rows = claims.evaluate(MetricsStore("metrics", {}), PAPER)
    assert [row.outcome.verdict for row in rows] == ["not measured"] * len(claims.CLAIMS)
    assert all(row.outcome.reason for row in rows)


def test_a_malformed_file_is_not_measured_not_a_crash():
    rows = claims.evaluate(store(ynet_eval={"t_f": 30, "ka_grid": [{"k_e": 20, "k_a": 1}, "x"]}), PAPER)
    assert {row.outcome.verdict for row in rows} == {"not measured"}


def test_claims_are_unique_and_complete():
    assert len(CLAIMS) == len(claims.CLAIMS)
    for claim in claims.CLAIMS:
        assert claim.section and claim.quote and "holds if" in claim.rule, claim.id
    section = claims.claims_section(MetricsStore("metrics", {}), PAPER)
    assert section["counts"] == {"holds": 0, "does not hold": 0, "not measured": len(claims.CLAIMS)}


def plain(tex: str) -> str:
    """LaTeX written out as the page quotes it: math, \\%, \\&, \\textsf{Y}, \\ie; citations
    dropped; whitespace collapsed."""
    tex = re.sub(r"\\cite\{[^}]*\}", "", tex)
    tex = re.sub(r"\\(?:textsf|texttt|textit|textbf)\{([^}]*)\}", r"\1", tex)
    for old, new in ((r"\%", "%"), (r"\&", "&"), (r"\ie", "i.e."), ("\\ ", " "), ("$", ""), ("~", " ")):
        tex = tex.replace(old, new)
    return re.sub(r"\s+%", "%", re.sub(r"\s+", " ", tex)).strip()


@pytest.mark.skipif(not PAPER_TEX.exists(), reason=f"{PAPER_TEX} not on this machine")
def test_every_quote_is_in_the_papers_text():
    text = plain(PAPER_TEX.read_text())
    missing = [claim.id for claim in claims.CLAIMS if plain(claim.quote) not in text]
    assert not missing


@pytest.mark.skipif(not PAPER_TEX.exists(), reason=f"{PAPER_TEX} not on this machine")
def test_the_papers_percentages_are_relative_to_ynets_error():
    """The convention the rules use: each percentage of the paper's text is (other - Y-net) /
    Y-net of its tables' numbers (to its rounding), not the error reduction (other - Y-net) / other."""
    long = {(d, m, x): claims.paper_long(PAPER, d, m, x) for d in ("sdd", "ind")
            for m in ("pecnet", "ynet") for x in claims.METRICS}
    ttst = {(d, a, x): claims.paper_ttst(PAPER, d, a, x) for d, a in
            (("sdd", "none"), ("sdd", "cws"), ("sdd", "ttst_cws"), ("ind", "cws"), ("ind", "ttst_cws"))
            for x in claims.METRICS}
    short = {x: (claims.paper_column(PAPER, "sdd_short", model="pecnet", k=20)[x],
                 claims.paper_column(PAPER, "sdd_short", model="ynet", k=20)[x]) for x in claims.METRICS}
    eth = {x: (claims.paper_ethucy(PAPER, "trajectronpp")[x]["avg"],
               claims.paper_ethucy(PAPER, "ynet")[x]["avg"]) for x in claims.METRICS}
    printed = {  # the text's percentage: (other, Y-net)
        50.6: (long["sdd", "pecnet", "ade"], long["sdd", "ynet", "ade"]),
        77.1: (long["sdd", "pecnet", "fde"], long["sdd", "ynet", "fde"]),
        35.0: (long["ind", "pecnet", "ade"], long["ind", "ynet", "ade"]),
        55.9: (long["ind", "pecnet", "fde"], long["ind", "ynet", "fde"]),
        26.9: short["ade"], 34.0: short["fde"], 5.6: eth["ade"], 51.9: eth["fde"],
        24.3: (ttst["sdd", "none", "ade"], ttst["sdd", "cws", "ade"]),
        9.1: (ttst["sdd", "cws", "ade"], ttst["sdd", "ttst_cws", "ade"]),
        30.4: (ttst["sdd", "cws", "fde"], ttst["sdd", "ttst_cws", "fde"]),
        18.5: (ttst["ind", "cws", "ade"], ttst["ind", "ttst_cws", "ade"]),
    }
    tex = plain(PAPER_TEX.read_text())
    for pct, (other, ynet) in printed.items():
        assert f"{pct:.1f}%" in tex
        assert claims.gain(other, ynet) * 100 == pytest.approx(pct, abs=0.15), pct
        assert (other - ynet) / other * 100 != pytest.approx(pct, abs=0.15), pct


def test_the_page_has_a_row_per_claim_with_its_verdict(project):  # noqa: F811
    html = full_project(project).read_text()
    assert_well_formed(html)
    section = html.split('<h2 id="claims">')[1].split("<h2 ")[0]
    rows = re.findall(r'<tr data-claim="([^"]+)">(.*?)</tr>', section, re.S)
    assert [claim_id for claim_id, _ in rows] == [claim.id for claim in claims.CLAIMS]
    for _, row in rows:
        verdict = re.search(r'data-claim-verdict="([^"]+)"><b>([^<]+)</b>', row)
        assert verdict and verdict[1] == verdict[2] and verdict[1] in claims.VERDICTS
        assert not re.search(r"\b(nan|None|inf)\b", row)
    assert 'href="#claims"' in html
