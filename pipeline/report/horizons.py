"""What the report shows of `metrics/horizon_analysis.json` (stage `horizon_analysis`), and its
two figures.

`section(record)` gives a report section its rows: one per horizon (the test windows, their
sources, median speed, standing-still share, constant velocity, the straight line to the true
goal, Y-net, its FDE / ADE and the median spread of its K goals), one per horizon of the one-population comparison (the longest
horizon's test windows truncated at t), the leak-check total and the figure paths. `draw_figures`
draws the figures from the record alone (matplotlib, Agg):

- `curves.png`: ADE and FDE against t_f, each horizon on its own test windows (top) and on one
  population (bottom: the longest horizon's models' predictions scored over their first t
  seconds, solid, and each horizon's own Y-net run on the truncated windows, dashed);
- `model.png`: who is in each horizon's test set (median speed, standing-still share), Y-net's
  validation ADE per epoch, FDE / ADE per horizon and model, and Y-net's per-window FDE against
  ADE beyond the release horizon.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pipeline.io import write_with
from pipeline.model_list import YNET
from pipeline.models import ShownModel
from pipeline.models.constant_velocity import NAME as CONSTANT_VELOCITY
from pipeline.report.lookups import dig

SUBJECT = YNET
RELEASE_HORIZON = 30  # s: the authors' released windows' horizon, the main Y-net's
FIGURES = {"curves": "curves.png", "model": "model.png"}


def _t(name: str) -> int:
    return int(name.removeprefix("tf"))


# ---------------------------------------------------------------------------------------------
# The section's rows


def horizon_rows(record: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One row per horizon, each horizon on its own test windows (None where a value is absent)."""
    rows = []
    for name, row in (record.get("per_horizon") or {}).items():
        models = row.get("models") or {}
        rows.append({
            "t_f": _t(name),
            "test_windows": dig(row, "data", "windows"),
            "raw": (dig(row, "data", "sources") or {}).get("raw", 0),
            "release_chain": (dig(row, "data", "sources") or {}).get("release_chain", 0),
            "release": (dig(row, "data", "sources") or {}).get("release", 0),
            "median_speed_px_s": dig(row, "data", "speed_px_s", "median"),
            "standing_share": dig(row, "data", "standing_share"),
            "cv_ade": dig(models, CONSTANT_VELOCITY, "ade"),
            "cv_fde": dig(models, CONSTANT_VELOCITY, "fde"),
            "straight_to_goal_ade": dig(row, "straight_to_goal", "ade"),
            "ynet_ade": dig(models, SUBJECT, "ade"),
            "ynet_fde": dig(models, SUBJECT, "fde"),
            "ynet_fde_over_ade": dig(models, SUBJECT, "fde_over_ade"),
            "ynet_goal_spread_px": dig(models, SUBJECT, "endpoints", "spread_px", "median"),
            "ynet_not_run": dig(models, SUBJECT, "not_run"),
        })
    return sorted(rows, key=lambda r: r["t_f"])


def one_population_rows(record: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One row per horizon t of the one-population comparison: the straight line to the true
    position at t, each stored longest-horizon model over its first t steps
    (`<model>_ade` / `<model>_fde`) and the own-horizon models (`own_<model>_ade` / `_fde`)."""
    rows = []
    for name, row in (dig(record, "one_population", "per_horizon") or {}).items():
        out: dict[str, Any] = {"t_f": _t(name),
                               "straight_to_goal_ade": dig(row, "straight_to_goal", "ade"),
                               "median_speed_px_s": dig(row, "speed_px_s", "median")}
        for model, scores in (row.get("longest_predictions_truncated") or {}).items():
            out[f"{model}_ade"], out[f"{model}_fde"] = scores.get("ade"), scores.get("fde")
        for model, scores in (row.get("own_horizon_models") or {}).items():
            out[f"own_{model}_ade"], out[f"own_{model}_fde"] = scores.get("ade"), scores.get("fde")
        rows.append(out)
    return sorted(rows, key=lambda r: r["t_f"])


def grows(values: list[Any]) -> bool | None:
    """Whether the numbers rise at every step (None with fewer than two numbers)."""
    numbers = [v for v in values if isinstance(v, (int, float))]
    if len(numbers) < 2:
        return None
    return all(b > a for a, b in zip(numbers, numbers[1:]))


def findings(record: Mapping[str, Any]) -> dict[str, Any]:
    """What the rows say, for the section's text (read off the record, never typed in): whether
    Y-net's ADE rises with t_f on its own test windows per horizon and on one population (the
    longest horizon's stored predictions truncated, and each horizon's own model), the fastest and
    slowest median walker speed across horizons, and the leak-check total."""
    rows, population = horizon_rows(record), one_population_rows(record)
    speeds = [(r["median_speed_px_s"], r["t_f"]) for r in rows
              if isinstance(r["median_speed_px_s"], (int, float))]
    return {
        "per_horizon_grows": grows([r["ynet_ade"] for r in rows]),
        "one_population_grows": grows([r.get(f"{SUBJECT}_ade") for r in population]),
        "own_models_grow": grows([r.get(f"own_{SUBJECT}_ade") for r in population]),
        "fastest": max(speeds) if speeds else None,   # (median px/s, t_f)
        "slowest": min(speeds) if speeds else None,
        "leak_total": dig(record, "leak_check", "total"),
        # (smallest, largest) median spread of Y-net's K goals from the release horizon on (px)
        "goal_spread_px": _span([r["ynet_goal_spread_px"] for r in rows
                                 if r["t_f"] >= RELEASE_HORIZON]),
    }


def _span(values: list[Any]) -> tuple[float, float] | None:
    numbers = [v for v in values if isinstance(v, (int, float))]
    return (min(numbers), max(numbers)) if numbers else None


def section(record: Mapping[str, Any]) -> dict[str, Any]:
    """What a report section needs: `rows` (per horizon), `one_population` (its rows, the horizon
    and window count), `findings`, `leak_total` and `figures` (file names as the stage wrote them)."""
    population = record.get("one_population") or {}
    return {"rows": horizon_rows(record),
            "one_population": {"horizon": population.get("horizon"),
                               "windows": population.get("windows"),
                               "rows": one_population_rows(record)},
            "findings": findings(record),
            "leak_total": dig(record, "leak_check", "total"),
            "figures": [Path(p).name for p in (record.get("figures") or {}).values()]}


# ---------------------------------------------------------------------------------------------
# Figures


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: Path) -> None:
    write_with(path, lambda tmp: fig.savefig(tmp, format="png"))


def _series(rows: Mapping[str, Any], *keys: str) -> tuple[list[int], list[float]]:
    """(t_f, value) of every horizon (`tf<t>` -> node) where node[keys...] is a number."""
    points = sorted((_t(name), dig(node, *keys)) for name, node in rows.items())
    points = [(t, v) for t, v in points if isinstance(v, (int, float))]
    return [t for t, _ in points], [v for _, v in points]


def model_colour(shown: Mapping[str, ShownModel], model: str) -> str | None:
    return shown[model].colour if model in shown else None


def model_label(shown: Mapping[str, ShownModel], model: str) -> str:
    return shown[model].label if model in shown else model


def _models(per_horizon: Mapping[str, Any]) -> list[str]:
    found = {m for row in per_horizon.values() for m in (row.get("models") or {})}
    return sorted(found, key=lambda m: (m != SUBJECT, m))


def plot_curves(record: Mapping[str, Any], path: Path, shown: Mapping[str, ShownModel]) -> None:
    plt = _pyplot()
    per_horizon = record["per_horizon"]
    population = record["one_population"]
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), dpi=100, sharex=True, sharey="col")
    for col, metric in enumerate(("ade", "fde")):
        top, bottom = axes[0, col], axes[1, col]
        for model in _models(per_horizon):
            xs, ys = _series(per_horizon, "models", model, metric)
            top.plot(xs, ys, marker="o", color=model_colour(shown, model),
                     label=model_label(shown, model))
            xs, ys = _series(population["per_horizon"], "longest_predictions_truncated", model,
                             metric)
            bottom.plot(xs, ys, marker="o", color=model_colour(shown, model),
                        label=f"{model_label(shown, model)}, {population['horizon']}-s model, "
                              "first t s")
            xs, ys = _series(population["per_horizon"], "own_horizon_models", model, metric)
            if xs:
                bottom.plot(xs, ys, marker="s", linestyle="--", markerfacecolor="none",
                            color=model_colour(shown, model),
                            label=f"{model_label(shown, model)}, each horizon's own model")
        if metric == "ade":
            xs, ys = _series(per_horizon, "straight_to_goal", "ade")
            top.plot(xs, ys, "k:", marker=".", label="straight line to the true goal (FDE 0)")
            xs, ys = _series(population["per_horizon"], "straight_to_goal", "ade")
            bottom.plot(xs, ys, "k:", marker=".", label="straight line to the true goal (FDE 0)")
        counts = ", ".join(f"{_t(n)}: {dig(r, 'data', 'windows')}" for n, r in per_horizon.items())
        top.set_title(f"{metric.upper()}, each horizon on its own test windows", fontsize=10)
        bottom.set_title(f"{metric.upper()}, one population: the {population['windows']} test "
                         f"windows of {population['horizon']} s, truncated at t", fontsize=10)
        bottom.set_xlabel("t_f (s)")
        top.set_ylabel(f"{metric.upper()} (px, best of K)")
        bottom.set_ylabel(f"{metric.upper()} (px, best of K)")
        if col == 0:
            top.text(0.01, 0.98, f"test windows per t_f: {counts}", transform=top.transAxes,
                     fontsize=7, va="top")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="center left")
    axes[1, 0].legend(fontsize=6.5, loc="upper left")
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)


def plot_model(record: Mapping[str, Any], path: Path, shown: Mapping[str, ShownModel]) -> None:
    plt = _pyplot()
    per_horizon = record["per_horizon"]
    population = record["one_population"]["per_horizon"]
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), dpi=100)

    ax = axes[0, 0]
    for rows, keys, style, label in (
            (per_horizon, ("data", "speed_px_s"), "-", "own test windows"),
            (population, ("speed_px_s",), "--", "one population")):
        xs, median = _series(rows, *keys, "median")
        _, q25 = _series(rows, *keys, "q25")
        _, q75 = _series(rows, *keys, "q75")
        ax.plot(xs, median, "k" + style, marker="o", label=f"median speed, {label}")
        if style == "-":
            ax.fill_between(xs, q25, q75, color="black", alpha=0.08)
    twin = ax.twinx()
    xs, share = _series(per_horizon, "data", "standing_share")
    twin.plot(xs, share, color="tab:orange", marker="^", label="standing share, own windows")
    xs, share = _series(population, "standing_share")
    twin.plot(xs, share, color="tab:orange", marker="^", linestyle="--",
              label="standing share, one population")
    twin.set_ylim(0, 1)
    twin.set_ylabel("share standing still", color="tab:orange")
    ax.set_ylabel("speed over the future (px/s)")
    ax.set_xlabel("t_f (s)")
    ax.set_title("Who is in each horizon's test set (band: speed quartiles, own windows)",
                 fontsize=10)
    handles = ax.get_legend_handles_labels()
    extra = twin.get_legend_handles_labels()
    ax.legend(handles[0] + extra[0], handles[1] + extra[1], fontsize=7, loc="upper right")
    ax.grid(alpha=0.3)

    ax = axes[0, 1]
    curves = record.get("ynet_training") or {}
    trained = {_t(n): c for n, c in curves.items() if c.get("trained") and c.get("val_ade")}
    cmap = plt.cm.viridis
    for i, (t, curve) in enumerate(sorted(trained.items())):
        ax.plot(range(1, len(curve["val_ade"]) + 1), curve["val_ade"], marker=".",
                color=cmap(i / max(len(trained) - 1, 1)), label=f"{t} s")
    missing = [str(_t(n)) for n, c in curves.items() if not c.get("trained")]
    title = "Y-net validation ADE per epoch (deterministic, K = 1)"
    if missing:
        title += f"\nnot trained: {', '.join(missing)} s"
    ax.set_title(title, fontsize=10)
    if trained:
        ax.set_yscale("log")
        ax.legend(fontsize=7, ncol=2)
    ax.set_xlabel("epoch")
    ax.set_ylabel("val ADE (px)")
    ax.grid(alpha=0.3)

    ax = axes[1, 0]
    for model in _models(per_horizon):
        xs, ys = _series(per_horizon, "models", model, "fde_over_ade")
        ax.plot(xs, ys, marker="o", color=model_colour(shown, model),
                label=model_label(shown, model))
    ax.set_title("FDE / ADE (means over the test windows), own windows", fontsize=10)
    ax.set_xlabel("t_f (s)")
    ax.set_ylabel("FDE / ADE")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)

    ax = axes[1, 1]
    markers = iter("os^Dv<>")
    top = 0.0
    for name, row in per_horizon.items():
        errors = dig(row, "models", SUBJECT, "per_window")
        if not errors:
            continue
        ax.scatter(errors["ade"], errors["fde"], s=14, alpha=0.6, marker=next(markers),
                   label=f"{_t(name)} s ({len(errors['ade'])} windows)")
        top = max(top, max(errors["ade"] + errors["fde"]))
    if top:
        ax.plot([0, top], [0, top], "k:", linewidth=1, label="FDE = ADE")
        ax.plot([0, top / 2], [0, top], "k--", linewidth=0.8, alpha=0.5, label="FDE = 2 ADE")
        ax.legend(fontsize=7)
    ax.set_title("Y-net per test window, beyond 30 s (first round)", fontsize=10)
    ax.set_xlabel("ADE (px)")
    ax.set_ylabel("FDE on the sampled goal (px)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)


def draw_figures(record: Mapping[str, Any], folder: Path,
                 shown: Mapping[str, ShownModel]) -> dict[str, str]:
    """Both figures into `folder`, each model drawn as `shown` (name -> label and colour:
    `pipeline.models.all_models`); {name: path} as written (the record's `figures`)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = {name: folder / file for name, file in FIGURES.items()}
    plot_curves(record, paths["curves"], shown)
    plot_model(record, paths["model"], shown)
    return {name: path.as_posix() for name, path in paths.items()}


def print_summary(record: Mapping[str, Any]) -> None:
    """The per-horizon and one-population rows on stdout, and the leak-check total."""
    def f(value: Any, width: int, decimals: int = 1) -> str:
        if isinstance(value, (int, float)):
            return f"{value:{width}.{decimals}f}"
        return f"{'-':>{width}}"

    print(" t_f  test  raw chain v_med stand CV_ADE CV_FDE line YN_ADE YN_FDE F/A")
    for r in horizon_rows(record):
        chained = r["release_chain"] + r["release"]
        print(f"{r['t_f']:4d} {r['test_windows']:5d} {r['raw']:4d} {chained:5d}"
              f" {f(r['median_speed_px_s'], 5)} {f(r['standing_share'], 5, 2)} {f(r['cv_ade'], 6)}"
              f" {f(r['cv_fde'], 6)} {f(r['straight_to_goal_ade'], 5)} {f(r['ynet_ade'], 6)}"
              f" {f(r['ynet_fde'], 6)} {f(r['ynet_fde_over_ade'], 4, 2)}")
    print("one population (longest horizon's test windows, truncated at t): ADE / FDE")
    for r in one_population_rows(record):
        cells = "  ".join(f"{k[:-4]} {f(r[k], 5)}/{f(r[k[:-4] + '_fde'], 5)}"
                          for k in r if k.endswith("_ade") and k != "straight_to_goal_ade")
        print(f"{r['t_f']:4d} line {f(r['straight_to_goal_ade'], 5)}  {cells}")
    print(f"leak check: {dig(record, 'leak_check', 'total')} overlap(s)")
