"""The report stage: every table cell is measured, quoted from the paper or explained; the page
parses, opens from the file system, and its figures load in a real browser.

Fixtures are metrics files in the contracts' formats (see `pipeline.report.page`'s docstring), written
here; the Chromium test needs Debian's `chromium` (`tests/setup_chromium.sh`): without it the test
skips locally and fails in CI.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.report.figures import load_qualitative
from pipeline.report.lookups import Absent, Measured, load_metrics, lookup
from pipeline.report.page import animation_section
from pipeline.report.run_provenance import (git_state, is_output, lock_outputs, porcelain_paths,
                                            read_lock)
from pipeline.report.tables import (Cell, Column, Row, Table, build_tables, compare,
                                    find_long_term, headline_metrics, summarize)
from pipeline.stages import animations as animations_stage
from pipeline.stages import report as report_stage
from pipeline.stages import report_figures as report_figures_stage
from pipeline.config.loading import ParamsError, from_dict
from pipeline.config.report import ReportParams

REPO = Path(__file__).resolve().parents[1]
PAPER = REPO / "pipeline" / "report" / "paper_values.yaml"
PAPER_TEX = REPO.parent / "shared" / "paper" / "ynet-paper.tex"
BANDS = ReportParams(close=0.05, far=0.20)
HORIZONS = [5, 10, 15, 20, 30, 40, 50, 60]
ETHUCY_SCENES = ["eth", "hotel", "univ", "zara1", "zara2"]


# ---------------------------------------------------------------------------------------------
# Fixtures in the contracts' formats


def stat(mean: float, std: float) -> dict:
    return {"mean": mean, "std": std}


def four(ade: float, fde: float) -> dict:
    return {"ade": stat(ade, 0.4), "fde": stat(fde, 0.9), "ade_joint": stat(ade + 2.5, 0.5),
            "fde_joint": stat(fde + 4.5, 1.0)}


def baseline(model: str, t_f: int, ade: float) -> dict:
    return {"model": model, "t_f": t_f, "k": 20, "n_windows": 300, "rounds": 3,
            "ade": stat(ade, 0.7), "fde": stat(2.1 * ade, 1.3), "ade_joint": stat(ade + 1.25, 0.7),
            "fde_joint": stat(2.1 * ade + 3.5, 1.5), "train_seconds": 61.0 * t_f}


def data_metrics() -> dict[str, object]:
    """What the data stages write (small but in their formats)."""
    return {
        "windows.json": {"release": {"tf30": {"train": 964, "val": 156, "test": 382}},
                         "raw": {f"tf{h}": {"train": 100 - h, "val": 10, "test": 50 - h // 2,
                                            "outside_split": 7} for h in HORIZONS}},
        "data_audit.json": {"t_f": 30, "compat_drop_first_row": False,
                            "totals": {"ours": 14, "release": 14, "exact_matches": 13},
                            "videos": {"gates_2": {"ours": 10, "release": 10, "exact_matches": 10},
                                       "little_0": {"ours": 4, "release": 4, "exact_matches": 3,
                                                    "mismatches": ["track 7: frames differ"]}}},
        "horizon_windows.json": {"chain_pieces": 1122,
                                 **{f"tf{h}": {s: {"raw": 9, "release_chain": 400 - h}
                                               for s in ("train", "val", "test")} for h in HORIZONS}},
        "chain_bias.json": {
            f"tf{h}": {"raw": {"windows": 700 - 10 * h, "cv_ade": 3.5 * h, "cv_fde": 7.25 * h},
                       "release_chain": {"windows": 190 - h, "cv_ade": 3.0 * h, "cv_fde": 6.5 * h},
                       "kept_fraction": 0.25} for h in HORIZONS},
        "sdd_sources.json": sdd_sources({"gates_2": "fetched", "nexus_10": "fetched"}),
    }


def sdd_sources(origins: dict[str, str], images: dict[str, dict] | None = None,
                path: str = "") -> dict:
    """Stage tracks' record: the given videos, pinned unless fingerprinted from the copy."""
    videos = {video: {"origin": origin, "file": f"annotations/{video.replace('_', '/video')}/annotations.txt",
                      "sha256": hashlib.sha256(video.encode()).hexdigest(),
                      "pinned": origin != "your copy (fingerprinted)", "rows": 1000}
              for video, origin in origins.items()}
    return {"copy": {"provided": bool(path), "path": path}, "videos": videos,
            "reference_images": images or {}, "totals": {"videos": len(videos)}}


BEYOND_MODELS = ("pecnet", "rpecnet", "sgan", "constant_velocity")  # on every horizon table


def beyond_model(model: str, ade: float, rounds: int = 3) -> dict:
    """One model's record in stage score_predictions' layout (pipeline.harness.stored_scores)."""
    values = {"ade": ade, "fde": 2 * ade, "ade_joint": ade, "fde_joint": 2 * ade + 8.5,
              "ade_best_endpoint": ade + 4.25, "miss_rate": 0.375, "kde_nll": 11.5 + ade / 100,
              "kde_degenerate_share": 0.0, "off_limits_share": 0.1875, "collision_rate": 0.0125}
    std = 0.5 if rounds > 1 else 0.0
    return {"file": f"data/predictions/long_term/x/{model}.parquet", "model": model,
            "rounds": rounds, "k": 20, "t": 30, "n_windows": 382, "n_scenes": 11,
            "metrics": {k: {"mean": v, "std": std, "per_round": [v] * rounds}
                        for k, v in values.items()},
            "ground_truth": {"off_limits_share": 0.125, "collision_rate": 0.0,
                             "copresent_share": 0.5}}


def beyond_metrics() -> dict:
    """metrics/beyond/long_term.json: the baselines on every horizon table, Y-net at 10 s (one
    round), not run at the other horizons (none at 30 s: its main setting is the release's)."""
    tables = {}
    for h in HORIZONS:
        models = {m: beyond_model(m, (2.25 + j) * h) for j, m in enumerate(BEYOND_MODELS)}
        if h == 10:
            models["ynet"] = beyond_model("ynet", 1.75 * h, rounds=1)
        elif h != 30:
            models["ynet"] = {"file": f"data/predictions/long_term/tf{h}/ynet.parquet",
                              "model": "ynet",
                              "not_run_reason": f"Y-net is not trained at t_f = {h} s here"}
        tables[f"tf{h}"] = {"window_table": f"data/horizon_windows/tf{h}.parquet", "t_f": h,
                            "models": models}
    tables["release_tf30"] = {"window_table": "data/windows/release_tf30.parquet", "t_f": 30,
                              "models": {"ynet": beyond_model("ynet", 50.5)}}
    return {"unit": "px", "tables": tables, "score_seconds": 6.5,
            "thresholds": {"miss_threshold_m": 2.0, "collision_threshold_m": 0.2,
                           "log_pdf_floor": -20.0, "forbidden_classes": ["structure", "tree"]}}


IND_REASON = "inD is licence-restricted and not redistributed"


def short_term_beyond_metrics() -> dict:
    """metrics/beyond/short_term.json: S-GAN and PECNet on SDD (px) and on eth (m), Y-net on SDD
    only (not run on eth)."""
    def entry(name: str, unit: str, models: dict) -> dict:
        return {"benchmark": f"short_term_{name}", "unit": unit, "split": "test",
                "n_windows": 2829 if unit == "px" else 181, "n_future": 12,
                "scene_masks": {"source": "hand labels data/labels" if unit == "px" else "road maps",
                                "forbidden_classes": ["structure", "tree"] if unit == "px"
                                else ["not_road"], "scenes_with_mask": ["coupa_0"],
                                "scenes_without_mask": [], "windows_with_mask": 2829 if unit == "px"
                                else 181, "n_windows": 2829 if unit == "px" else 181},
                "models": models}
    sdd = {m: beyond_model(m, ade) for m, ade in (("ynet", 12.75), ("sgan", 13.375),
                                                    ("pecnet", 14.5))}
    eth = {"ynet": {"file": "data/predictions/short_term/eth/ynet.parquet", "model": "ynet",
                    "not_run_reason": "Y-net is not trained on eth in the cpu profile"},
           "sgan": beyond_model("sgan", 0.8125), "pecnet": beyond_model("pecnet", 0.625)}
    return {"thresholds": {"miss_threshold_m": 2.0, "collision_threshold_m": 0.2,
                           "log_pdf_floor": -20.0, "forbidden_classes": ["structure", "tree"]},
            "benchmarks": {"sdd": entry("sdd_trajnet", "px", sdd), "eth": entry("ethucy_eth", "m", eth)},
            "score_seconds": 3.5}


def ind_beyond_metrics() -> dict:
    """metrics/beyond/ind.json without inD: every file gives the reason."""
    return {"thresholds": {}, "score_seconds": 0.01, "benchmarks": {"ind": {
        "benchmark": "ind_long_term", "unit": "px", "split": "test",
        "models": {m: {"file": f"data/predictions/ind/{m}.parquet", "model": m,
                       "not_run_reason": IND_REASON} for m in ("ynet", "sgan", "pecnet")}}}}


def model_metrics() -> dict[str, object]:
    """What the training / evaluation stages will write."""
    files: dict[str, object] = {
        "beyond/long_term.json": beyond_metrics(),
        "beyond/short_term.json": short_term_beyond_metrics(),
        "beyond/ind.json": ind_beyond_metrics(),
        "ynet_eval.json": {
            "profile": "cpu", "t_f": 30, "n_windows": 382, "rounds": 3,
            "main": four(49.5, 70.25),
            "ablation": {"none": four(66.5, 88.0), "cws": four(53.75, 88.0), "ttst_cws": four(49.5, 70.25)},
            "ka_grid": [{"k_e": k_e, "k_a": k_a, "ade": stat(60.0 - k_e / 2 - k_a, 0.3),
                         "fde": stat(80.0 - k_e / 2, 0.6)} for k_e in (5, 20) for k_a in (1, 2, 5)],
            "eval_seconds": 1500.0, "train_seconds": 36000.0},
        "baselines/pecnet_ka.json": [{"k_a": k_a, "k": 20 * k_a, "ade": stat(75.5 - k_a, 0.2),
                                      "fde": stat(120.25, 0.5)}
                                     for k_a in (1, 2, 5)],
        "segmentation.json": {"miou": 0.6125, "iou": {"pavement": 0.75, "road": 0.5,
                                                                 "structure": 0.625, "terrain": 0.4375,
                                                                 "tree": 0.8125},
                              "train_seconds": 4200.0},
        "ind_benchmark.json": {"status": "not provided", "reason": "inD not provided: set data.ind.path"},
        "short_term/sdd.json": {"rounds": 3, "models": {"ynet": {
            "k20": {"ade": stat(8.25, 0.05), "fde": stat(12.5, 0.1)},
            "k5": {"ade": stat(11.75, 0.1), "fde": stat(21.0, 0.2)}}}},
    }
    for i, scene in enumerate(ETHUCY_SCENES):
        files[f"short_term/ethucy_{scene}.json"] = {"rounds": 3, "models": {"ynet": {
            "ade": stat(0.125 + 0.0625 * i, 0.005), "fde": stat(0.25 + 0.0625 * i, 0.01)}}}
    files["baseline_seed_spread.json"] = seed_spread_record()
    for h in HORIZONS:
        if h != 30:  # the t_f = 30 point is the main Y-net's (ynet_eval.json)
            files[f"ynet_horizons/tf{h}.json"] = {"t_f": h, "rounds": 3, "main": four(1.5 * h + 3, 3.0 * h)}
        for j, model in enumerate(("constant_velocity", "sgan", "pecnet", "rpecnet")):
            files[f"baselines/{model}_tf{h}.json"] = baseline(model, h, (2.0 + j) * h)
    return files


def seed_spread_record() -> dict:
    """Stage baseline_seed_spread's file: PECNet at 50 s over seeds 0, 1, 2 and S-GAN at 5 s with
    one seed (no spread)."""
    def per_seed(seed, ade, fde, epoch):
        return {"seed": seed, "ade": ade, "fde": fde, "ade_joint": ade, "fde_joint": fde + 1.0,
                "round_std": {"ade": 1.75, "fde": 3.25}, "best_epoch": epoch,
                "best_val_ade": 100.0 + epoch, "trained_epochs": 40, "trained_horizon": 50}
    evaluation = {"split": "test", "k": 20, "rounds": 3, "seed": 0, "n_windows": 66}
    pecnet = [per_seed(0, 190.25, 358.5, 23), per_seed(1, 142.5, 270.0, 31), per_seed(2, 160.0, 301.0, 9)]
    return {"models": ["sgan", "pecnet", "rpecnet"], "horizons": [5, 50], "extra_seeds": [1, 2], "entries": [
        {"model": "pecnet", "horizon": 50, "seeds": [0, 1, 2], "main_seed": 0, "evaluation": evaluation,
         "over_training_seeds": {"ade": stat(164.25, 19.75), "fde": stat(309.875, 36.25)},
         "main_round_std": {"ade": 1.75, "fde": 3.25}, "per_seed": pecnet},
        {"model": "sgan", "horizon": 5, "seeds": [0], "main_seed": 0, "evaluation": evaluation,
         "over_training_seeds": {"ade": stat(11.25, 0.0), "fde": stat(20.5, 0.0)},
         "main_round_std": {"ade": 0.0625, "fde": 0.125}, "per_seed": [per_seed(0, 11.25, 20.5, 30)]}]}


def write_metrics(folder: Path, files: dict[str, object], skip: tuple[str, ...] = ()) -> None:
    for rel, content in files.items():
        if rel in skip:
            continue
        path = folder / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(content))


def write_qualitative(path: Path, n: int = 3) -> None:
    """`n` windows as the Y-net evaluation stores them: a smooth scene, a heatmap blob per goal,
    20 straight predicted paths to those goals (smooth, so the animations encode in a blink)."""
    rng = np.random.default_rng(0)
    arrays = {}
    h, w = 120, 160
    rows, cols = np.mgrid[0:h, 0:w]
    for i in range(n):
        goals = rng.random((20, 2)) * [w, h]
        heatmap = sum(np.exp(-((cols - x) ** 2 + (rows - y) ** 2) / 50.0) for x, y in goals)
        past = np.stack([np.linspace(10, 40, 5), np.linspace(20, 30, 5)], 1)
        arrays[f"scene_image_{i}"] = np.stack([rows * 2, cols, np.full_like(rows, 90 + 40 * i)],
                                              -1).astype(np.uint8)
        arrays[f"past_{i}"] = past
        arrays[f"future_{i}"] = np.stack([np.linspace(45, 140, 30), np.linspace(30, 90, 30)], 1)
        arrays[f"goal_heatmap_{i}"] = heatmap
        arrays[f"sampled_goals_{i}"] = goals
        arrays[f"trajectory_heatmap_{i}"] = heatmap
        steps = np.linspace(1 / 30, 1, 30)[None, :, None]  # (1, 30, 1)
        arrays[f"predictions_{i}"] = past[-1] + steps * (goals[:, None] - past[-1])  # (20, 30, 2)
    arrays["scene_id_0"] = np.array("gates_2 window 3")
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, **arrays)


def write_png(path: Path, colour: tuple[int, int, int]) -> None:
    from PIL import Image
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.new("RGB", (64, 48), colour).save(path)


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """A working folder with every input of the report stage (metrics written by each test)."""
    return write_project(tmp_path)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory) -> Path:
    """One full project, rendered once for the tests that only read what the report wrote (a
    page each took them a second and a half)."""
    root = write_project(tmp_path_factory.mktemp("full_project"))
    full_project(root)
    return root


def write_project(root: Path) -> Path:
    """Every input of the report stage under `root` but the metrics."""
    (root / "metrics").mkdir()
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params["report"] = {"close": 0.05, "far": 0.20}
    (root / "params.yaml").write_text(yaml.safe_dump(params))
    (root / "manifests").mkdir()
    (root / "manifests" / "sdd.sha256").write_text("ab" * 32 + "  annotations/x.txt\n")
    (root / "dvc.lock").write_text(yaml.safe_dump({"schema": "2.0", "stages": {
        "fetch@sdd": {"outs": [{"path": "data/raw/sdd", "md5": "0e5e7977cdd07682f5a28f53a640c3ba.dir",
                                "nfiles": 86}]},
        "windows": {"params": {"params.yaml": {"windows": params["windows"]}}},
        "train_ynet": {"params": {"params.yaml": {"profile": "cpu", "ynet.cpu": params["ynet"]["cpu"]}}}}}))
    (root / "reports" / "data").mkdir(parents=True)
    (root / "reports" / "data" / "windows_per_scene.json").write_text(json.dumps(
        {"raw": {"tf30": {"test": {"gates_2": 10}, "train": {"gates_4": 4}}},
         "release": {"tf30": {"test": {"coupa_0": 47}}}}))
    return root


def run_report(root: Path) -> Path:
    """`python -m pipeline.stages.report` on `root`'s inputs; returns the page's path."""
    out = root / "reports" / "index.html"
    report_stage.main([
        "--metrics", str(root / "metrics"), "--paper", str(PAPER), "--params", str(root / "params.yaml"),
        "--scene-counts", str(root / "reports/data/windows_per_scene.json"),
        "--gallery", str(root / "reports/figures/gallery"),
        "--short-term-seeds", str(root / "studies/short_term_seeds"),
        "--budget", str(root / "studies/budget"),
        "--manifests", str(root / "manifests"), "--dvc-lock", str(root / "dvc.lock"),
        "--animations", str(root / "reports/figures/animations"),
        "--horizon-figures", str(root / "reports/figures/horizons"),
        "--out", str(out), "--figures", str(root / "reports/figures/report"),
        "--plots", str(root / "reports/plots"), "--headline", str(root / "reports/headline")])
    return out


def run_animations(root: Path) -> None:
    """Stage `animations` on a one-window long-term file (each window takes about a second) and a
    short-term one not yet written."""
    write_qualitative(root / "data/animated.npz", n=1)
    animations_stage.main([
        "--qualitative", f"long_term={root / 'data/animated.npz'}",
        "--qualitative", f"short_term_sdd={root / 'data/predictions/short_term/sdd/ynet_qualitative.npz'}",
        "--out", str(root / "reports/figures/animations")])


def run_report_figures(root: Path) -> None:
    """Stage `report_figures` on `root`'s qualitative arrays and segmentation figures."""
    report_figures_stage.main([
        "--qualitative", str(root / "data/ynet_predictions/qualitative.npz"),
        "--segmentation-figures", str(root / "reports/figures/segmentation"),
        "--out", str(root / "reports/figures/gallery")])


GALLERY: dict[str, bytes] = {}  # what stage report_figures drew in the first full project


def full_project(root: Path, animations: bool = False) -> Path:
    """Every input of the report; with `animations`, stage animations' output too. Stage
    report_figures runs in the first full project only: its inputs are the same in every one, so
    the others get a copy of what it drew (a second each, as the report's tests render a dozen)."""
    write_metrics(root / "metrics", data_metrics() | model_metrics())
    write_qualitative(root / "data/ynet_predictions/qualitative.npz")
    for video in ("coupa_0", "gates_2", "quad_3"):
        write_png(root / f"reports/figures/segmentation/labels/{video}.png", (200, 160, 40))
        write_png(root / f"reports/figures/segmentation/predictions/{video}.png", (60, 160, 40))
    gallery = root / "reports/figures/gallery"
    if not GALLERY:
        run_report_figures(root)
        GALLERY.update((p.relative_to(gallery).as_posix(), p.read_bytes())
                       for p in gallery.rglob("*") if p.is_file())
    for rel, content in GALLERY.items():
        (gallery / rel).parent.mkdir(parents=True, exist_ok=True)
        (gallery / rel).write_bytes(content)
    if animations:
        run_animations(root)
    return run_report(root)


# ---------------------------------------------------------------------------------------------
# HTML inspection


class Cells(HTMLParser):
    """Every <td> (attributes, text, whether it holds an image) and every <img src>."""

    def __init__(self):
        super().__init__()
        self.cells: list[dict] = []
        self.images: list[str] = []
        self.spans: list[tuple[str, str]] = []  # (class, text) of value spans
        self._td: dict | None = None
        self._span: str | None = None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "td":
            self._td = {"attrs": attrs, "text": "", "img": False}
        elif tag == "img":
            self.images.append(attrs.get("src", ""))
            if self._td is not None:
                self._td["img"] = True
        elif tag in ("span", "b") and attrs.get("class") in ("ours-value", "paper-value"):
            self._span = attrs["class"]
            self.spans.append((self._span, ""))

    def handle_endtag(self, tag):
        if tag == "td" and self._td is not None:
            self.cells.append(self._td)
            self._td = None
        elif tag in ("span", "b"):
            self._span = None

    def handle_data(self, data):
        if self._td is not None:
            self._td["text"] += data
        if self._span is not None:
            cls, text = self.spans[-1]
            self.spans[-1] = (cls, text + data)


def parse(html: str) -> Cells:
    parser = Cells()
    parser.feed(html)
    parser.close()
    return parser


class Nesting(HTMLParser):
    """Fails on an end tag that does not close the innermost open element (html.parser itself
    accepts anything, so this is what makes "the page parses" mean something)."""

    VOID = {"meta", "img", "br", "hr", "input", "link", "source", "wbr"}

    def __init__(self):
        super().__init__()
        self.stack: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        pass

    def handle_endtag(self, tag):
        assert self.stack and self.stack[-1] == tag, \
            f"</{tag}> closes <{self.stack[-1:]}> at {self.getpos()}"
        self.stack.pop()


def assert_well_formed(html: str) -> None:
    checker = Nesting()
    checker.feed(html)
    checker.close()
    assert checker.stack == [], f"unclosed: {checker.stack}"
    assert html.lstrip().lower().startswith("<!doctype html>")
    assert "<script" not in html.lower(), "the page needs no JavaScript"
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", html), "the page must load nothing remote"


def comparison_cells(page: Cells) -> list[dict]:
    return [c for c in page.cells if "data-kind" in c["attrs"]]


def numeric_leaves(node) -> list[float]:
    if isinstance(node, dict):
        return [x for v in node.values() for x in numeric_leaves(v)]
    if isinstance(node, list):
        return [x for v in node for x in numeric_leaves(v)]
    if isinstance(node, int | float) and not isinstance(node, bool):
        return [float(node)]
    return []


def formatted(values, decimals=(1, 2, 3)) -> set[str]:
    return {f"{v:,.{d}f}" for v in values for d in decimals}


# ---------------------------------------------------------------------------------------------
# Tests


def test_paper_values_have_the_four_tables_in_the_papers_numbering():
    paper = yaml.safe_load(PAPER.read_text())
    assert [paper[k]["number"] for k in ("sdd_short", "eth_ucy", "sdd_long", "ttst")] == [1, 2, 3, 4]
    for key in ("sdd_short", "sdd_long", "ttst"):
        for column in paper[key]["columns"]:
            assert all(isinstance(column[m], float) for m in ("ade", "fde")), column
    for model in paper["eth_ucy"]["models"]:
        assert set(model["ade"]) == set(model["fde"]) == {*ETHUCY_SCENES, "avg"}


@pytest.mark.skipif(not PAPER_TEX.exists(), reason=f"{PAPER_TEX} not on this machine")
def test_every_paper_value_is_printed_in_the_paper():
    """Transcription check: each quoted number occurs in the paper's source as printed."""
    tex = PAPER_TEX.read_text()
    paper = yaml.safe_load(PAPER.read_text())
    values = numeric_leaves([paper[k] for k in ("sdd_short", "eth_ucy", "sdd_long", "ttst")])
    values = [v for v in values if v not in (1.0, 2.0, 3.0, 4.0, 5.0, 20.0)]  # numbers, K, K_a
    missing = [v for v in values if f"{v:.2f}" not in tex]
    assert not missing


@pytest.mark.parametrize("ours, expected_band", [(104.0, "close"), (96.0, "close"), (110.0, "mid"),
                                                 (81.0, "mid"), (130.0, "far"), (60.0, "far")])
def test_relative_difference_bands(ours, expected_band):
    cell = compare(100.0, Measured(ours, 1.0, 3, "x"), BANDS)
    assert cell.kind == "measured"
    assert cell.band == expected_band
    assert math.isclose(cell.diff, (ours - 100.0) / 100.0)


def test_report_params_are_typed():
    assert from_dict(ReportParams, {"close": 0.05, "far": 0.2}, "report") == BANDS
    with pytest.raises(ParamsError, match="unknown key"):
        from_dict(ReportParams, {"close": 0.05, "far": 0.2, "clsoe": 1}, "report")
    with pytest.raises(ParamsError, match="close < far"):
        from_dict(ReportParams, {"close": 0.3, "far": 0.2}, "report")


def test_every_cell_is_measured_quoted_or_explained(rendered):
    html = (rendered / "reports/index.html").read_text()
    assert_well_formed(html)
    page = parse(html)
    cells = comparison_cells(page)
    paper = yaml.safe_load(PAPER.read_text())
    n_paper = (sum(2 * len(paper[k]["columns"]) for k in ("sdd_short", "sdd_long", "ttst"))
               + 2 * len(paper["eth_ucy"]["models"]) * (len(ETHUCY_SCENES) + 1))
    registered = yaml.safe_load((rendered / "params.yaml").read_text())["models"]
    assert len(cells) == n_paper + 2 * len(registered)  # Table 3: ADE, FDE of each registered model
    for cell in cells:
        text = " ".join(cell["text"].split())
        kind = cell["attrs"]["data-kind"]
        assert kind in ("measured", "paper-only", "absent", "ours-only"), cell
        assert text.startswith("paper "), text
        if kind == "measured":
            assert "ours" in text and re.search(r"[+-]\d+\.\d %", text), text
        elif kind == "ours-only":  # a registered model: the paper has no value, so no difference
            assert text.startswith("paper \u2014 ours ") and "not in the paper" in text, text
            assert not re.search(r"[+-]\d+\.\d %", text), text
        elif kind == "absent":
            assert re.search(r"[a-z]{4,}", text.split(" ", 2)[2]), text  # words, not a number
        else:
            assert "paper only" in text
        assert not re.search(r"\b(nan|None|inf)\b", text), text
    kinds = {c["attrs"]["data-kind"] for c in cells}
    assert kinds == {"measured", "paper-only", "absent", "ours-only"}  # inD status record: absent
    assert all(c["text"].strip() or c["img"] for c in page.cells), "a blank table cell"


def test_no_number_is_invented(rendered):
    """Every 'ours' number is a value of a metrics file (or Table 2's average of them); every
    'paper' number is in paper_values.yaml."""
    page = parse((rendered / "reports/index.html").read_text())
    metrics = data_metrics() | model_metrics()
    allowed = formatted(numeric_leaves(metrics))
    for metric in ("ade", "fde"):
        scenes = [metrics[f"short_term/ethucy_{s}.json"]["models"]["ynet"][metric]["mean"]
                  for s in ETHUCY_SCENES]
        allowed |= formatted([float(np.mean(scenes))])
    quoted = formatted(numeric_leaves(yaml.safe_load(PAPER.read_text())), decimals=(2,))
    spans = page.spans
    assert any(cls == "ours-value" for cls, _ in spans)
    for cls, text in spans:
        assert text.strip() in (allowed if cls == "ours-value" else quoted), (cls, text)


def test_a_missing_metrics_file_is_explained(project):
    write_metrics(project / "metrics", data_metrics() | model_metrics(), skip=("ynet_eval.json",))
    html = run_report(project).read_text()
    reason = f"stage not yet run: {project / 'metrics'}/ynet_eval.json missing"
    assert reason in html
    tables = build_tables(yaml.safe_load(PAPER.read_text()),
                          load_metrics(project / "metrics", "metrics"), BANDS)
    ttst = next(t for t in tables if t.key == "ttst")
    sdd_cells = [row.cells[i] for row in ttst.rows for i, c in enumerate(ttst.columns) if c.group == "SDD"]
    assert {c.ours.reason for c in sdd_cells} == {"stage not yet run: metrics/ynet_eval.json missing"}


def test_a_status_record_shows_its_reason(rendered):
    html = (rendered / "reports/index.html").read_text()
    assert "inD not provided: set data.ind.path" in html
    store = load_metrics(rendered / "metrics", "metrics")
    cell = find_long_term(store, {"dataset": "ind", "model": "pecnet", "k_a": 1}, "ade")
    assert isinstance(cell, Absent) and cell.kind == "status"


def test_a_file_for_another_horizon_is_not_compared(project):
    files = data_metrics() | model_metrics()
    files["baselines/sgan_tf30.json"] = baseline("sgan", 20, 50.0)
    write_metrics(project / "metrics", files)
    store = load_metrics(project / "metrics", "metrics")
    cell = find_long_term(store, {"dataset": "sdd", "model": "sgan", "k_a": 1}, "ade")
    assert isinstance(cell, Absent) and "t_f = 20 s, not 30 s" in cell.reason


def test_only_data_stages_give_a_valid_page(project):
    """`dvc repro report` after the data stages: a page that says what is missing."""
    write_metrics(project / "metrics", data_metrics())
    out = run_report(project)
    html = out.read_text()
    assert_well_formed(html)
    page = parse(html)
    assert {c["attrs"]["data-kind"] for c in comparison_cells(page)} == {"absent", "paper-only"}
    assert "No figure: no model has a measured horizon yet" in html
    assert "gallery/index.json missing (stage report_figures draws it)" in html
    assert "No animations: stage not yet run: " in html and "animations/index.json missing" in html
    assert "segmentation.json missing" in html
    assert "Bias of horizons" in html
    assert json.loads((project / "reports/plots/horizon_ade.json").read_text()) == []
    assert not (project / "reports/figures/report/horizon_ade.png").exists()
    assert all(c["text"].strip() or c["img"] for c in page.cells)


def test_plot_series_hold_only_measured_values(rendered):
    horizon = json.loads((rendered / "reports/plots/horizon_ade.json").read_text())
    assert [row["t_f"] for row in horizon] == HORIZONS
    assert horizon[0]["ynet"] == 1.5 * 5 + 3 and horizon[0]["sgan"] == 3.0 * 5
    ka = json.loads((rendered / "reports/plots/ka_ade.json").read_text())
    assert [row["k_a"] for row in ka] == [1, 2, 5]
    assert ka[1] == {"k_a": 2, "ynet_ke5": 55.5, "ynet_ke20": 48.0, "pecnet_k20ka": 73.5}
    for name in ("horizon_ade.png", "ka_ade.png"):
        assert (rendered / "reports/figures/report" / name).stat().st_size > 1000
    assert (rendered / "reports/figures/gallery/qualitative.png").stat().st_size > 1000


def test_a_broken_qualitative_file_is_reported(project, tmp_path):
    path = tmp_path / "q.npz"
    write_qualitative(path, n=1)
    arrays = dict(np.load(path))
    del arrays["goal_heatmap_0"]
    np.savez(path, **arrays)
    loaded = load_qualitative(path)
    assert isinstance(loaded, Absent) and "missing goal_heatmap" in loaded.reason
    path.write_bytes(b"")  # a file cut short to nothing: explained, not a crash
    loaded = load_qualitative(path)
    assert isinstance(loaded, Absent) and "unreadable" in loaded.reason


def test_animations_are_shown_per_benchmark_and_a_missing_one_says_so(project):
    html = full_project(project, animations=True).read_text()
    assert_well_formed(html)
    sources = [src for src in parse(html).images if src.endswith(".webp")]
    assert sources == ["figures/animations/long_term_0.webp"]
    section = html[html.index('<h2 id="animations">'):html.index('<h2 id="data">')]
    assert "<h3>SDD long-term, 1 s a step</h3>" in section
    assert "gates_2 window 3: 5 observed, 30 predicted steps, K = 20" in section
    assert ("<h3>SDD short-term (TrajNet), 0.4 s a step</h3>\n<p class=\"absent-note\">Not shown: "
            f"{project / 'data/predictions/short_term/sdd/ynet_qualitative.npz'} missing") in section

    folder = project / "reports/figures/animations"
    shown = animation_section(folder, project / "reports")["benchmarks"][0]["windows"]
    assert [(w["src"], w["found"]) for w in shown] == [("figures/animations/long_term_0.webp", True)]
    (folder / "long_term_0.webp").unlink()
    assert "long_term_0.webp missing: re-run stage animations" in run_report(project).read_text()
    (folder / "index.json").write_text('{"benchmarks": [{"windows": 3}]}')
    absent = animation_section(folder, project / "reports")["absent"]
    assert absent.kind == "invalid" and "index.json: not the animations index (TypeError" in absent.reason


# ---------------------------------------------------------------------------------------------
# A real browser

CHECK_SCRIPT = """<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); })
                   .map(function (i) { return i.getAttribute('src'); });
  document.body.setAttribute('data-images', String(imgs.length));
  var loaded = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; })
                   .map(function (i) { return i.getAttribute('src'); });
  document.body.setAttribute('data-loaded', JSON.stringify(loaded));
  document.body.setAttribute('data-broken', JSON.stringify(broken));
});
</script>"""


def in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def chromium() -> str:
    exe = (os.environ.get("CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
           or shutil.which("google-chrome"))
    if exe:
        return exe
    if in_ci():
        pytest.fail("chromium not found in CI: tests/setup_chromium.sh must install it before the tests")
    pytest.skip("chromium not installed (install it with tests/setup_chromium.sh); CI requires it")


def run_chromium(page: Path, *args: str, profile: Path) -> str:
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--hide-scrollbars", "--no-first-run", f"--user-data-dir={profile}",
           "--virtual-time-budget=10000", *args, page.as_uri()]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def image_report(page: Path, profile: Path) -> tuple[int, list[str], list[str]]:
    """(images on the page, those that did not load, those that did), measured by the browser
    after load."""
    check = page.with_name("check.html")
    check.write_text(page.read_text().replace("</body>", CHECK_SCRIPT + "</body>"))
    dom = run_chromium(check, "--dump-dom", profile=profile)
    body = re.search(r"<body([^>]*)>", dom)
    assert body, dom[:500]
    n = re.search(r'data-images="(\d+)"', body.group(1))
    broken, loaded = (re.search(rf"data-{name}=\"([^\"]*)\"", body.group(1)) for name in ("broken", "loaded"))
    assert n and broken and loaded, f"the load check did not run: {body.group(0)[:300]}"
    return (int(n.group(1)), *(json.loads(m.group(1).replace("&quot;", '"')) for m in (broken, loaded)))


def test_page_renders_in_headless_chromium(project, tmp_path):
    from PIL import Image
    page = full_project(project, animations=True)
    profile = tmp_path / "chromium-profile"
    n, broken, loaded = image_report(page, profile)
    assert n >= 3 + 6 + 1 and broken == []  # three report figures, six segmentation figures, an animation
    animated = [src for src in loaded if src.startswith("figures/animations/")]
    assert animated == ["figures/animations/long_term_0.webp"]
    for src in animated:
        assert Image.open(page.parent / src).n_frames > 1

    shot = tmp_path / "shot.png"
    run_chromium(page, f"--screenshot={shot}", "--window-size=1280,2400", profile=profile)
    pixels = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert pixels.shape == (2400, 1280)
    assert pixels.std() > 10 and (pixels < 200).mean() > 0.02, "the screenshot is blank"

    (project / "reports/figures/report/horizon_ade.png").unlink()  # the check must catch this
    n, broken, _ = image_report(page, profile)
    assert broken == ["figures/report/horizon_ade.png"]


def test_segmentation_figures_reach_the_page_as_the_committed_gallery_jpegs(rendered):
    html = (rendered / "reports/index.html").read_text()
    copies = sorted((rendered / "reports/figures/gallery").glob("segmentation_predictions_*.jpg"))
    assert [copy.name for copy in copies] == [f"segmentation_predictions_{video}.jpg"
                                              for video in ("coupa_0", "gates_2", "quad_3")]
    for copy in copies:
        assert copy.read_bytes()[:2] == b"\xff\xd8"  # JPEG magic
        assert f'src="figures/gallery/{copy.name}"' in html
    assert 'src="figures/gallery/qualitative.png"' in html
    assert "figures/segmentation/" not in html  # the page never points at the stage's own output


def test_report_figures_say_why_a_figure_is_missing(tmp_path):
    report_figures_stage.main(["--qualitative", str(tmp_path / "absent.npz"),
                               "--segmentation-figures", str(tmp_path / "absent"),
                               "--out", str(tmp_path / "gallery")])
    index = json.loads((tmp_path / "gallery/index.json").read_text())
    assert index["qualitative"]["file"] is None and "absent.npz missing" in index["qualitative"]["absent"]
    assert "absent missing" in index["segmentation"]["absent"] and index["segmentation"]["rows"] == []
    assert sorted(p.name for p in (tmp_path / "gallery").iterdir()) == ["index.json"]


def test_horizon_figure_takes_30_s_from_the_main_ynet_and_explains_untrained_horizons(project):
    files = data_metrics() | model_metrics()
    files["ynet_horizons/tf40.json"] = {"t_f": 40, "trained": False,
                                        "not_run_reason": "not trained at 40 s in the cpu profile"}
    write_metrics(project / "metrics", files)
    run_report(project)
    horizon = {row["t_f"]: row for row in
               json.loads((project / "reports/plots/horizon_ade.json").read_text())}
    assert horizon[30]["ynet"] == 49.5  # ynet_eval.json main ADE
    assert "ynet" not in horizon[40] or horizon[40]["ynet"] is None
    assert "not trained at 40 s in the cpu profile" in (project / "reports/index.html").read_text()


def test_a_horizon_not_run_by_the_profile_says_not_run_not_invalid(project):
    files = data_metrics() | model_metrics()
    files["ynet_horizons/tf15.json"] = {"t_f": 15, "profile": "cpu", "trained": False,
                                        "not_run_reason": "not trained at 15 s in this profile"}
    write_metrics(project / "metrics", files)
    html = run_report(project).read_text()
    assert 'title="not trained at 15 s in this profile">not run<' in html
    assert ">invalid<" not in html


def test_headline_metrics_hold_our_ade_and_fde_per_table_and_model(rendered):
    headline = rendered / "reports/headline"
    main = json.loads((rendered / "metrics/ynet_eval.json").read_text())["main"]
    ynet = json.loads((headline / "table3_sdd_long/sdd_ynet_ka1.json").read_text())
    assert ynet == {"ade": main["ade"]["mean"], "fde": main["fde"]["mean"]}
    files = sorted(headline.rglob("*.json"))
    assert len(files) > 5
    assert all(set(json.loads(f.read_text())) <= {"ade", "fde"} for f in files)  # two DVC columns
    assert not (headline / "table3_sdd_long/ind_ynet_ka1.json").exists()  # nothing unmeasured
    names = {f.relative_to(headline).as_posix() for f in files}  # model names as the list spells them
    assert not [name for name in names if any(label in name for label in ("s_gan", "y_net", "r_pe"))]
    assert {"table4_ttst/sdd_ynet_none.json", "table4_ttst/sdd_ynet_cws.json",
            "table4_ttst/sdd_ynet_ttst_cws.json"} <= names  # one file per ablation column


def test_two_columns_of_one_headline_file_name_are_refused():
    """Table 4's three ablation columns once shared one file (the last written won): a table whose
    columns would share a headline file, or have none, is an error, not a silent overwrite."""
    def table(*keys: str) -> Table:
        return Table("t", 4, "T", "", "px", 2, tuple(Column("SDD", k, key=k) for k in keys),
                     (Row("ADE", tuple(Cell(1.0, None) for _ in keys)),))  # paper only
    assert headline_metrics([table("sdd_ynet_none", "sdd_ynet_cws")], []) == {}
    for keys in (("sdd_ynet_cws", "sdd_ynet_cws"), ("sdd_ynet_cws", "")):
        with pytest.raises(ValueError, match="each column needs a headline file name of its own"):
            headline_metrics([table(*keys)], [])


def test_page_shows_the_params_dvc_lock_recorded_not_params_yaml(project):
    (project / "params.yaml").write_text((project / "params.yaml").read_text() + "unread_section: 7\n")
    html = full_project(project).read_text()
    assert "unread_section" not in html
    assert "release_horizon" in html  # windows, as the lock's `windows` stage recorded it


def seed_spread_rows(html: str) -> list[str]:
    section = html.split('id="seed-spread"', 1)[1].split("<h2", 1)[0]
    rows = re.findall(r"<tr>(.*?)</tr>", section, flags=re.S)
    return [" ".join(re.sub(r"<[^>]+>", " ", row).split()) for row in rows]


def test_training_seed_spread_table_beside_the_evaluation_round_spread(rendered):
    html = (rendered / "reports/index.html").read_text()
    assert_well_formed(html)
    rows = seed_spread_rows(html.replace("&plusmn;", "±"))
    assert rows[1] == ("over training seeds over evaluation rounds over training seeds over evaluation rounds")
    assert rows[2] == ("PECNet 50 s 164.2 ± 19.8 ± 1.75 309.9 ± 36.2 ± 3.25 "
                       "seed 0: 190.2 / 358.5 (23, 123.0); seed 1: 142.5 / 270.0 (31, 131.0); "
                       "seed 2: 160.0 / 301.0 (9, 109.0)")
    assert rows[3].startswith("S-GAN 5 s 11.2 1 seed, no spread ± 0.06 20.5 1 seed, no spread ± 0.12")
    # which spread each "±" is: said once, and on every comparison cell
    text = " ".join(re.sub(r"<[^>]+>", " ", html.replace("&plusmn;", "±")).split())
    assert ('Which spread a "±" is: in Tables 1-4 and Figures 4-5 it is the standard deviation over '
            "seeded evaluation rounds (sampling one trained model again), never over training") in text
    assert "evaluation (test split, K = 20, 3 rounds from seed 0) are the same" in text
    cells = [" ".join(c["text"].split()) for c in comparison_cells(parse(html))]
    spreads = [c for c in cells if "±" in c]
    assert spreads and all(re.search(r"± \d+\.\d+ over 3 evaluation rounds", c) for c in spreads), spreads


def ynet_spread_entry(not_run: bool) -> dict:
    """Y-net's entry of baseline_seed_spread.json: seeds 0, 1, 2 (paper), or the main seed alone
    with the reason (cpu)."""
    def per_seed(seed, ade, fde, epoch):
        return {"seed": seed, "ade": ade, "fde": fde, "ade_joint": ade, "fde_joint": fde + 1.0,
                "round_std": {"ade": 0.25, "fde": 1.5}, "best_epoch": epoch,
                "best_val_ade": 110.0 + epoch, "trained_epochs": 300, "trained_horizon": 30}
    entry = {"model": "ynet", "horizon": 30, "seeds": [0, 1, 2], "main_seed": 0,
             "evaluation": {"t_f": 30, "n_windows": 382, "rounds": 3, "k_e": 20, "k_a": 1},
             "over_training_seeds": {"ade": stat(52.0, 1.25), "fde": stat(75.5, 2.5)},
             "main_round_std": {"ade": 0.25, "fde": 1.5},
             "per_seed": [per_seed(0, 50.75, 72.25, 28), per_seed(1, 53.5, 77.0, 31),
                          per_seed(2, 51.75, 77.25, 25)]}
    if not not_run:
        return entry
    del entry["over_training_seeds"]
    return {**entry, "seeds": [0], "per_seed": entry["per_seed"][:1],
            "not_run_reason": "Y-net is not trained with extra training seeds in the cpu profile "
                              "(its extra seeds here: none): on 2 CPU cores it takes 30 min"}


@pytest.mark.parametrize("not_run", [False, True])
def test_ynet_row_of_the_training_seed_spread(project, not_run):
    files = data_metrics() | model_metrics()
    spread = files["baseline_seed_spread.json"]
    spread["entries"].insert(0, ynet_spread_entry(not_run))
    spread.update(models=["ynet", *spread["models"]], ynet_extra_seeds=[] if not_run else [1, 2])
    write_metrics(project / "metrics", files)
    html = run_report(project).read_text()
    assert_well_formed(html)
    rows = seed_spread_rows(html.replace("&plusmn;", "±"))
    text = " ".join(re.sub(r"<[^>]+>", " ", html.replace("&plusmn;", "±")).split())
    if not_run:
        assert rows[2] == ("Y-net 30 s not run: Y-net is not trained with extra training seeds in the "
                           "cpu profile (its extra seeds here: none): on 2 CPU cores it takes 30 min "
                           "seed 0: 50.8 / 72.2 (28, 138.0)")
        assert "The main Y-net (t_f = 30 s, the release's windows) likewise: initial weights" in text
    else:
        assert rows[2] == ("Y-net 30 s 52.0 ± 1.2 ± 0.25 75.5 ± 2.5 ± 1.50 "
                           "seed 0: 50.8 / 72.2 (28, 138.0); seed 1: 53.5 / 77.0 (31, 141.0); "
                           "seed 2: 51.8 / 77.2 (25, 135.0)")
        assert "The main Y-net (t_f = 30 s, the release's windows) likewise with seeds 1, 2" in text
    assert ("scored in the main setting of Table 3 (TTST + CWS, K_e = 20, K_a = 1, 3 rounds) with the "
            "same round seeds") in text
    assert rows[3].startswith("PECNet 50 s 164.2 ± 19.8 ± 1.75")  # the baselines' rows follow
    assert "evaluation (test split, K = 20, 3 rounds from seed 0) are the same" in text


def test_no_seed_spread_file_is_explained(project):
    write_metrics(project / "metrics", data_metrics() | model_metrics(), skip=("baseline_seed_spread.json",))
    html = run_report(project).read_text()
    section = html.split('id="seed-spread"', 1)[1].split("<h3", 1)[0]
    assert "baseline_seed_spread.json missing" in section and "<table" not in section


def horizon_analysis_record() -> dict:
    """Two horizons: the plateau per horizon (50 then 48 px), a rise on one population."""
    def horizon(ade: float, speed: float, windows: int) -> dict:
        return {"data": {"windows": windows, "sources": {"raw": windows}, "speed_px_s": {"median": speed},
                         "standing_share": 0.1},
                "models": {"ynet": {"ade": ade, "fde": 2 * ade, "fde_over_ade": 2.0},
                           "constant_velocity": {"ade": 3 * ade, "fde": 6 * ade}},
                "straight_to_goal": {"ade": 20.0}}
    population = {"tf30": {"straight_to_goal": {"ade": 10.0}, "speed_px_s": {"median": 4.0},
                           "longest_predictions_truncated": {"ynet": {"ade": 39.0, "fde": 70.0}},
                           "own_horizon_models": {"ynet": {"ade": 41.0, "fde": 72.0}}},
                  "tf40": {"straight_to_goal": {"ade": 12.0}, "speed_px_s": {"median": 4.1},
                           "longest_predictions_truncated": {"ynet": {"ade": 48.3, "fde": 80.0}},
                           "own_horizon_models": {"ynet": {"ade": 48.3, "fde": 80.0}}}}
    return {"per_horizon": {"tf30": horizon(50.5, 22.7, 382), "tf40": horizon(48.5, 4.1, 84)},
            "one_population": {"horizon": 40, "windows": 84, "per_horizon": population},
            "leak_check": {"total": 0},
            "figures": {"curves": "reports/figures/horizons/curves.png",
                        "model": "reports/figures/horizons/model.png"}}


def test_horizon_analysis_section_shows_both_populations_and_its_figures(project):
    write_metrics(project / "metrics", data_metrics() | model_metrics()
                  | {"horizon_analysis.json": horizon_analysis_record()})
    write_png(project / "reports/figures/horizons/curves.png", (200, 0, 0))
    html = run_report(project).read_text()
    assert_well_formed(html)
    section = html.split('id="horizons"', 1)[1].split("<h2", 1)[0]
    assert "22.7 px/s at 30 s" in section and "4.1 px/s at 40 s" in section
    assert "does not rise at every horizon;" in section  # per horizon: 50.5 then 48.5
    assert "So the plateau is who is in each horizon's test set, not the model." in section
    assert "48.3 / 80.0" in section and "<td class=\"num\">39.0 / 70.0</td>" in section
    assert section.count("<img") == 1  # model.png is missing: not shown
    assert "../figures/horizons/curves.png" in section or "figures/horizons/curves.png" in section


def test_no_horizon_analysis_file_is_explained(project):
    write_metrics(project / "metrics", data_metrics() | model_metrics())
    section = run_report(project).read_text().split('id="horizons"', 1)[1].split("<h2", 1)[0]
    assert "horizon_analysis.json missing" in section and "<table" not in section


def test_a_single_round_shows_no_spread(project):
    """One round has std 0 by definition: the page says "1 round", never "± 0.00 over 1 rounds"."""
    files = data_metrics() | model_metrics()
    files["short_term/sdd.json"]["rounds"] = 1
    for k in ("k20", "k5"):
        for metric in ("ade", "fde"):
            files["short_term/sdd.json"]["models"]["ynet"][k][metric]["std"] = 0.0
    write_metrics(project / "metrics", files)
    store = load_metrics(project / "metrics", "metrics")
    one = lookup(store, "short_term/sdd.json", ("models", "ynet", "k20", "ade"))
    three = lookup(store, "ynet_eval.json", ("main", "ade"))
    assert (one.std, one.rounds) == (None, 1) and (three.std, three.rounds) == (0.4, 3)
    table = parse(run_report(project).read_text())
    cells = [" ".join(c["text"].split()) for c in comparison_cells(table)]
    short = [c for c in cells if "8.25" in c or "11.75" in c]
    assert short and all("1 round, no spread" in c and "±" not in c for c in short), short
    assert not any("over 1 rounds" in c for c in cells)


# What a reader sees in a table (a label) -> the model key of the metrics files, written out here
# rather than taken from paper_values.yaml, so a wrong key in either place fails.
MODEL_OF_LABEL = {"S-GAN": "sgan", "PECNet*": "pecnet", "PECNet": "pecnet", "R-PECNet": "rpecnet",
                  "Y-net": "ynet"}
ABLATION_OF_LABEL = {"TTST \u2717  CWS \u2717": "none", "TTST \u2717  CWS \u2713": "cws",
                     "TTST \u2713  CWS \u2713": "ttst_cws"}


def distinct_metrics() -> dict[str, object]:
    """Every model file of `model_metrics`' contracts, measured, with no two values alike: a cell
    that reads another key than its own (K = 5 for K = 20, ADE for FDE, another scene, ablation,
    K_a or dataset) shows a number that cannot be the right one."""
    values = itertools.count(101.5, 1.25)

    def measured() -> dict:
        return {key: {"mean": next(values), "std": 0.25} for key in ("ade", "fde", "ade_joint", "fde_joint")}

    def long_term(t_f: int = 30) -> dict:
        return {"t_f": t_f, "rounds": 3, "main": measured(),
                "ablation": {name: measured() for name in ("none", "cws", "ttst_cws")},
                "ka_grid": [{"k_e": k_e, "k_a": k_a, "rounds": 1, **measured()}
                            for k_e in (10, 20) for k_a in (1, 2, 5)]}

    files: dict[str, object] = {
        "short_term/sdd.json": {"rounds": 3, "models": {
            m: {"k20": measured(), "k5": measured()} for m in ("sgan", "pecnet", "ynet")}},
        "ynet_eval.json": long_term(),
        "ind_benchmark.json": {**long_term(), "baselines": {
            m: {"horizon": 30, "k": 20, "rounds": 3, **measured()}
            for m in ("sgan", "pecnet", "rpecnet", "constant_velocity")}},
    }
    for scene in ETHUCY_SCENES:
        files[f"short_term/ethucy_{scene}.json"] = {"rounds": 3, "models": {
            m: measured() for m in ("sgan", "pecnet", "ynet")}}
    for model in ("constant_velocity", "sgan", "pecnet", "rpecnet"):
        files[f"baselines/{model}_tf30.json"] = {"model": model, "horizon": 30, "k": 20, "rounds": 3,
                                                 **measured()}
    return files


def expected_cell(files: dict, table: str, row: str, column: "Column") -> dict | None:
    """The metrics node {"ade": {"mean"}, ...} a cell must show, found from what the reader sees."""
    if table == "sdd_short":
        model = MODEL_OF_LABEL.get(column.label)
        k = column.group.split("= ")[1]
        return files["short_term/sdd.json"]["models"][model][f"k{k}"] if model else None
    if table == "eth_ucy":
        model = MODEL_OF_LABEL.get(column.group)
        return files[f"short_term/ethucy_{row.lower()}.json"]["models"][model] if model else None
    record = files["ynet_eval.json" if column.group == "SDD" else "ind_benchmark.json"]
    if table == "ttst":
        return record["ablation"][ABLATION_OF_LABEL[column.label]]
    model, k_a = MODEL_OF_LABEL[column.label], int(column.sub.split("= ")[1])
    if model != "ynet":
        return files[f"baselines/{model}_tf30.json"] if column.group == "SDD" else record["baselines"][model]
    if k_a == 1:
        return record["main"]
    return next(cell for cell in record["ka_grid"] if (cell["k_e"], cell["k_a"]) == (20, k_a))


def test_every_cell_shows_the_value_its_key_names(project):
    files = distinct_metrics()
    write_metrics(project / "metrics", data_metrics() | model_metrics() | files)
    paper = yaml.safe_load(PAPER.read_text())
    tables = build_tables(paper, load_metrics(project / "metrics", "metrics"), BANDS)
    checked = 0
    for table in tables:
        for row in table.rows:
            for column, cell in zip(table.columns, row.cells, strict=True):
                metric = "ade" if row.label == "ADE" or column.label == "ADE" else "fde"
                where = (table.key, row.label, column.group, column.label, column.sub)
                if table.key == "eth_ucy" and row.label == "AVG":
                    node = [expected_cell(files, table.key, scene, column) for scene in ETHUCY_SCENES]
                    expected = None if node[0] is None else np.mean([n[metric]["mean"] for n in node])
                else:
                    node = expected_cell(files, table.key, row.label, column)
                    expected = None if node is None else node[metric]["mean"]
                if expected is None:
                    assert cell.ours is None, where  # a model this pipeline does not train
                    continue
                assert isinstance(cell.ours, Measured), (where, cell.ours)
                assert cell.ours.mean == pytest.approx(expected, abs=1e-12), where
                if table.key in ("sdd_long", "ttst"):
                    assert cell.joint.mean == node[f"{metric}_joint"]["mean"], where
                checked += 1
    assert checked == 2 * 5 + 2 * 3 * 6 + 2 * 12 + 2 * 5  # every cell of a model we run


TEX_LABELS = {"sdd_short": "tab:sdd_short", "eth_ucy": "tab:eth-ucy", "sdd_long": "tab:sdd_long",
              "ttst": "tab:ttst"}
ROW_NAMES = r"\b(ADE|FDE|ETH|HOTEL|UNIV|ZARA1|ZARA2|AVG)\b"


def tex_rows(tex: str, label: str) -> dict[str, list[float]]:
    """The numeric rows of the LaTeX table labelled `label`: row name -> its values left to right
    (every value the paper prints has two decimals; LaTeX arguments such as {1} or {0pt} do not)."""
    block = next(part for part in tex.split(r"\begin{table") if rf"\label{{{label}}}" in part)
    body = block.split(r"\begin{tabular}")[1].split(r"\end{tabular}")[0]
    rows = {}
    for chunk in body.split(r"\\"):
        values = [float(v) for v in re.findall(r"\d+\.\d+", chunk)]
        name = re.search(ROW_NAMES, re.sub(r"\d+\.\d+", "", chunk))
        if values and name:
            rows[name.group(1)] = values
    return rows


@pytest.mark.skipif(not PAPER_TEX.exists(), reason=f"{PAPER_TEX} not on this machine")
def test_paper_values_sit_where_the_papers_tables_print_them():
    """Transcription, cell by cell: each row of each table, left to right, as the LaTeX has it."""
    tex, paper = PAPER_TEX.read_text(), yaml.safe_load(PAPER.read_text())
    for key in ("sdd_short", "sdd_long", "ttst"):
        rows = tex_rows(tex, TEX_LABELS[key])
        assert set(rows) == {"ADE", "FDE"}, key
        for metric in ("ade", "fde"):
            assert rows[metric.upper()] == [c[metric] for c in paper[key]["columns"]], (key, metric)
    rows = tex_rows(tex, TEX_LABELS["eth_ucy"])
    assert list(rows) == ["ETH", "HOTEL", "UNIV", "ZARA1", "ZARA2", "AVG"]
    for name, values in rows.items():
        scene = name.lower()
        assert values == [m[metric][scene] for m in paper["eth_ucy"]["models"] for metric in ("ade", "fde")], name


def per_video_row(html: str, video: str) -> list[str]:
    """The cells of `video`'s row in the provenance table of raw annotations and horizon windows."""
    match = re.search(rf"<tr><td>{video}</td><td>([^<]*)</td><td>([^<]*)</td><td>([^<]*)</td></tr>", html)
    assert match, f"no per-video row for {video}"
    return list(match.groups())


def test_provenance_says_where_the_sdd_annotations_came_from(project):
    html = full_project(project).read_text()  # data_metrics: the mirror only, 2 videos
    assert "The raw annotations are the pinned mirror's 2 videos" in html
    assert "set <code>data.sdd.path</code> in params.yaml" in html
    assert "fingerprinted file of your copy" not in html
    assert per_video_row(html, "gates_2") == ["test", "fetched", "raw"]
    assert per_video_row(html, "coupa_0") == ["test", "none", "release-chained"]
    assert per_video_row(html, "nexus_10") == ["outside the split", "fetched",
                                                "none (outside the TrajNet split)"]
    assert ("The horizon benchmark's windows are raw on the 1 TrajNet videos with raw annotations and "
            "cut from chained release windows on the other 46.") in html

    files = data_metrics() | model_metrics()
    image = {"sha256": "c0" * 32, "pinned": False}
    files["sdd_sources.json"] = record = sdd_sources(
        {"gates_2": "fetched; your copy identical", "coupa_3": "your copy (fingerprinted)",
         "bookstore_0": "fetched"},
        images={"annotations/coupa/video3/reference.jpg": image,
                "annotations/gates/video2/reference.jpg": {"sha256": "d1" * 32, "pinned": True}},
        path="/data/stanford_campus_dataset")
    write_metrics(project / "metrics", files)
    html = run_report(project).read_text()
    assert_well_formed(html)
    assert "<code>data.sdd.path</code> = <code>/data/stanford_campus_dataset</code>" in html
    assert ("3 videos with raw annotations, fetched <b>1</b>, fetched; your copy identical <b>1</b>, "
            "your copy (fingerprinted) <b>1</b>") in html
    fingerprinted = re.findall(r"<tr><td>([^<]*)</td><td><code>([0-9a-f]{64})</code></td></tr>", html)
    assert fingerprinted == [("annotations/coupa/video3/annotations.txt",
                              record["videos"]["coupa_3"]["sha256"]),
                             ("annotations/coupa/video3/reference.jpg", "c0" * 32)]
    assert per_video_row(html, "coupa_3") == ["train", "your copy (fingerprinted)", "raw"]
    assert per_video_row(html, "gates_2") == ["test", "fetched; your copy identical", "raw"]

    write_metrics(project / "metrics", {"sdd_sources.json": []})
    assert "metrics/sdd_sources.json: not a mapping" in run_report(project).read_text()
    (project / "metrics/sdd_sources.json").unlink()
    assert "sdd_sources.json missing" in run_report(project).read_text()


def test_provenance_counts_code_and_params_changes_never_outputs(tmp_path):
    """Outputs of the pipeline (anything dvc.lock records, dvc.lock itself, the report's own
    outputs) change whenever a stage runs; only code or params.yaml make the numbers uncommitted."""
    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    git("init", "-q")
    lock = {"stages": {"evaluate_ynet": {"outs": [{"path": "metrics/ynet_eval.json"}]},
                       "tracks": {"outs": [{"path": "data/tracks"}]}}}
    for rel, text in {"pipeline/a.py": "x = 1\n", "params.yaml": "a: 1\n", "metrics/ynet_eval.json": "{}",
                      "dvc.lock": yaml.safe_dump(lock), "reports/index.html": "<p>"}.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    git("add", "-A")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "c")
    outputs = [*lock_outputs(read_lock(tmp_path / "dvc.lock")), "reports/index.html"]
    assert outputs == ["metrics/ynet_eval.json", "data/tracks", "reports/index.html"]
    assert git_state(tmp_path, outputs)["dirty"] is False

    (tmp_path / "metrics/ynet_eval.json").write_text('{"ade": 1}')
    (tmp_path / "dvc.lock").write_text(yaml.safe_dump({**lock, "schema": "2.0"}))
    (tmp_path / "reports/index.html").write_text("<p>new")
    (tmp_path / "data/tracks").mkdir(parents=True)
    (tmp_path / "data/tracks/t.parquet").write_text("rows")
    state = git_state(tmp_path, outputs)
    assert state["dirty"] is False and state["code_changes"] == [] and state["output_changes"] == 4

    (tmp_path / "params.yaml").write_text("a: 2\n")
    (tmp_path / "pipeline/a.py").write_text("x = 2\n")
    (tmp_path / "pipeline/b.py").write_text("y = 1\n")
    state = git_state(tmp_path, outputs)
    assert state["dirty"] is True and state["params_changed"] is True
    assert sorted(state["code_changes"]) == ["pipeline/a.py", "pipeline/b.py"]
    assert porcelain_paths(["R  old.py -> new.py", " M a b.py", "?? data/"]) == [
        "new.py", "a b.py", "data/"]
    assert is_output("data/", ["data/tracks"]) and not is_output("database.py", ["data"])
    assert is_output("reports/figures/.report.tmp2484.kn91exfz/", ["reports/figures/report"])
    assert is_output("metrics/.ynet_eval.json.tmp77", ["metrics/ynet_eval.json"])
    assert not is_output("pipeline/.page.py.tmp77", ["metrics/ynet_eval.json"])


def test_metrics_of_another_profile_or_k_are_shown_but_not_compared(project):
    files = data_metrics() | model_metrics()
    files["ynet_eval.json"] = {**files["ynet_eval.json"], "profile": "paper"}  # the lock says cpu
    files["baselines/sgan_tf30.json"] = {**baseline("sgan", 30, 60.0), "k": 3}
    write_metrics(project / "metrics", files)
    paper = yaml.safe_load(PAPER.read_text())
    store = load_metrics(project / "metrics", "metrics")
    tables = {t.key: t for t in build_tables(paper, store, BANDS, profile="cpu")}
    long_term = tables["sdd_long"]
    kinds = {(c.group, c.label, c.sub): cell.kind for c, cell in zip(long_term.columns, long_term.rows[0].cells)}
    assert kinds[("SDD", "Y-net", "K_a = 1")] == kinds[("SDD", "Y-net", "K_a = 2")] == "mismatch"
    assert kinds[("SDD", "S-GAN", "K_a = 1")] == "mismatch" and kinds[("SDD", "PECNet", "K_a = 1")] == "measured"
    sgan = long_term.rows[0].cells[0]
    assert sgan.diff is None and sgan.band == "" and sgan.ours.mean == 60.0
    assert sgan.ours.mismatch == "measured with k = 3; this cell is for k = 20"
    assert {cell.kind for cell in tables["ttst"].rows[0].cells[:3]} == {"mismatch"}
    assert summarize(long_term).counts["mismatch"] == 2 * 4  # ADE, FDE x Y-net K_a 1, 2, 5 and S-GAN
    headline = headline_metrics(tables.values(), [])
    assert not any(name.startswith("table3_sdd_long/sdd_ynet") for name in headline)
    html = run_report(project).read_text()  # the lock of the fixture says profile cpu
    assert "measured with profile = paper; this cell is for profile = cpu" in html
    assert 'data-kind="mismatch"' in html


def beyond_rows(html: str) -> dict[str, list[str]]:
    """{row label: its values (ours-value spans) or its not-scored reason} of the beyond table."""
    table = html[html.index('data-table="beyond"'):]
    table = table[:table.index("</table>")]
    rows = {}
    for label, body in re.findall(r"<tr><th>([^<]+)</th>(.*?)</tr>", table, flags=re.S):
        values = re.findall(r'class="ours-value">([^<]+)<', body)
        rows[label] = values or [" ".join(re.sub(r"<[^>]+>", " ", body).split())]
    return rows


def test_beyond_section_renders_from_the_score_predictions_file(project):
    files = data_metrics() | model_metrics()
    files["beyond/long_term.json"]["tables"]["tf30"]["models"]["sgan"] = {
        "file": "x.parquet", "model": "sgan", "not_run_reason": "S-GAN was not trained here"}
    write_metrics(project / "metrics", files)
    html = run_report(project).read_text()
    assert_well_formed(html)
    rows = beyond_rows(html)
    # t_f = 30: the horizon table's models in the paper's order, then the release row.
    assert list(rows) == ["model", "S-GAN", "PECNet", "R-PECNet", "Constant velocity",
                          "Y-net, release_tf30 windows"]
    # PECNet at 30 s: ADE 2.25 * 30 = 67.5; FDE 135, joint 143.5, best endpoint 71.75, miss 0.375,
    # NLL 11.5 + 0.675, off limits 0.1875 (truth 0.125), collisions 0.0125 (truth 0).
    assert rows["PECNet"] == ["67.50", "135.00", "143.50", "71.75", "0.375", "12.18", "0.188",
                              "0.125", "0.013", "0.000"]
    assert rows["Y-net, release_tf30 windows"][:2] == ["50.50", "101.00"]
    assert rows["S-GAN"] == ["not scored: S-GAN was not trained here"]
    section = html[html.index('<h2 id="beyond">'):html.index('<h2 id="data">')]
    assert "tf15/ynet: Y-net is not trained at t_f = 15 s here" in section
    assert "Miss rate</b> at 2.0 m" in section and "closer than 0.2 m" in section
    assert 'src="figures/report/beyond_horizons.png"' in section
    assert (project / "reports/figures/report/beyond_horizons.png").stat().st_size > 10_000


def test_beyond_section_changes_no_paper_table_and_says_when_it_is_missing(project):
    files = data_metrics() | model_metrics()
    write_metrics(project / "metrics", files)
    with_it = comparison_cells(parse(run_report(project).read_text()))
    (project / "metrics/beyond/long_term.json").unlink()
    html = run_report(project).read_text()
    assert comparison_cells(parse(html)) == with_it  # every cell of the paper's tables as it was
    assert f"stage not yet run: {project / 'metrics'}/beyond/long_term.json missing" in html
    assert not (project / "reports/figures/report/beyond_horizons.png").exists()


def test_a_registered_model_gets_a_table_3_column_a_horizon_line_and_beyond_rows(project):
    """One line in params.yaml `models` (README "Your model here") and the files its stages write
    put a model in Table 3 (no paper value: "—", no difference), Figure 4, the dvc plots series,
    the headline metrics and "Beyond the paper's tables"; one not yet run is explained, not blank."""
    params = yaml.safe_load((project / "params.yaml").read_text())
    params["models"]["toy"] = {"class": "Toy", "label": "Toy walker", "colour": "#17becf",
                               "settings": {}}
    params["models"]["later"] = {"class": "Later", "label": "Not run yet", "colour": "#bcbd22",
                                 "settings": {}}
    (project / "params.yaml").write_text(yaml.safe_dump(params, sort_keys=False))
    files = data_metrics() | model_metrics()
    for h in HORIZONS:
        files[f"baselines/toy_tf{h}.json"] = baseline("toy", h, 0.75 * h)
        files["beyond/long_term.json"]["tables"][f"tf{h}"]["models"]["toy"] = beyond_model("toy", 0.75 * h)
    write_metrics(project / "metrics", files)
    html = full_project_page(project)

    table = html[html.index('data-table="sdd_long"'):]
    reasons = table[:table.index('<h2 id=')]  # the table's list of reasons, once each
    table = table[:table.index("</table>")]
    header = re.findall(r"<th>([^<]*)</th>", table)
    # after the paper's SDD columns (Y-net K_a = 5), before inD; registry order
    assert header.index("Toy walker") == header.index("Constant velocity") + 1
    assert header.index("Not run yet") == header.index("Toy walker") + 1
    cells = [c for c in comparison_cells(parse(html)) if "22.50" in c["text"]]  # toy's ADE at 30 s
    assert len(cells) == 1 and cells[0]["attrs"]["data-kind"] == "ours-only"
    text = " ".join(cells[0]["text"].split())
    assert text.startswith("paper \u2014 ours 22.50") and "not in the paper" in text
    missing = f"stage not yet run: {project / 'metrics'}/baselines/later_tf30.json missing"
    mark = re.search(r'<sup class="reason">(n\d+)</sup> ' + re.escape(missing), reasons)
    assert mark, "the reason is listed under the table"
    assert table.count(f'<sup class="reason">{mark.group(1)}</sup>') == 2  # its ADE and FDE cells
    assert missing not in table  # the reason once, under the table, not in every cell

    horizon = html[html.index('<h2 id="fig-horizon">'):html.index('<h2 id="seed-spread">')]
    assert "<tr><th>Toy walker</th>" in horizon and "<tr><th>Not run yet</th>" in horizon
    rows = json.loads((project / "reports/plots/horizon_ade.json").read_text())
    assert [row["toy"] for row in rows] == [0.75 * h for h in HORIZONS]
    headline = json.loads((project / "reports/headline/table3_sdd_long/sdd_toy_ka1.json")
                          .read_text())
    assert headline == {"ade": 22.5, "fde": 2.1 * 22.5}
    assert list(beyond_rows(html))[:6] == ["model", "S-GAN", "PECNet", "R-PECNet",
                                          "Constant velocity", "Toy walker"]
    assert beyond_rows(html)["Toy walker"][:2] == ["22.50", "45.00"]


def full_project_page(root: Path) -> str:
    """The report of `root`'s metrics as written (no fixture metrics added)."""
    write_qualitative(root / "data/ynet_predictions/qualitative.npz")
    html = run_report(root).read_text()
    assert_well_formed(html)
    return html


def short_term_rows(html: str, table: str = "beyond-short-term") -> dict[str, list[str]]:
    """{"<benchmark> / <model>": [unit, values...] or [unit, not-scored reason]}."""
    part = html[html.index(f'data-table="{table}"'):]
    part = part[:part.index("</table>")]
    rows = {}
    for bench, model, body in re.findall(r"<tr><th>([^<]+)</th><th>([^<]+)</th>(.*?)</tr>", part,
                                         flags=re.S):
        unit = re.search(r"<td>([^<]*)</td>", body)
        values = re.findall(r'class="ours-value">([^<]+)<', body)
        rows[f"{bench} / {model}"] = [unit.group(1) if unit else ""] + (
            values or [" ".join(re.sub(r"<[^>]+>", " ", body).split()[1:])])
    return rows


def test_beyond_short_term_table_states_units_and_reasons(project):
    write_metrics(project / "metrics", data_metrics() | model_metrics())
    html = run_report(project).read_text()
    assert_well_formed(html)
    rows = short_term_rows(html)
    assert list(rows) == ["benchmark / model", "SDD (TrajNet) / Y-net", "SDD (TrajNet) / S-GAN",
                          "SDD (TrajNet) / PECNet", "ETH / Y-net", "ETH / S-GAN", "ETH / PECNet"]
    # Pixels: 2 decimals (ADE 12.75, FDE twice that).
    assert rows["SDD (TrajNet) / Y-net"][:3] == ["px", "12.75", "25.50"]
    # Metres: 3 decimals; best endpoint 0.625 + 4.25; miss 0.375; NLL 11.5 + 0.00625.
    assert rows["ETH / PECNet"] == ["m", "0.625", "1.250", "9.750", "4.875", "0.375", "11.51",
                                    "0.188", "0.125", "0.013", "0.000"]
    assert rows["ETH / Y-net"] == ["m", "not scored: Y-net is not trained on eth in the cpu profile"]
    section = html[html.index('<h3 id="beyond-short-term">'):html.index('<h2 id="animations">')]
    assert "per pixel&sup2; for SDD, per metre&sup2; for ETH/UCY" in section
    assert "ETH: 181 of 181 windows in a scene with a mask, forbidden not_road" in section
    assert f"inD is absent from these metrics: {IND_REASON}" in section
    assert "(ind/ynet, ind/sgan, ind/pecnet)" in section  # the long-term models' order


def test_short_term_and_ind_beyond_change_no_paper_table_and_say_when_missing(project):
    write_metrics(project / "metrics", data_metrics() | model_metrics())
    with_them = comparison_cells(parse(run_report(project).read_text()))
    for rel in ("beyond/short_term.json", "beyond/ind.json"):
        (project / "metrics" / rel).unlink()
    html = run_report(project).read_text()
    assert comparison_cells(parse(html)) == with_them
    assert f"stage not yet run: {project / 'metrics'}/beyond/short_term.json missing" in html
    assert f"inD: stage not yet run: {project / 'metrics'}/beyond/ind.json missing" in html
    assert 'data-table="beyond"' in html  # the long-term part stands on its own


@pytest.mark.parametrize("jobs", [None, 2])
def test_the_time_section_says_when_stages_ran_side_by_side(project, monkeypatch, jobs):
    """With `make repro`'s --jobs 2 the stage times add up to more than the run's wall time: the
    page says so; a record from before --jobs (no such key) reads as one stage at a time."""
    monkeypatch.chdir(project)  # the report stage reads reports/stage_times.json by default
    run = {"started": "2026-11-27 09:53:26 UTC", "seconds": 2010.1, "exit_code": 0,
           "command": "tools/parallel_repro.py --jobs 2", "stages_run": ["a", "b"], "cpu_count": 2,
           **({"jobs": jobs} if jobs else {})}
    (project / "reports/stage_times.json").write_text(json.dumps({"last_run": run, "stages": {
        "a": {"seconds": 1500.0, "run_started": run["started"]},
        "b": {"seconds": 1500.0, "run_started": run["started"]}}}))
    html = run_report(project).read_text()
    assert "33.5 min in all" in html and "50.0 min" in html  # the run's wall time; the stages' sum
    assert ("Up to 2 single-threaded stages ran at once" in html) == (jobs == 2)


def test_table3_diagnostics_section_shows_k1_the_rollout_and_the_compat_rows(project):
    files = data_metrics() | model_metrics()
    files["rpecnet_rollouts.json"] = {
        "target_fde_over_ade": 2.872, "horizons": {"tf30": {
            "t_f": 30, "chosen": "original_frame",
            "choice": {"split": "val", "n_windows": 156, "variants": {
                "original_frame": {"ade": 261.6, "fde": 607.4, "fde_over_ade": 2.32}}},
            "test": {"variant": "original_frame", "n_windows": 382, "ade": 274.24, "fde": 611.77}}}}
    files["pecnet_test_selection.json"] = {"per_horizon": {"tf30": {
        "validation_selected": {"epoch": 29, "test": {"headline": {"ade": 82.44, "fde": 173.75},
                                                      "pecnet": {"ade": 89.18, "fde": 173.75}}},
        "compat": {p: {"best_ade": {"value": 81.14, "epoch": 35}, "best_fde": {"value": 158.89, "epoch": 38}}
                   for p in ("headline", "pecnet")}}}}
    write_metrics(project / "metrics", files)
    html = run_report(project).read_text()
    assert_well_formed(html)
    section = html.split('id="diagnostics"', 1)[1].split('id="fig-horizon"', 1)[0]
    assert "PECNet 72.22 / 118.13" in section  # the paper's cell, by its label
    assert "upstream&#39;s test-set selection (compat)" in section or "upstream's test-set selection (compat)" in section
    assert "158.89 (38)" in section and "173.75 (29)" in section
    assert "27 %" in section  # (173.75 - 158.89) / (173.75 - 118.13) of the FDE gap
    assert "R-PECNet, roll-out original_frame" in section and "274.24" in section and "2.32" in section
