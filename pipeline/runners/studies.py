"""A study's run of a pipeline stage (studies/dvc.yaml): the stage's own command, in a scratch
folder beside a copy of params.yaml with some keys changed, which is what `dvc exp run -S
key=value` would give the stage. So the stage's code, fingerprint and lock entry stay the main
pipeline's, and a study measures exactly what the pipeline runs, with one setting moved."""

from __future__ import annotations

import copy
import os
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from pipeline.config.loading import ParamsError
from pipeline.io import write_text

REPO = Path(__file__).resolve().parents[2]


def dotted(params: Mapping[str, Any], key: str) -> Any:
    """params["a"]["b"]["c"] for "a.b.c"; an error naming the key where a level is missing."""
    node: Any = params
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            raise ParamsError(f"params.yaml has no {key!r} (no {part!r} there)")
        node = node[part]
    return node


def with_overrides(params: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """A copy of `params` with each dotted key of `overrides` set; the key must exist (a typo
    would otherwise add a setting no stage reads)."""
    changed = copy.deepcopy(dict(params))
    for key, value in overrides.items():
        *parents, last = key.split(".")
        node = dotted(changed, ".".join(parents)) if parents else changed
        dotted(changed, key)  # must exist
        node[last] = value
    return changed


def scratch_params(scratch: Path, params: Mapping[str, Any], overrides: Mapping[str, Any]) -> Path:
    """`scratch`/params.yaml: `params` with `overrides`; the scratch folder, made if need be."""
    scratch.mkdir(parents=True, exist_ok=True)
    write_text(scratch / "params.yaml", yaml.safe_dump(with_overrides(params, overrides),
                                                       sort_keys=False))
    return scratch


def run_stage(stage: str, args: list[str], cwd: Path) -> None:
    """`python -m pipeline.stages.<stage> args` in `cwd`, where it reads its params.yaml; paths in
    `args` must be absolute."""
    path = os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))
    subprocess.run([sys.executable, "-m", f"pipeline.stages.{stage}", *args], cwd=cwd,
                   env={**os.environ, "PYTHONPATH": path}, check=True)


def short_term_commands(model: str, dataset: str, windows: Path, scratch: Path,
                        ynet_inputs: tuple[Path, Path, Path] | None = None
                        ) -> list[tuple[str, list[str]]]:
    """(stage, arguments) of a short-term model's training, then its scoring, in `scratch`, every
    path absolute: `train_short_term_baseline` + `evaluate_short_term_baseline`, or for Y-net
    (`ynet_inputs`: its maps, the SDD root, the ETH/UCY images) `train_short_term_ynet` +
    `evaluate_short_term_ynet`."""
    train, run = scratch / "train.json", scratch / "run.json"
    common = ["--dataset", dataset, "--windows", str(windows.resolve()),
              "--checkpoint-dir", str(scratch / "model")]
    scored = ["--train-metrics", str(train), "--metrics", str(run),
              "--predictions", str(scratch / "predictions.parquet")]
    if ynet_inputs is None:
        common += ["--model", model]
        return [("train_short_term_baseline", [*common, "--metrics", str(train)]),
                ("evaluate_short_term_baseline", [*common, *scored])]
    maps, sdd, ethucy_scenes = ynet_inputs
    common += ["--maps", str(maps.resolve()), "--sdd", str(sdd.resolve())]
    return [("train_short_term_ynet", [*common, "--metrics", str(train)]),
            ("evaluate_short_term_ynet", [*common, *scored,
                                          "--ethucy-scenes", str(ethucy_scenes.resolve()),
                                          "--qualitative", str(scratch / "qualitative.npz")])]
