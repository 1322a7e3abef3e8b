"""A stage's code holds only the params.yaml sections it reads, so editing one section's module of
`pipeline.config` re-runs only the stages that read that section.

For each section module `pipeline/config/<section>.py` the test computes, with
`pipeline.code_graph.code_closure`, the stage modules of dvc.yaml whose code contains it, and
asserts that they are the stages that read the section, where a stage reads a section when

- its dvc.yaml `params:` declare a key of it (over every stage that runs its module, foreach items
  resolved by DVC), unless each declared key of that section reaches it on its command line
  (`--n-past ${windows.n_past}`): the stage then gets a number and never runs the section's code;
- or it rebuilds the section's dataclass from a file another stage wrote from that section (a
  model file's settings, a slot's scoring settings) or from another section's values
  (`FROM_ELSEWHERE`, each with its source): DVC tracks the file or that other section, so the
  stage's params cannot say it.

What is left are sections that a library the stage imports needs for other stages' work:
`NOT_READ` names each with that library, to go as the libraries are split (one benchmark one
module, stages reading params once: issue 63); the test fails when one of them has left the
closure, so the list only shrinks. `UNCHECKED` is the other way round: a stage that reads a
section's keys from the params mapping, without the section's class. The frozen study stages of
studies/dvc.yaml are left out (DVC never re-runs them), and `pipeline/config/loading.py`, how any
section loads, is in the code of every stage that loads one.
"""

from __future__ import annotations

import shlex
from collections import defaultdict
from functools import cache

import pytest
import yaml
from dvc.repo import Repo

from pipeline.code_graph import REPO, code_closure, has_code

CONFIG = REPO / "pipeline" / "config"
SHARED = {"__init__", "loading"}  # no section: the package's docstring and what every section uses

MODEL_FILE = "a Y-net model file's settings (YnetSettings.from_saved, runners.ynet_scoring)"
CHECKPOINT = "a trained baseline's checkpoint settings (<Model>.load, runners.baselines)"
SLOT_FILE = "its slot's scoring settings, data/ynet_slot_scoring (slot_scoring.read_slot_scoring)"
SHORT_TERM_SAMPLING = ("built from short_term_models.<profile> (runners.short_term.ynet_options, "
                       "ShortTermModelsParams.eval_params)")
FROM_ELSEWHERE: dict[str, dict[str, str]] = {
    "ynet": dict.fromkeys(["evaluate_ynet", "evaluate_ynet_horizon", "evaluate_ynet_seed",
                           "evaluate_short_term_ynet", "evaluate_ind", "horizon_analysis"],
                          MODEL_FILE),
    "sgan": dict.fromkeys(["evaluate_baseline", "evaluate_baseline_seed",
                           "evaluate_short_term_baseline", "evaluate_ind"], CHECKPOINT),
    "pecnet": dict.fromkeys(["evaluate_baseline", "evaluate_baseline_seed",
                             "evaluate_short_term_baseline", "evaluate_ind", "evaluate_pecnet_ka",
                             "evaluate_rpecnet", "evaluate_rpecnet_seed", "rpecnet_rollouts"],
                            CHECKPOINT),
    **{section: {"evaluate_ynet_horizon": SLOT_FILE, "evaluate_ynet_seed": SLOT_FILE,
                 "evaluate_short_term_ynet": SHORT_TERM_SAMPLING}
       for section in ("ttst", "cws", "eval")},
}

REGISTRY = "runners.baselines: its registry imports every baseline, so both settings classes"
SHORT_TERM = "runners.short_term: Y-net's and the baselines' short-term runs in one module"
SHORT_TERM_MODELS = "config.short_term_models: its eval_params builds the eval section's class"
DEVICE = "device: parses runtime.device names with the section's own check (parse_device_name)"
AUGMENT = "data.augment (through runners.segmentation): its NO_AUGMENT default"
NOT_READ: dict[str, dict[str, str]] = {
    "runtime": dict.fromkeys(["epoch_selection", "horizon_analysis"], DEVICE),
    "sgan": {**dict.fromkeys(["epoch_selection", "evaluate_pecnet_ka", "evaluate_rpecnet",
                              "evaluate_rpecnet_seed", "rpecnet_rollouts", "pecnet_test_selection",
                              "short_term_pecnet_test_selection"], REGISTRY),
             **dict.fromkeys(["evaluate_short_term_ynet", "train_short_term_ynet"], SHORT_TERM)},
    "pecnet": {"epoch_selection": REGISTRY,
               **dict.fromkeys(["evaluate_short_term_ynet", "train_short_term_ynet"], SHORT_TERM)},
    "ynet": {**dict.fromkeys(["evaluate_short_term_baseline", "train_short_term_baseline",
                              "short_term_pecnet_test_selection"], SHORT_TERM)},
    **{section: dict.fromkeys(["evaluate_short_term_baseline", "train_short_term_baseline",
                               "train_short_term_ynet", "short_term_pecnet_test_selection"],
                              SHORT_TERM_MODELS if section == "eval" else SHORT_TERM)
       for section in ("ttst", "cws", "eval")},
    "segmentation": {"semantic_maps": AUGMENT},
}
UNCHECKED: dict[str, dict[str, str]] = {
    "windows": {"ynet_slot_scoring": "the stage reads windows.horizons and windows.release_horizon "
                                     "from the params mapping (slot_settings)"},
}


def section_modules() -> list[str]:
    return sorted(p.stem for p in CONFIG.glob("*.py") if p.stem not in SHARED)


def stage_module(cmd: str) -> str:
    tokens = shlex.split(" ".join(str(cmd).split()))
    return tokens[tokens.index("-m") + 1].rpartition(".")[2]


def command_line_sections(stage: dict) -> set[str]:
    """The sections all of whose declared keys this dvc.yaml stage (as written, before DVC
    resolves it) passes on its command line, as `${<key>}`."""
    body = stage.get("do", stage)
    cmd = " ".join(str(body["cmd"]).split())
    passed, read = set(), set()
    for key in body.get("params", []):
        section = key.split(".")[0]
        (passed if "${" not in section and "${" + key + "}" in cmd else read).add(section)
    return passed - read


@cache
def sections_read() -> dict[str, set[str]]:
    """Stage module -> the sections its dvc.yaml stages declare, less those passed as arguments."""
    written = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]
    on_command_line = {name: command_line_sections(stage) for name, stage in written.items()}
    reads = defaultdict(set)
    for stage in Repo(str(REPO)).index.stages:
        if stage.dvcfile.relpath != "dvc.yaml" or stage.addressing == "code_fingerprints":
            continue
        name = stage.addressing.partition("@")[0]
        declared = {key.split(".")[0] for dep in stage.deps
                    for key in (getattr(dep, "params", None) or [])}
        reads[stage_module(stage.cmd)] |= declared - on_command_line[name]
    return dict(reads)


def stages_containing(section: str) -> set[str]:
    path = f"pipeline/config/{section}.py"
    return {module for module in sections_read()
            if path in code_closure(f"pipeline.stages.{module}")}


def stages_reading(section: str) -> set[str]:
    return {module for module, sections in sections_read().items() if section in sections}


def test_every_section_module_is_a_params_section():
    sections = set(yaml.safe_load((REPO / "params.yaml").read_text()))
    assert set(section_modules()) <= sections
    assert not has_code(CONFIG / "__init__.py"), "pipeline.config re-exports nothing: no code"


@pytest.mark.parametrize("section", section_modules())
def test_a_section_s_module_is_in_the_code_of_the_stages_that_read_it_only(section):
    inside, reads = stages_containing(section), stages_reading(section)
    elsewhere, not_read = FROM_ELSEWHERE.get(section, {}), NOT_READ.get(section, {})
    unchecked = UNCHECKED.get(section, {})
    assert not set(elsewhere) & reads and not set(not_read) & (reads | set(elsewhere))
    assert inside - reads - set(elsewhere) - set(not_read) == set(), \
        f"pipeline/config/{section}.py is in the code of stages that do not read it"
    assert reads - inside - set(unchecked) == set(), \
        f"stages read section {section} without its module"
    assert set(elsewhere) | set(not_read) <= inside, \
        f"listed for {section} but no longer in their code: shorten FROM_ELSEWHERE / NOT_READ"
    assert not set(unchecked) & inside, f"{section}: now read with its class; shorten UNCHECKED"


def test_the_checks_see_a_section_passed_on_the_command_line():
    stage = {"cmd": "python -m pipeline.stages.x --n-past ${windows.n_past}",
             "params": ["windows.n_past", "ttst"]}
    assert command_line_sections(stage) == {"windows"}
    stage["params"].append("windows.horizons")  # read in the code too
    assert command_line_sections(stage) == set()
    assert sections_read()["train_ynet"] >= {"ynet", "runtime"}
    assert "windows" not in sections_read()["train_ynet"]  # --n-past ${windows.n_past}
    assert "windows" in sections_read()["windows"]
