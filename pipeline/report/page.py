"""The report: the HTML page a reviewer reads, the paper's numbers beside ours (stage `report`).

Reads every metrics file that exists (each one defensively: a missing or malformed file becomes an
explained absence, never a blank or a made-up number), the paper's values
(`pipeline/report/paper_values.yaml`), the params and the data manifests, and writes

- `reports/index.html` (jinja2, no scripts, no network): the paper's claims in words, each with
  ours and a verdict (`pipeline.report.claims`); Tables 1-4 cell by cell (paper, ours as
  mean and spread over evaluation rounds, relative difference coloured by size; every model
  registered in params.yaml `models`, README "Your model here", as a Table 3 column of its own,
  ours only: the paper has no value for it; each paper cell marked with who measured it and, where
  its source took the best of K otherwise than our headline, ours under that protocol beside it and
  compared, and why a cell differs: `pipeline.report.provenance`), the horizon and
  K_a figures, the training-seed spread (baselines and Y-net), the qualitative figure, "Beyond the paper's
  tables" (`pipeline.report.beyond`: the metrics of stages `score_predictions` and
  `score_short_term_predictions`: long-term SDD, the short-term benchmarks, inD), the data audit and
  counts, segmentation scores, provenance;
- its figures as PNG files (matplotlib, Agg) in `reports/figures/report/`;
- the figure series as JSON for `dvc plots` in `reports/plots/`;
- a section "Predictions, step by step" showing the animations stage `animations` wrote (its
  `index.json` in `--animations`; linked where they are, not copied), or why there are none.

Everything is written to a temporary path and renamed, so an interrupted run leaves the previous
report intact.

Metrics read (paths relative to `--metrics`; a record {"status": ..., "reason": ...} in place of
results is shown as its reason):
- `ynet_eval.json`: {"profile", "t_f", "rounds", "main": {"ade": {"mean", "std"}, "fde", "ade_joint",
  "fde_joint"}, "ablation": {"none"|"cws"|"ttst_cws": {...}}, "ka_grid": [{"k_e", "k_a", "ade", "fde"}]}
- `ynet_horizons/tf<H>.json`: {"main": {...}} or {"not_run_reason": "..."} (t_f = 30: ynet_eval.json);
  `baselines/<model>_tf<H>.json`: {"ade": {"mean", "std"}, "fde", ..., "rounds", "k", "horizon"};
  `baselines/pecnet_ka.json`: [{"k_a", "k", "ade": {"mean", "std"}, "fde"}]
- `baseline_seed_spread.json` (`pipeline.studies.seed_spread`): {"extra_seeds", "ynet_extra_seeds",
  "entries": [{"model", "horizon", "evaluation", "over_training_seeds": {"ade": {"mean", "std"}, ...},
  "main_round_std": {"ade", "fde"}, "per_seed": [{"seed", "ade", "fde", "best_epoch",
  "best_val_ade"}]}]}; an entry with "not_run_reason" (Y-net where the profile trains no extra seed)
  has no "over_training_seeds"
- `short_term/sdd.json`: {"rounds", "models": {<model>: {"k20"|"k5": {"ade": {"mean", "std"}, "fde"}}}}
- `short_term/ethucy_<scene>.json`: {"rounds", "models": {<model>: {"ade": {...}, "fde": {...}}}}
- `ind_benchmark.json`: as `ynet_eval.json` plus "baselines": {<model>: {"ade", "fde"}} (or a status record)
- `beyond/long_term.json`: {"thresholds", "tables": {<table>: {"t_f", "models": {<model>: {"rounds",
  "metrics": {<metric>: {"mean", "std"}}, "ground_truth": {<metric>: value}} or {"not_run_reason"}}}}}
  (`pipeline.harness.stored_scores`); `beyond/short_term.json` and `beyond/ind.json`: {"thresholds",
  "benchmarks": {<name>: {"unit", "scene_masks", "models": {<model>: the same model record}}}}
- `segmentation.json`: {"miou", "iou": {class: iou}}; the data files `windows.json`,
  `data_audit.json`, `horizon_windows.json`, `chain_bias.json`, and `sdd_sources.json` (stage
  `tracks`: {"copy": {"provided", "path"}, "videos": {<video>: {"origin", "file", "sha256",
  "pinned", "rows"}}, "reference_images": {<file>: {"sha256", "pinned"}}, "totals"}).
A value is a number (measured once) or {"mean", "std", ...} over seeded rounds
(`pipeline.harness.metrics.seeded_rounds`, the one layout every scoring stage writes).

The page is assembled here (`build_context`, `write_report`) from its parts:
`pipeline.report.tables` (Tables 1-4, their summaries, the headline metrics), `series` (the
figures' series, the Table 3 diagnostics section), `figures` (matplotlib), `seed_spread`,
`data_and_segmentation`, `run_provenance` (commit, dvc.lock, machine, stage times) and `common`
(what they share), with `claims`, `beyond`, `horizons` and `lookups`.

The stage (`pipeline.stages.report`) calls `write_report`.
"""

from __future__ import annotations

import datetime as dt
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TYPE_CHECKING

import yaml

from pipeline.splits import TEST_VIDEOS
from pipeline.io import atomic_dir, write_text
from pipeline.models import ModelEntry
from pipeline.report import horizons
from pipeline.report.beyond import beyond_section
from pipeline.report.claims import claims_section
from pipeline.report.common import (LONG_TERM_KE, LONG_TERM_TF, FigureSlot, horizon_models,
                                    model_colours, table_models)
from pipeline.report.data_and_segmentation import (chain_bias_rows, scene_count_rows,
                                                   segmentation_scores,
                                                   window_count_rows)
from pipeline.report.figures import plot_series
from pipeline.report.lookups import Absent, Measured, MetricsStore, is_number, load_metrics
from pipeline.report.budget import budget_runs, budget_section
from pipeline.report.short_term_seeds import seed_rows, short_term_seeds
from pipeline.report.provenance import PROTOCOL_KEYS, PROTOCOL_LABELS, PROTOCOLS, load_paper_values
from pipeline.report.run_provenance import (git_state, lock_outputs, lock_params, machine,
                                            manifest_checksums, profiles, raw_data_hashes,
                                            sdd_sources, stage_profile, stage_timings)
from pipeline.report.seed_spread import seed_spread_section
from pipeline.report.series import (diagnostics_section, horizon_series, ka_series, paper_ka_points,
                                    paper_long_term_points, plot_rows)
from pipeline.report.tables import build_tables, headline_metrics, summarize

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.report import ReportParams

TEMPLATE = Path(__file__).parent / "templates" / "report.html.j2"


def fmt_number(value: Any, decimals: int = 2) -> str:
    return f"{value:,.{decimals}f}" if is_number(value) else "n/a"


def fmt_pct(value: Any) -> str:
    return f"{value * 100:+.1f} %" if is_number(value) else "n/a"


def fmt_duration(seconds: Any) -> str:
    if not is_number(seconds):
        return "n/a"
    if seconds < 120:
        return f"{seconds:.1f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.2f} h"


def render_html(context: Mapping[str, Any], template: Path = TEMPLATE) -> str:
    import jinja2
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(template.parent), autoescape=True,
                             undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True)
    env.filters.update(num=fmt_number, pct=fmt_pct, dur=fmt_duration)
    env.tests.update(absent=lambda v: isinstance(v, Absent), measured=lambda v: isinstance(v, Measured))
    return env.get_template(template.name).render(**context)


@dataclass(frozen=True)
class Inputs:
    """Where everything the report reads lives (the stage's arguments)."""
    metrics: Path
    paper: Path
    scene_counts: Path
    gallery: Path  # stage report_figures' folder: the qualitative figure, the segmentation gallery
    manifests: Path
    repo: Path = field(default_factory=Path.cwd)
    own_outputs: tuple[str, ...] = ()  # the report's outputs, relative to `repo`
    stage_times: Path | None = None  # tools/timed_repro.py's record of `make repro`
    animations: Path | None = None  # stage animations' folder (index.json and the animations)
    horizon_figures: Path | None = None  # stage horizon_analysis' figures folder
    short_term_seeds: Path | None = None  # the study's runs of Tables 1-2's baselines
    budget: Path | None = None  # the budget-curve study's runs


def rel_src(path: Path, html_dir: Path) -> str:
    """An <img src> relative to the page, so it opens from the file system."""
    return Path(os.path.relpath(path.resolve(), html_dir.resolve())).as_posix()


def figure_sections(paper: Mapping, store: MetricsStore, horizons: list[int], gallery: Mapping,
                    slot, registered: Mapping[str, ModelEntry] | None = None) -> tuple[dict, dict]:
    """Figures 4-6 drawn (when there is something to draw) and described; the dvc plots series.
    Figure 4 has a line for every `registered` model too."""
    registered = registered or {}
    models, colours = horizon_models(registered), model_colours(registered)
    h_series, k_series = horizon_series(store, horizons, models), ka_series(store)
    names = dict(models)
    h_paper = [(LONG_TERM_TF, y, key, "paper, Table 3 (t_f = 30 s)", f"{names.get(key, key)} (paper)")
               for key, y in paper_long_term_points(paper).items()]
    k_paper = [(x, y, f"ynet_ke{LONG_TERM_KE}", "paper, Table 3 (Y-net K_e = 20)", "")
               for x, y in paper_ka_points(paper)]
    h_slot, k_slot = slot("horizon_ade.png"), slot("ka_ade.png")
    h_drawn = plot_series(h_series, h_paper, "prediction horizon t_f (s)", h_slot.path, colours)
    k_drawn = plot_series(k_series, k_paper, "K_a (paths per goal)", k_slot.path, colours)
    sections = {
        "figures_note": paper.get("figures", {}),
        "horizon": {"series": h_series, "horizons": horizons, "src": h_slot.src if h_drawn else None},
        "ka": {"series": k_series, "src": k_slot.src if k_drawn else None},
        "qualitative": gallery["qualitative"],
    }
    plots = {"horizon_ade.json": plot_rows(h_series, "t_f"), "ka_ade.json": plot_rows(k_series, "k_a")}
    return sections, plots


def gallery_index(folder: Path, html_dir: Path) -> dict[str, Any]:
    """Stage `report_figures`' index, each file as an <img> src relative to the page (the figures
    stay in the stage's folder): {"qualitative": {src, absent, problems}, "segmentation": {absent,
    kinds, rows: [{video, images: [src | None]}], other: [src]}}."""
    index = read_json(folder / "index.json")
    if isinstance(index, Absent):
        reason = f"{index.reason} (stage report_figures draws it)"
        return {"qualitative": {"src": None, "absent": reason, "problems": []},
                "segmentation": {"absent": reason, "kinds": [], "rows": [], "other": []}}

    def src(name: str | None) -> str | None:
        return rel_src(folder / name, html_dir) if name else None

    figure, segmentation = index["qualitative"], index["segmentation"]
    return {"qualitative": {"src": src(figure["file"]), "absent": figure["absent"],
                            "problems": figure["problems"]},
            "segmentation": {**segmentation,
                             "rows": [{**row, "images": [src(name) for name in row["images"]]}
                                      for row in segmentation["rows"]],
                             "other": [src(name) for name in segmentation["other"]]}}


def animation_section(folder: Path | None, html_dir: Path) -> dict[str, Any]:
    """Stage `animations`' benchmarks as its index.json lists them, each window's <img> src
    relative to the page (the animations stay in the stage's folder, beside the page's)."""
    if folder is None:
        return {"absent": Absent("no --animations folder given"), "benchmarks": []}
    index = read_json(folder / "index.json")
    if isinstance(index, Absent):
        return {"absent": index, "benchmarks": []}
    try:
        benchmarks = [{**entry, "windows": [
            {**w, "src": rel_src(folder / w["file"], html_dir), "found": (folder / w["file"]).is_file()}
            for w in entry["windows"]]} for entry in index["benchmarks"]]
    except (KeyError, TypeError) as e:
        return {"absent": Absent(f"{(folder / 'index.json').as_posix()}: not the animations index "
                                 f"({type(e).__name__}: {e})", "invalid"), "benchmarks": []}
    return {"absent": None, "benchmarks": benchmarks}


def horizon_analysis_section(store: MetricsStore, folder: Path | None, html_dir: Path,
                             labels: Mapping[str, str]) -> dict[str, Any]:
    """Stage `horizon_analysis`' record as `pipeline.report.horizons.section` reads it, its
    figures' <img> src relative to the page (they stay in the stage's folder)."""
    record = store.record("horizon_analysis.json")
    if isinstance(record, Absent):
        return {"absent": record}
    content = horizons.section(record)
    figures = [{"src": rel_src(folder / name, html_dir), "found": (folder / name).is_file()}
               for name in content["figures"]] if folder is not None else []
    return {"absent": None, "source": store.where("horizon_analysis.json"), **content,
            "figures": figures, "labels": dict(labels)}


def data_section(store: MetricsStore, scene_counts: Path) -> dict[str, Any]:
    """The audit, window counts, chain bias and per-video counts, as the data stages wrote them."""
    windows, horizon_windows = store.record("windows.json"), store.record("horizon_windows.json")
    per_scene = read_json(scene_counts)
    scene_columns, scene_rows = scene_count_rows(per_scene)
    return {"audit": store.record("data_audit.json"), "windows": windows,
            "horizon_windows": horizon_windows, "counts": window_count_rows(windows, horizon_windows),
            "chain_bias": store.record("chain_bias.json"),
            "chain_rows": chain_bias_rows(store.record("chain_bias.json")),
            "scene_columns": scene_columns, "scene_rows": scene_rows,
            "scene_absent": per_scene if isinstance(per_scene, Absent) else None}


def provenance_section(inputs: Inputs, lock: Mapping[str, Any] | Absent, params: Mapping[str, Any],
                       store: MetricsStore) -> dict[str, Any]:
    params_text = (yaml.safe_dump(params, sort_keys=True, default_flow_style=None, width=100)
                   if params else "(dvc.lock records no params yet)")
    outputs = [*lock_outputs(lock), *inputs.own_outputs]
    return {"git": git_state(inputs.repo, outputs), "params_text": params_text,
            "profiles": profiles(params, store), "manifests": manifest_checksums(inputs.manifests),
            "raw_hashes": raw_data_hashes(lock), "machine": machine(),
            "sdd_sources": sdd_sources(store, (params.get("split") or {}).get("val_videos") or []),
            "timings": stage_timings(store), "stage_profile": stage_profile(inputs.stage_times),
            "metrics_files": sorted(store.where(rel) for rel in store.files)}


def build_context(inputs: Inputs, lock: Mapping[str, Any] | Absent, report_params: ReportParams,
                  figures_dir: Path, final_figures_dir: Path, html_dir: Path,
                  registered: Mapping[str, ModelEntry] | None = None) -> tuple[dict, dict, dict]:
    """Everything the template shows, the dvc plots series and the headline metrics files; figures
    drawn into `figures_dir`. `lock`: dvc.lock as `read_lock` gives it (the params the stages ran
    with, the outputs, the raw data's hashes); `registered`: params.yaml `models`, shown in Table
    3, Figure 4 and "Beyond the paper's tables" beside the paper's models.

    `final_figures_dir` is where those figures will be after the rename (for the <img> paths).
    """
    registered = registered or {}
    paper = load_paper_values(inputs.paper)
    params = lock_params(lock)
    store = load_metrics(inputs.metrics, inputs.metrics.as_posix())
    studies = load_metrics(inputs.short_term_seeds) if inputs.short_term_seeds else None
    seeds = (short_term_seeds(store, studies, (params.get("train_baseline") or {}).get("seed", 0))
             if studies else None)
    curves = budget_runs(load_metrics(inputs.budget)) if inputs.budget else {}
    tables = build_tables(paper, store, report_params, params.get("profile"), registered, seeds,
                          curves)
    horizons = (params.get("windows") or {}).get("horizons") or []

    def slot(name: str) -> FigureSlot:
        return FigureSlot(figures_dir / name, rel_src(final_figures_dir / name, html_dir))

    gallery = gallery_index(inputs.gallery, html_dir)
    figures, plots = figure_sections(paper, store, horizons, gallery, slot, registered)
    context = {
        "generated": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "bands": report_params,
        "protocol_labels": PROTOCOL_LABELS, "protocol_lines": PROTOCOLS,
        "protocol_keys": PROTOCOL_KEYS,
        "summaries": [summarize(t) for t in tables],
        "claims": claims_section(store, paper, seeds),
        "tables": tables,
        "diagnostics": diagnostics_section(store, paper, table_models(registered)),
        **figures,
        "beyond": beyond_section(store, LONG_TERM_TF, horizon_models(registered),
                                 model_colours(registered), slot),
        "seed_spread": seed_spread_section(store),
        "short_term_seeds": seed_rows(seeds) if seeds else [],
        "budget": budget_section(curves, paper, store, slot),
        "horizon_analysis": horizon_analysis_section(store, inputs.horizon_figures, html_dir,
                                                     dict(table_models(registered))),
        "animations": animation_section(inputs.animations, html_dir),
        "data": data_section(store, inputs.scene_counts),
        "n_test_videos": len(TEST_VIDEOS),
        "segmentation": {**segmentation_scores(store),
                         "gallery": gallery["segmentation"]},
        "provenance": provenance_section(inputs, lock, params, store),
    }
    return context, plots, headline_metrics(tables, figures["horizon"]["series"])


def read_json(path: Path) -> Any:
    if not path.exists():
        return Absent(f"stage not yet run: {path.as_posix()} missing")
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as e:
        return Absent(f"{path.as_posix()} unreadable: {e}", "invalid")


def read_text(path: Path) -> str:
    try:
        return path.read_text()
    except OSError as e:
        return f"(unreadable: {e})"


def write_report(inputs: Inputs, lock: Mapping[str, Any] | Absent, report_params: ReportParams,
                 out: Path, figures: Path, plots: Path, headline: Path,
                 template: Path = TEMPLATE,
                 registered: Mapping[str, ModelEntry] | None = None) -> None:
    """Render everything into temporary places, then rename figures, plots, headline metrics and
    the page (folders 0755 and the page 0644, readable by other users)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    with (atomic_dir(figures, mode=0o755) as staged_figures, atomic_dir(plots, mode=0o755) as staged_plots,
          atomic_dir(headline, mode=0o755) as staged_headline):
        context, series, numbers = build_context(inputs, lock, report_params, staged_figures, figures,
                                                 out.parent, registered)
        html = render_html(context, template)
        for name, rows in series.items():
            (staged_plots / name).write_text(json.dumps(rows, indent=1) + "\n")
        for name, values in numbers.items():
            (staged_headline / name).parent.mkdir(parents=True, exist_ok=True)
            (staged_headline / name).write_text(json.dumps(values, indent=2, sort_keys=True) + "\n")
    write_text(out, html, mode=0o644)
