"""The report's section "The paper's claims, checked": each claim the paper makes in words, what
this pipeline measured for it and whether it holds.

A claim (`Claim`) is a quote, verbatim from the paper's text up to LaTeX markup (a test checks it
against the tex), the section it is in, its rule in words, and `check`, the function that applies
the rule to the metrics store and the paper's values (`paper_values.yaml`). The verdict is one of
`VERDICTS`, with a one-line reason: `not measured` where an input is absent (a missing metrics
file, a status record, a model this pipeline does not run), with that input's reason.

Most rules compare models, and are written as margins (`Margin`): a signed sum of measured numbers
that is positive where the claim holds, e.g. PECNet's ADE - 1.5 x Y-net's for "better by over
50 %". A margin's spread over training seeds is sqrt(sum coef^2 std^2) over its numbers whose
model was trained with several seeds (`metrics/baseline_seed_spread.json`: the baselines, and the
main Y-net where the profile trains extra seeds, `metrics/ynet_seeds/`); the other numbers come
from one training seed, and the page says so. A claim holds when every margin is positive and,
where it has a seed spread, larger than that spread.

The paper's percentages are (other - Y-net) / Y-net, the other model's error over Y-net's (its
tables give its text's percentages this way: PECNet's 72.22 px against Y-net's 47.94 px is its
"50.6 %"); ours are computed the same way, with the error reduction (other - Y-net) / other beside.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pipeline.model_list import label
from pipeline.report.lookups import (Absent, Measured, MetricsStore, as_measured, is_number,
                                     lookup, lookup_grid)

VERDICTS = ("holds", "does not hold", "not measured")
METRICS = ("ade", "fde")
YNET_FILE = "ynet_eval.json"
IND_FILE = "ind_benchmark.json"
SEED_SPREAD_FILE = "baseline_seed_spread.json"
LONG_TF = 30  # the long-term tables' horizon (s)
LONG_K = 20  # their K (Y-net: K_e)
MAIN = {"k_e": LONG_K, "k_a": 1}  # Y-net's main setting: TTST + CWS, K_e = 20, K_a = 1
RECURRENT_TF = 5  # R-PECNet is PECNet trained for t_f = 5 s, rolled out for longer horizons
ETHUCY_SCENES = ("eth", "hotel", "univ", "zara1", "zara2")
ABLATIONS = {"none": "neither", "cws": "CWS only", "ttst_cws": "TTST + CWS"}  # Table 4's settings
HALF_DIGIT = 0.0005  # "over 77.1 %" holds from 77.05 %: half the last digit the paper prints


# ---------------------------------------------------------------------------------------------
# Numbers, margins, outcomes


@dataclass(frozen=True)
class Term:
    """One number a rule reads: ours (mean over evaluation rounds of the main training seed) and,
    where the model was trained with several seeds, the std over them and their count."""
    model: str  # its label, for the seeds line
    value: float
    seed_std: float | None = None
    seeds: int = 1


@dataclass(frozen=True)
class Margin:
    """sum(coef x term) over `parts`: positive where the claim holds."""
    name: str
    parts: tuple[tuple[float, Term], ...]

    @property
    def value(self) -> float:
        return sum(coef * term.value for coef, term in self.parts)

    @property
    def spread(self) -> float | None:
        """Its std over training seeds, from the terms that have one; None: one training seed."""
        known = [(coef * term.seed_std) ** 2 for coef, term in self.parts if term.seed_std is not None]
        return math.sqrt(sum(known)) if known else None

    @property
    def state(self) -> str:
        if self.value <= 0:
            return "reversed"
        if self.spread is not None and self.value <= self.spread:
            return "within seed spread"
        return "clear"

    def text(self, unit: str, decimals: int) -> str:
        spread = f" \u00b1 {self.spread:.{decimals}f}" if self.spread is not None else ""
        return f"{self.name} {self.value:+.{decimals}f}{spread} {unit}"


@dataclass(frozen=True)
class Outcome:
    """A claim's verdict and reason, our numbers and the paper's (lines of text), and which
    numbers have a spread over training seeds."""
    verdict: str
    reason: str
    ours: tuple[str, ...] = ()
    paper: tuple[str, ...] = ()
    seeds: str = ""


@dataclass(frozen=True)
class Claim:
    id: str
    section: str  # where in the paper
    quote: str  # verbatim, LaTeX markup (math, \%, \textsf{Y}, \cite) written out as plain text
    rule: str  # the rule `check` applies, in words
    check: Callable[[MetricsStore, Mapping], Outcome]


@dataclass(frozen=True)
class ClaimRow:
    claim: Claim
    outcome: Outcome


def seeds_line(margins: Iterable[Margin]) -> str:
    """Which models' numbers have a spread over training seeds, and which come from one seed."""
    several: dict[str, int] = {}
    single: set[str] = set()
    for margin in margins:
        for _, term in margin.parts:
            if term.seed_std is not None:
                several[term.model] = max(several.get(term.model, 0), term.seeds)
            else:
                single.add(term.model)
    parts = [f"{model}: {n} training seeds" + (" (one for some of its numbers)" if model in single else "")
             for model, n in sorted(several.items())]
    alone = sorted(single - set(several))
    if alone:
        parts.append(f"one training seed: {', '.join(alone)}")
    return "; ".join(parts)


def decide(margins: Sequence[Margin], unit: str, decimals: int, ours: Sequence[str],
           paper: Sequence[str], note: str = "") -> Outcome:
    """`holds` when every margin is positive and beyond its seed spread, else `does not hold`
    naming the margins that are not (the reversed first)."""
    wrong = [m for m in margins if m.state == "reversed"]
    within = [m for m in margins if m.state == "within seed spread"]
    seeds = seeds_line(margins)
    if wrong or within:
        found = []
        if wrong:
            found.append(f"reversed: {', '.join(m.text(unit, decimals) for m in wrong)}")
        if within:
            found.append(f"within the training-seed spread: "
                         f"{', '.join(m.text(unit, decimals) for m in within)}")
        reason = "; ".join(found)
        return Outcome("does not hold", reason + (f"; {note}" if note else ""), tuple(ours),
                       tuple(paper), seeds)
    spread = [m for m in margins if m.spread is not None]
    if not spread:
        reason = "every margin positive (one training seed: no seed spread to test it against)"
    else:
        tightest = min(spread, key=lambda m: m.value / m.spread).text(unit, decimals)
        reason = (f"every margin positive and beyond its training-seed spread (tightest: {tightest})"
                  if len(spread) == len(margins) else
                  f"every margin positive, and beyond its training-seed spread where it has one "
                  f"(tightest: {tightest})")
    return Outcome("holds", reason + (f"; {note}" if note else ""), tuple(ours), tuple(paper), seeds)


def not_measured(absent: Absent, ours: Sequence[str] = (), paper: Sequence[str] = ()) -> Outcome:
    return Outcome("not measured", absent.reason, tuple(ours), tuple(paper))


def first_absent(values: Iterable[Any]) -> Absent | None:
    return next((v for v in values if isinstance(v, Absent)), None)


def gain(other: float, ynet: float) -> float:
    """The paper's percentage: the other model's error over Y-net's, (other - Y-net) / Y-net."""
    return (other - ynet) / ynet


def versus(name: str, other_label: str, other: float, ynet_label: str, ynet: float, unit: str,
           decimals: int) -> str:
    """'ADE: PECNet 82.64 vs Y-net 50.48 px: +63.7 % (error reduction 38.9 %)'."""
    return (f"{name}: {other_label} {other:.{decimals}f} vs {ynet_label} {ynet:.{decimals}f} {unit}: "
            f"{gain(other, ynet) * 100:+.1f} % (error reduction {(other - ynet) / other * 100:.1f} %)")


# ---------------------------------------------------------------------------------------------
# Reading our numbers (each a `Term`, or why there is none)


def seed_spread(store: MetricsStore, model: str, horizon: int, metric: str,
                setting: Mapping[str, int]) -> tuple[float, int] | None:
    """(std over training seeds, number of seeds) of `metric` for `model` at `horizon`, from the
    stage baseline_seed_spread, where its evaluation is `setting` (K, or Y-net's K_e and K_a);
    None where the model was trained with one seed."""
    record = store.record(SEED_SPREAD_FILE)
    entries = record.get("entries") if isinstance(record, dict) else None
    for entry in entries if isinstance(entries, list) else []:
        if not isinstance(entry, dict) or (entry.get("model"), entry.get("horizon")) != (model, horizon):
            continue
        evaluation = entry.get("evaluation") or {}
        if any(key in evaluation and evaluation[key] != value for key, value in setting.items()):
            return None
        std = ((entry.get("over_training_seeds") or {}).get(metric) or {}).get("std")
        seeds = entry.get("seeds") or []
        if is_number(std) and len(seeds) > 1:
            return float(std), len(seeds)
    return None


def term(model: str, value: Measured | Absent, spread: tuple[float, int] | None = None) -> Term | Absent:
    if isinstance(value, Absent):
        return value
    if value.mismatch:
        return Absent(f"{value.source}: {value.mismatch}", "invalid")
    std, seeds = spread or (None, 1)
    return Term(label(model), value.mean, std, seeds)


def ynet_setting(store: MetricsStore, metric: str, ablation: str = "ttst_cws") -> Term | Absent:
    """Y-net at t_f = 30 s, K_e = 20, K_a = 1: the main setting (TTST + CWS) or an ablation."""
    path = ("main", metric) if ablation == "ttst_cws" else ("ablation", ablation, metric)
    spread = seed_spread(store, "ynet", LONG_TF, metric, MAIN) if ablation == "ttst_cws" else None
    return term("ynet", lookup(store, YNET_FILE, path, t_f=LONG_TF), spread)


def ynet_grid(store: MetricsStore, k_e: int, k_a: int, metric: str = "ade") -> Term | Absent:
    spread = seed_spread(store, "ynet", LONG_TF, metric, {"k_e": k_e, "k_a": k_a})
    value = lookup_grid(store, YNET_FILE, "ka_grid", {"k_e": k_e, "k_a": k_a}, metric, t_f=LONG_TF)
    return term("ynet", value, spread if (k_e, k_a) == (MAIN["k_e"], MAIN["k_a"]) else None)


def ynet_horizon(store: MetricsStore, t_f: int, metric: str = "ade") -> Term | Absent:
    """Y-net at horizon `t_f`: the main model at 30 s, a horizon model elsewhere."""
    if t_f == LONG_TF:
        return ynet_setting(store, metric)
    return term("ynet", lookup(store, f"ynet_horizons/tf{t_f}.json", ("main", metric), t_f=t_f),
                seed_spread(store, "ynet", t_f, metric, MAIN))


def baseline(store: MetricsStore, model: str, t_f: int, metric: str = "ade") -> Term | Absent:
    value = lookup(store, f"baselines/{model}_tf{t_f}.json", (metric,), t_f=t_f,
                   expect={"k": LONG_K})
    return term(model, value, seed_spread(store, model, t_f, metric, {"k": LONG_K}))


def pecnet_ka(store: MetricsStore, metric: str = "ade") -> dict[int, tuple[Any, Term]] | Absent:
    """K_a -> (K, PECNet's `metric` with K samples) from baselines/pecnet_ka.json (a list); a row
    without a finite value is left out."""
    rel = "baselines/pecnet_ka.json"
    record = store.record(rel)
    if not isinstance(record, list):
        return record if isinstance(record, Absent) else Absent(f"{store.where(rel)} is not a list",
                                                                "invalid")
    found = {}
    for row in record:
        if isinstance(row, dict) and is_number(row.get("k_a")):
            where = f"{store.where(rel)}: k_a = {row['k_a']}"
            value = as_measured(row.get(metric), row.get("rounds"), where)
            spread = seed_spread(store, "pecnet", LONG_TF, metric, {"k": row.get("k")})
            if isinstance(found_term := term("pecnet", value, spread), Term):
                found[int(row["k_a"])] = (row.get("k"), found_term)
    return found


def ind(store: MetricsStore, model: str, metric: str, ablation: str = "ttst_cws") -> Term | Absent:
    """inD at t_f = 30 s (ind_benchmark.json: Y-net as ynet_eval.json, baselines under `baselines`)."""
    if model != "ynet":
        path = ("baselines", model, metric)
    else:
        path = ("main", metric) if ablation == "ttst_cws" else ("ablation", ablation, metric)
    return term(model, lookup(store, IND_FILE, path, t_f=LONG_TF))


def short_sdd(store: MetricsStore, model: str, k: int, metric: str) -> Term | Absent:
    return term(model, lookup(store, "short_term/sdd.json", ("models", model, f"k{k}", metric)))


def ethucy_avg(store: MetricsStore, model: str, metric: str) -> Term | Absent:
    """The mean of the five scenes' means (as Table 2's AVG row), when all five were measured."""
    values = [lookup(store, f"short_term/ethucy_{scene}.json", ("models", model, metric))
              for scene in ETHUCY_SCENES]
    absent = first_absent(values)
    if absent is not None:
        return absent
    return Term(label(model), sum(v.mean for v in values) / len(values))


def other_models(store: MetricsStore, rel: str) -> list[str] | Absent:
    """The models beside Y-net in a short-term metrics file (what this pipeline runs there)."""
    record = store.record(rel)
    if isinstance(record, Absent):
        return record
    models = record.get("models") if isinstance(record, dict) else None
    if not isinstance(models, dict):
        return Absent(f"{store.where(rel)} has no models", "invalid")
    return [m for m in models if m != "ynet"]


def horizons_measured(store: MetricsStore) -> list[int]:
    """Every horizon with a PECNet or Y-net file (Y-net's 30 s: ynet_eval.json)."""
    found = set()
    for rel in store.files:
        for prefix in ("baselines/pecnet_tf", "baselines/rpecnet_tf", "ynet_horizons/tf"):
            rest = rel.removeprefix(prefix).removesuffix(".json")
            if rel.startswith(prefix) and rest.isdigit():
                found.add(int(rest))
    return sorted(found)


# ---------------------------------------------------------------------------------------------
# The paper's numbers (paper_values.yaml)


def paper_column(paper: Mapping, table: str, **match: Any) -> Mapping:
    return next(c for c in paper[table]["columns"] if all(c.get(k) == v for k, v in match.items()))


def paper_long(paper: Mapping, dataset: str, model: str, metric: str, k_a: int = 1) -> float:
    return paper_column(paper, "sdd_long", dataset=dataset, model=model, k_a=k_a)[metric]


def paper_ttst(paper: Mapping, dataset: str, ablation: str, metric: str) -> float:
    return paper_column(paper, "ttst", dataset=dataset, ablation=ablation)[metric]


def paper_ethucy(paper: Mapping, model: str) -> Mapping:
    return next(m for m in paper["eth_ucy"]["models"] if m["model"] == model)


# ---------------------------------------------------------------------------------------------
# The rules


def better_by(store: MetricsStore, paper: Mapping, dataset: str,
              over: Mapping[str, float]) -> Outcome:
    """Long term, t_f = 30 s: PECNet's error exceeds Y-net's by more than `over` (per metric, the
    paper's convention) beyond the seed spread; both metrics shown."""
    def find(metric: str, model: str) -> Term | Absent:
        if dataset == "ind":
            return ind(store, model, metric)
        return ynet_setting(store, metric) if model == "ynet" else baseline(store, model, LONG_TF, metric)

    found = {m: (find(m, "pecnet"), find(m, "ynet")) for m in METRICS}
    paper_lines = [versus(m.upper(), "PECNet", paper_long(paper, dataset, "pecnet", m), "Y-net",
                          paper_long(paper, dataset, "ynet", m), "px", 2) for m in METRICS]
    absent = first_absent(v for pair in found.values() for v in pair)
    if absent is not None:
        return not_measured(absent, paper=paper_lines)
    ours = [versus(m.upper(), "PECNet", p.value, "Y-net", y.value, "px", 2)
            for m, (p, y) in found.items()]
    margins = [Margin(f"{m.upper()}: PECNet \u2212 " + (f"{1 + t:.4g} \u00d7 Y-net" if t else "Y-net"),
                      ((1.0, found[m][0]), (-(1 + t), found[m][1]))) for m, t in over.items()]
    return decide(margins, "px", 2, ours, paper_lines)


def check_over_50(store: MetricsStore, paper: Mapping) -> Outcome:
    return better_by(store, paper, "sdd", {"ade": 0.50})


def check_intro_sdd(store: MetricsStore, paper: Mapping) -> Outcome:
    return better_by(store, paper, "sdd", {"ade": 0.506 - HALF_DIGIT, "fde": 0.771 - HALF_DIGIT})


def check_ind(store: MetricsStore, paper: Mapping) -> Outcome:
    return better_by(store, paper, "ind", {"ade": 0.0, "fde": 0.0})


def check_horizon_gap(store: MetricsStore, paper: Mapping) -> Outcome:
    """The ADE gap PECNet - Y-net grows at every step from one horizon to the next."""
    gap = paper_long(paper, "sdd", "pecnet", "ade") - paper_long(paper, "sdd", "ynet", "ade")
    paper_lines = [f"Figure 4: a plot, no published numbers; Table 3 (30 s): PECNet \u2212 Y-net = "
                   f"{gap:.2f} px"]
    horizons = horizons_measured(store)
    found = {h: (baseline(store, "pecnet", h), ynet_horizon(store, h)) for h in horizons}
    absent = first_absent(v for pair in found.values() for v in pair)
    if absent is not None:
        return not_measured(absent, paper=paper_lines)
    if len(horizons) < 2:
        return not_measured(Absent("fewer than two horizons measured"), paper=paper_lines)
    gaps = " \u00b7 ".join(f"{h} s {p.value - y.value:.1f}" for h, (p, y) in found.items())
    margins = [Margin(f"{a}\u2192{b} s", ((1.0, found[b][0]), (-1.0, found[b][1]),
                                          (-1.0, found[a][0]), (1.0, found[a][1])))
               for a, b in zip(horizons, horizons[1:])]
    ours = [f"ADE gap PECNet \u2212 Y-net (px): {gaps}",
            "its growth per step: " + " \u00b7 ".join(m.text("", 1).strip() for m in margins)]
    return decide(margins, "px", 1, ours, paper_lines)


def check_recurrent(store: MetricsStore, paper: Mapping) -> Outcome:
    """PECNet trained per horizon has a lower ADE than R-PECNet at every horizon beyond 5 s."""
    paper_lines = [f"Table 3 (30 s) ADE, {name}: R-PECNet {paper_long(paper, d, 'rpecnet', 'ade'):.2f} "
                   f"vs PECNet {paper_long(paper, d, 'pecnet', 'ade'):.2f} px"
                   for d, name in (("sdd", "SDD"), ("ind", "inD"))]
    horizons = [h for h in horizons_measured(store) if h > RECURRENT_TF]
    found = {h: (baseline(store, "rpecnet", h), baseline(store, "pecnet", h)) for h in horizons}
    absent = first_absent(v for pair in found.values() for v in pair)
    if absent is not None:
        return not_measured(absent, paper=paper_lines)
    if not horizons:
        return not_measured(Absent(f"no horizon beyond {RECURRENT_TF} s measured"), paper=paper_lines)
    margins = [Margin(f"{h} s", ((1.0, r), (-1.0, p))) for h, (r, p) in found.items()]
    ours = ["ADE R-PECNet vs PECNet (px): "
            + " \u00b7 ".join(f"{h} s {r.value:.1f} vs {p.value:.1f}" for h, (r, p) in found.items())]
    return decide(margins, "px", 1, ours, paper_lines)


def ablation_gain(store: MetricsStore, paper: Mapping, dataset: str, without: str, with_: str,
                  metrics: Sequence[str]) -> Outcome:
    """Y-net's error without a component (`without`) exceeds its error with it (`with_`)."""
    def find(metric: str, ablation: str) -> Term | Absent:
        if dataset == "ind":
            return ind(store, "ynet", metric, ablation)
        return ynet_setting(store, metric, ablation)

    def line(metric: str, before: float, after: float) -> str:
        return (f"{metric.upper()}: {before:.2f} ({ABLATIONS[without]}) \u2192 {after:.2f} px: "
                f"{gain(before, after) * 100:+.1f} %")

    paper_lines = [line(m, paper_ttst(paper, dataset, without, m), paper_ttst(paper, dataset, with_, m))
                   for m in metrics]
    found = {m: (find(m, without), find(m, with_)) for m in metrics}
    absent = first_absent(v for pair in found.values() for v in pair)
    if absent is not None:
        return not_measured(absent, paper=paper_lines)
    ours = [line(m, a.value, b.value) for m, (a, b) in found.items()]
    margins = [Margin(f"{m.upper()}: {ABLATIONS[without]} \u2212 {ABLATIONS[with_]}",
                      ((1.0, a), (-1.0, b))) for m, (a, b) in found.items()]
    return decide(margins, "px", 2, ours, paper_lines)


def check_ttst_sdd(store: MetricsStore, paper: Mapping) -> Outcome:
    return ablation_gain(store, paper, "sdd", "cws", "ttst_cws", METRICS)


def check_ttst_ind(store: MetricsStore, paper: Mapping) -> Outcome:
    return ablation_gain(store, paper, "ind", "cws", "ttst_cws", METRICS)


def check_cws_ade(store: MetricsStore, paper: Mapping) -> Outcome:
    return ablation_gain(store, paper, "sdd", "none", "cws", ("ade",))


def check_cws_fde(store: MetricsStore, paper: Mapping) -> Outcome:
    """CWS leaves the FDE as it is: the change is within the spread over evaluation rounds of the
    two settings (it cannot be judged where either was scored in one round)."""
    paper_lines = [f"FDE: {paper_ttst(paper, 'sdd', 'none', 'fde'):.2f} (neither) \u2192 "
                   f"{paper_ttst(paper, 'sdd', 'cws', 'fde'):.2f} px (CWS only)"]
    values = [lookup(store, YNET_FILE, ("ablation", a, "fde"), t_f=LONG_TF) for a in ("none", "cws")]
    absent = first_absent(values)
    if absent is not None:
        return not_measured(absent, paper=paper_lines)
    before, after = values
    change = after.mean - before.mean
    ours = [f"FDE: {before.mean:.2f} (neither) \u2192 {after.mean:.2f} px (CWS only): "
            f"{change:+.2f} px ({change / before.mean * 100:+.1f} %)"]
    seeds = "one training seed: Y-net"
    if before.std is None or after.std is None:
        return Outcome("not measured", "each ablation setting was scored in one evaluation round: no "
                       "spread to tell an unchanged FDE from a changed one", tuple(ours),
                       tuple(paper_lines), seeds)
    spread = math.hypot(before.std, after.std)
    ours.append(f"spread over evaluation rounds: \u00b1 {spread:.2f} px")
    within = abs(change) <= spread
    reason = (f"the FDE moves by {abs(change):.2f} px, {'within' if within else 'beyond'} the spread "
              f"over evaluation rounds (\u00b1 {spread:.2f} px)")
    return Outcome("holds" if within else "does not hold", reason, tuple(ours), tuple(paper_lines), seeds)


def check_ka(store: MetricsStore, paper: Mapping) -> Outcome:
    """At every K_e of the K_a grid, ADE falls at each step up in K_a."""
    ka = [(c["k_a"], c["ade"]) for c in paper["sdd_long"]["columns"]
          if (c["dataset"], c["model"]) == ("sdd", "ynet")]
    paper_lines = [f"Table 3, SDD, K_e = {LONG_K}, ADE: " + " \u2192 ".join(f"{v:.2f}" for _, v in ka)
                   + f" px (K_a = {', '.join(str(k) for k, _ in ka)}); Figure 5: no published numbers"]
    record = store.record(YNET_FILE)
    grid = record.get("ka_grid") if isinstance(record, dict) else None
    if isinstance(record, Absent) or not isinstance(grid, list):
        why = record if isinstance(record, Absent) else Absent(f"{store.where(YNET_FILE)} has no ka_grid",
                                                               "invalid")
        return not_measured(why, paper=paper_lines)
    pairs = sorted({(row["k_e"], row["k_a"]) for row in grid if isinstance(row, dict)
                    and is_number(row.get("k_e")) and is_number(row.get("k_a"))})
    series: dict[int, list[tuple[int, Term]]] = {}
    for k_e, k_a in pairs:
        found = ynet_grid(store, k_e, k_a)
        if isinstance(found, Absent):
            return not_measured(found, paper=paper_lines)
        series.setdefault(k_e, []).append((k_a, found))
    margins = [Margin(f"K_e = {k_e}, K_a {a}\u2192{b}", ((1.0, ta), (-1.0, tb)))
               for k_e, points in series.items() for (a, ta), (b, tb) in zip(points, points[1:])]
    if not margins:
        return not_measured(Absent(f"{store.where(YNET_FILE)}: no K_e with two K_a values"),
                            paper=paper_lines)
    ours = [f"K_e = {k_e}, ADE: " + " \u2192 ".join(f"{t.value:.2f}" for _, t in points)
            + f" px (K_a = {', '.join(str(k) for k, _ in points)})" for k_e, points in series.items()]
    return decide(margins, "px", 2, ours, paper_lines)


def check_pecnet_samples(store: MetricsStore, paper: Mapping) -> Outcome:
    """PECNet with 20 K_a samples has a higher ADE than Y-net (K_e = 20) at every K_a of both."""
    paper_lines = ["Figure 5: a plot, no published numbers"]
    found = pecnet_ka(store)
    if isinstance(found, Absent):
        return not_measured(found, paper=paper_lines)
    pairs = []
    for k_a, (k, p) in sorted(found.items()):
        y = ynet_grid(store, LONG_K, k_a)
        if isinstance(y, Absent):
            continue  # a K_a the Y-net grid does not have
        pairs.append((k_a, k, p, y))
    if not pairs:
        return not_measured(Absent("no K_a in both baselines/pecnet_ka.json and Y-net's K_e = 20 grid"),
                            paper=paper_lines)
    ours = ["ADE PECNet vs Y-net (px): " + " \u00b7 ".join(
        f"K_a = {k_a}: {p.value:.2f} (K = {k}) vs {y.value:.2f}" for k_a, k, p, y in pairs)]
    margins = [Margin(f"K_a = {k_a}", ((1.0, p), (-1.0, y))) for k_a, _, p, y in pairs]
    return decide(margins, "px", 2, ours, paper_lines)


def check_sdd_short_pecnet(store: MetricsStore, paper: Mapping) -> Outcome:
    """Short-term SDD, K = 20: PECNet's ADE and FDE exceed Y-net's."""
    columns = {m: paper_column(paper, "sdd_short", model=m, k=20) for m in ("pecnet", "ynet")}
    paper_lines = [versus(m.upper(), "PECNet", columns["pecnet"][m], "Y-net", columns["ynet"][m],
                          "px", 2) for m in METRICS]
    found = {m: (short_sdd(store, "pecnet", 20, m), short_sdd(store, "ynet", 20, m)) for m in METRICS}
    absent = first_absent(v for pair in found.values() for v in pair)
    if absent is not None:
        return not_measured(absent, paper=paper_lines)
    ours = [versus(m.upper(), "PECNet", p.value, "Y-net", y.value, "px", 2)
            for m, (p, y) in found.items()]
    margins = [Margin(f"{m.upper()}: PECNet \u2212 Y-net", ((1.0, p), (-1.0, y)))
               for m, (p, y) in found.items()]
    return decide(margins, "px", 2, ours, paper_lines)


def below_all(others: Mapping[str, list[tuple[str, Term]]], ynet: Mapping[str, Term]) -> list[Margin]:
    """Y-net below every other model: one margin (other - Y-net) per column and other model."""
    return [Margin(f"{column}: {other.model}", ((1.0, other), (-1.0, ynet[column])))
            for column, pairs in others.items() for _, other in pairs]


def run_here(others: Sequence[str], paper_only: Iterable[str]) -> str:
    return (f"among the models run here: {', '.join(label(o) for o in others)}; "
            f"paper only: {', '.join(sorted(set(paper_only)))}")


def best_line(others: Iterable[tuple[str, float]], ynet: float, decimals: int) -> str:
    """'Y-net 7.85, next PECNet* 9.96': Y-net's and the lowest of the others' values."""
    name, value = min(others, key=lambda e: e[1])
    return f"Y-net {ynet:.{decimals}f}, next {name} {value:.{decimals}f}"


def check_sdd_short_best(store: MetricsStore, paper: Mapping) -> Outcome:
    """Short-term SDD: Y-net's ADE and FDE are the lowest of the models we run, at K = 20 and 5."""
    cols = paper["sdd_short"]["columns"]
    paper_lines = [f"K = {k} {m.upper()}: " + best_line(
        ((c["label"], c[m]) for c in cols if c["k"] == k and c["model"] != "ynet"),
        paper_column(paper, "sdd_short", model="ynet", k=k)[m], 2) for k in (20, 5) for m in METRICS]
    others = other_models(store, "short_term/sdd.json")
    if isinstance(others, Absent):
        return not_measured(others, paper=paper_lines)
    ynet, by = {}, {}
    for k in (20, 5):
        for m in METRICS:
            column = f"K = {k} {m.upper()}"
            ynet[column] = short_sdd(store, "ynet", k, m)
            by[column] = [(o, short_sdd(store, o, k, m)) for o in others]
    absent = first_absent([*ynet.values(), *(t for pairs in by.values() for _, t in pairs)])
    if absent is not None:
        return not_measured(absent, paper=paper_lines)
    ours = [f"{column}: " + best_line(((t.model, t.value) for _, t in pairs), ynet[column].value, 2)
            for column, pairs in by.items()]
    unrun = (c["label"] for c in cols if c["model"] not in (*others, "ynet"))
    return decide(below_all(by, ynet), "px", 2, ours, paper_lines, run_here(others, unrun))


def check_ethucy_best(store: MetricsStore, paper: Mapping) -> Outcome:
    """ETH/UCY, the average of the five scenes: Y-net's ADE and FDE are the lowest of the models
    we run."""
    entries = paper["eth_ucy"]["models"]
    paper_lines = [f"AVG {m.upper()}: " + best_line(
        ((e["label"], e[m]["avg"]) for e in entries if e["model"] != "ynet"),
        paper_ethucy(paper, "ynet")[m]["avg"], 2) for m in METRICS]
    others = other_models(store, f"short_term/ethucy_{ETHUCY_SCENES[0]}.json")
    if isinstance(others, Absent):
        return not_measured(others, paper=paper_lines)
    ynet = {f"AVG {m.upper()}": ethucy_avg(store, "ynet", m) for m in METRICS}
    by = {f"AVG {m.upper()}": [(o, ethucy_avg(store, o, m)) for o in others] for m in METRICS}
    absent = first_absent([*ynet.values(), *(t for pairs in by.values() for _, t in pairs)])
    if absent is not None:
        return not_measured(absent, paper=paper_lines)
    ours = [f"{column} (m): Y-net {ynet[column].value:.3f}, "
            + ", ".join(f"{t.model} {t.value:.3f}" for _, t in pairs) for column, pairs in by.items()]
    unrun = (e["label"] for e in entries if e["model"] not in (*others, "ynet"))
    return decide(below_all(by, ynet), "m", 3, ours, paper_lines, run_here(others, unrun))


def check_trajectron(store: MetricsStore, paper: Mapping) -> Outcome:
    """Against Trajectron++, which this pipeline does not run."""
    t, y = paper_ethucy(paper, "trajectronpp"), paper_ethucy(paper, "ynet")
    paper_lines = [versus(f"AVG {m.upper()}", "Trajectron++", t[m]["avg"], "Y-net", y[m]["avg"],
                          "m", 2) for m in METRICS]
    ours = [f"Y-net AVG {m.upper()} {v.value:.3f} m" for m in METRICS
            if isinstance(v := ethucy_avg(store, "ynet", m), Term)]
    return not_measured(Absent("Trajectron++ is not run by this pipeline (its numbers are the "
                               "paper's, quoted from its own paper)"), ours, paper_lines)


# ---------------------------------------------------------------------------------------------
# The claims, in the paper's order of results


CLAIMS: tuple[Claim, ...] = (
    Claim("sdd-short-best", "Table 1 caption (short term, SDD)",
          "Our method significantly outperforms previous state-of-the-art methods (indicated by *) on "
          "the Stanford Drone Dataset on both the ADE & FDE metrics for both settings of K",
          "holds if Y-net's ADE and FDE are below every other model's we run, at K = 20 and K = 5, "
          "each difference beyond its training-seed spread", check_sdd_short_best),
    Claim("sdd-short-pecnet", "Results, Stanford Drone Results",
          "outperforms the previous state-of-the-art performance of PECNet by 26.8% on ADE and 34.0% on FDE",
          "holds if PECNet's ADE and FDE (K = 20) are above Y-net's beyond the training-seed spread "
          "(the percentages are shown, not tested)", check_sdd_short_pecnet),
    Claim("ethucy-best", "Table 2 caption (short term, ETH/UCY)",
          "Our proposed method establishes new state-of-the-art results (previous results denoted by *) "
          "on both the ADE & the FDE metrics",
          "holds if Y-net's AVG ADE and FDE (mean of the five scenes) are below every other model's "
          "we run, beyond the training-seed spread", check_ethucy_best),
    Claim("ethucy-trajectron", "Results, ETH & UCY Results",
          "improving the previously state-of-the-art performance from Trajectron++ of 0.19 ADE & 0.41 "
          "FDE by about 5.6% ADE and 51.9% FDE",
          "holds if Trajectron++'s AVG ADE and FDE are above Y-net's", check_trajectron),
    Claim("sdd-long-over-50", "Results, Long Term: Forecasting Results",
          "improving upon PECNet's performance by over 50%",
          "ADE, the metric the Introduction names with 50.6 %: holds if PECNet's ADE exceeds 1.5 "
          "\u00d7 Y-net's (t_f = 30 s) by more than the training-seed spread", check_over_50),
    Claim("sdd-long-intro", "Introduction (long term, SDD part)",
          "substantially improves the performance of state-of-the-art short term methods by over "
          "50.6% and 35.0% respectively, on ADE and 77.1% and 55.9% respectively, on FDE metric",
          "SDD: holds if PECNet's ADE is at least 50.6 % and its FDE at least 77.1 % above Y-net's "
          "(as printed, to 0.1 %), beyond the training-seed spread", check_intro_sdd),
    Claim("ind-long", "Results, Long Term: Forecasting Results",
          "Y-net outperforms PECNet on InD improving ADE performance from 20.25 to 14.99 and FDE from "
          "32.95 to 21.13",
          "holds if Y-net's ADE and FDE on inD (t_f = 30 s) are below PECNet's beyond the "
          "training-seed spread", check_ind),
    Claim("horizon-gap", "Figure 4 caption",
          "we observe a consistently growing difference in ADE between Y-net and PECNet",
          "holds if the ADE gap PECNet \u2212 Y-net grows at every step from one measured horizon to "
          "the next, each step beyond its training-seed spread", check_horizon_gap),
    Claim("separate-vs-recurrent", "Results, Varying Prediction Horizon",
          "training a separate model for different time horizons is significantly better than using a "
          "short temporal horizon model recurrently",
          f"holds if PECNet's ADE is below R-PECNet's at every measured horizon beyond {RECURRENT_TF} s "
          "(where they are one model), each difference beyond its training-seed spread", check_recurrent),
    Claim("ttst-sdd", "Results, Test-Time Sampling Trick (SDD part)",
          "TTST reduces the error on SDD and inD by 9.1% and 18.5% in ADE, respectively, and 30.4% "
          "and 35.0% in FDE",
          "holds if Y-net's ADE and FDE with CWS only are above those with TTST + CWS (Table 4)",
          check_ttst_sdd),
    Claim("ttst-ind", "Results, Test-Time Sampling Trick (inD part)",
          "TTST reduces the error on SDD and inD by 9.1% and 18.5% in ADE, respectively, and 30.4% "
          "and 35.0% in FDE",
          "holds if Y-net's ADE and FDE on inD with CWS only are above those with TTST + CWS",
          check_ttst_ind),
    Claim("cws-ade", "Results, Conditioned Waypoint Sampling",
          "the ADE decreases by 24.3%",
          "holds if Y-net's ADE without TTST and CWS is above its ADE with CWS only (Table 4)",
          check_cws_ade),
    Claim("cws-fde", "Results, Conditioned Waypoint Sampling",
          "While it doesn't affect the goal sampling, i.e. the FDE",
          "holds if the FDE with CWS only differs from the FDE without either by no more than their "
          "spread over evaluation rounds", check_cws_fde),
    Claim("ka-ade", "Results, Varying K_a",
          "We show consistent ADE improvements for various K_e while increasing K_a",
          "holds if, at every K_e of the K_a grid, Y-net's ADE falls at every step up in K_a",
          check_ka),
    Claim("pecnet-more-samples", "Results, Varying K_a",
          "PECNet's performance is significantly worse than Y-net at K_e = 20 for all K_a",
          "holds if PECNet's ADE with K = 20 K_a samples is above Y-net's (K_e = 20) at every K_a "
          "both were scored at, beyond the training-seed spread", check_pecnet_samples),
)


def evaluate(store: MetricsStore, paper: Mapping, claims: Sequence[Claim] = CLAIMS) -> list[ClaimRow]:
    """Every claim's outcome; a rule that fails on a malformed file says so as `not measured`."""
    rows = []
    for claim in claims:
        try:
            outcome = claim.check(store, paper)
        except (KeyError, TypeError, ValueError, ZeroDivisionError, StopIteration) as e:
            outcome = Outcome("not measured", f"could not apply the rule: {type(e).__name__}: {e}")
        rows.append(ClaimRow(claim, outcome))
    return rows


def claims_section(store: MetricsStore, paper: Mapping) -> dict[str, Any]:
    """The template's context: the rows and how many claims have each verdict."""
    rows = evaluate(store, paper)
    return {"rows": rows,
            "counts": {v: sum(r.outcome.verdict == v for r in rows) for v in VERDICTS}}
