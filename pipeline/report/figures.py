"""The page's figures (matplotlib, Agg, PNG): series with their spread over rounds and the paper's
points (`plot_series`), and the qualitative figure in the paper's Figure 6 layout from the Y-net
evaluation's arrays (`load_qualitative`, `plot_qualitative`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.report.common import MODEL_COLOURS
from pipeline.report.lookups import Absent
from pipeline.report.series import Series

QUALITATIVE_KEYS = ("scene_image", "past", "future", "goal_heatmap", "sampled_goals",
                    "trajectory_heatmap", "predictions")


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def series_colours(keys: Iterable[str], models: Mapping[str, str] = MODEL_COLOURS) -> dict[str, Any]:
    """A model's colour (`models`: key -> colour) for its series; Y-net's K_e series in shades of
    its red, light to dark."""
    plt = _pyplot()
    keys = list(keys)
    shades = [k for k in keys if k.startswith("ynet_ke")]
    colours = {k: plt.cm.Reds(0.45 + 0.5 * i / max(len(shades) - 1, 1)) for i, k in enumerate(shades)}
    return {k: colours.get(k) or models.get(k.split("_k")[0] if k.startswith("pecnet_k") else k)
            for k in keys}


def plot_series(series: list[Series], paper_points: list[tuple[float, float, str, str, str]],
                xlabel: str, path: Path, models: Mapping[str, str] = MODEL_COLOURS) -> bool:
    """Lines with error bars (std over rounds) per series, plus labelled paper points.

    `paper_points`: (x, y, series key for the colour, legend label, name written beside the
    point). Returns False (no file) when no series has a measured point: the page then says why
    instead of an empty plot.
    """
    drawn = [s for s in series if s.points]
    if not drawn:
        return False
    plt = _pyplot()
    colours = series_colours([s.key for s in series] + [key for _, _, key, _, _ in paper_points],
                             models)
    fig, ax = plt.subplots(figsize=(7, 4.2), dpi=110)
    for s in drawn:
        xs = [x for x, _ in s.points]
        ys = [v.mean for _, v in s.points]
        err = [v.std or 0.0 for _, v in s.points]
        ax.errorbar(xs, ys, yerr=err, marker="o", capsize=3, label=f"{s.label} (ours)",
                    color=colours[s.key])
    for x, y, key, _, name in paper_points:
        ax.plot([x], [y], marker="D", markersize=8, linestyle="none", markerfacecolor="none",
                markeredgewidth=1.6, color=colours[key] or "black")
        if name:
            ax.annotate(name, (x, y), xytext=(7, -3), textcoords="offset points", fontsize=7,
                        color=colours[key] or "black")
    for label in dict.fromkeys(label for _, _, _, label, _ in paper_points):  # one black legend entry
        ax.plot([], [], marker="D", linestyle="none", markerfacecolor="none", color="black", label=label)
    values = [v.mean for s in drawn for _, v in s.points] + [y for _, y, _, _, _ in paper_points]
    if min(values) > 0 and max(values) / min(values) > 20:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("ADE (px, best of K)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True


@dataclass(frozen=True)
class Qualitative:
    examples: tuple[Mapping[str, np.ndarray], ...]
    problems: tuple[str, ...]


def load_qualitative(path: Path) -> Qualitative | Absent:
    """The Y-net evaluation's qualitative arrays, grouped by example index, shapes checked."""
    if not path.exists():
        return Absent(f"stage not yet run: {path.as_posix()} missing (written by the Y-net evaluation)")
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
    except (OSError, ValueError, EOFError) as e:  # EOFError: an empty file
        return Absent(f"{path.as_posix()} unreadable: {e}", "invalid")
    indices = sorted({int(m.group(1)) for name in arrays if (m := re.search(r"_(\d+)$", name))})
    examples, problems = [], []
    for i in indices:
        example = {key: arrays.get(f"{key}_{i}") for key in QUALITATIVE_KEYS}
        missing = [key for key, value in example.items() if value is None]
        problem = (f"example {i}: missing {', '.join(missing)}" if missing
                   else qualitative_shape_problem(example))
        if problem:
            problems.append(problem if problem.startswith("example") else f"example {i}: {problem}")
        else:  # optional `scene_id_<i>` (a string) names the row
            example["title"] = str(arrays.get(f"scene_id_{i}", f"example {i}"))
            examples.append(example)
    if not examples:
        return Absent(f"{path.as_posix()} holds no complete example"
                      + (f" ({'; '.join(problems)})" if problems else ""), "invalid")
    return Qualitative(tuple(examples), tuple(problems))


def qualitative_shape_problem(ex: Mapping[str, np.ndarray]) -> str:
    """'' when the arrays have the contract's shapes, else what is wrong."""
    checks = [
        ("scene_image", ex["scene_image"].ndim == 3 and ex["scene_image"].shape[2] == 3, "(H, W, 3)"),
        ("past", ex["past"].ndim == 2 and ex["past"].shape[1] == 2, "(n_p, 2)"),
        ("future", ex["future"].ndim == 2 and ex["future"].shape[1] == 2, "(n_f, 2)"),
        ("goal_heatmap", ex["goal_heatmap"].ndim == 2, "(H, W)"),
        ("sampled_goals", ex["sampled_goals"].ndim == 2 and ex["sampled_goals"].shape[1] == 2, "(K_e, 2)"),
        ("trajectory_heatmap", ex["trajectory_heatmap"].ndim == 2, "(H, W)"),
        ("predictions", ex["predictions"].ndim == 3 and ex["predictions"].shape[2] == 2, "(K, n_f, 2)"),
    ]
    bad = [f"{name} has shape {ex[name].shape}, expected {want}" for name, ok, want in checks if not ok]
    return "; ".join(bad)


def plot_qualitative(examples: Iterable[Mapping[str, np.ndarray]], path: Path) -> None:
    """The paper's Figure 6 layout: past | goal heatmap + goals | path heatmap | predictions."""
    examples = list(examples)
    plt = _pyplot()
    fig, axes = plt.subplots(len(examples), 4, figsize=(14, 3.6 * len(examples)), dpi=90, squeeze=False)
    titles = ("past (blue)", "goal heatmap, sampled goals", "trajectory heatmap for one goal",
              "predictions (red), ground truth (green)")
    for row, ex in zip(axes, examples, strict=True):
        image = ex["scene_image"]
        h, w = image.shape[:2]
        extent = (0, w, h, 0)  # heatmaps stretched over the image if their size differs
        for ax, title in zip(row, titles, strict=True):
            ax.imshow(image, extent=extent)
            ax.set_title(f"{ex['title']}: {title}" if ax is row[0] else title, fontsize=9)
            ax.set_axis_off()
        past, future = ex["past"], ex["future"]
        row[0].plot(past[:, 0], past[:, 1], "-o", color="#1f4fff", markersize=3)
        row[1].imshow(ex["goal_heatmap"], extent=extent, cmap="inferno", alpha=0.55)
        row[1].scatter(ex["sampled_goals"][:, 0], ex["sampled_goals"][:, 1], marker="*", s=40,
                       color="#ffe600", edgecolors="black", linewidths=0.4)
        row[2].imshow(ex["trajectory_heatmap"], extent=extent, cmap="inferno", alpha=0.55)
        for pred in ex["predictions"]:
            row[3].plot(pred[:, 0], pred[:, 1], "-", color="#e00000", linewidth=0.8, alpha=0.7)
        row[3].plot(future[:, 0], future[:, 1], "-", color="#00b000", linewidth=2)
        for ax in (row[2], row[3]):
            ax.plot(past[:, 0], past[:, 1], "-", color="#1f4fff", linewidth=2)
        for ax in row:
            ax.set_xlim(0, w)
            ax.set_ylim(h, 0)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
