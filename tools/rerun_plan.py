"""What a params change would re-run, read from dvc.yaml alone: `dvc exp run -S key=value --dry`
for a pipeline in any state.

`dvc exp run --dry` does not work here (it implies `--temp`, whose copy holds no data outputs), and
`dvc repro --dry` after editing params.yaml stops at the first missing output of a stale pipeline,
lists only the stages whose own inputs changed, and means touching params.yaml, which a running
`dvc repro` reads at every stage. This reads params.yaml and each stage's declared params keys (as
DVC resolves them, `${profile}` included) and writes nothing:

- changed: the stages that declare the key, a section above it or a key below it, when the new
  value differs from params.yaml's;
- downstream: every stage that depends on those through outputs. DVC runs each unless what it
  reads comes out byte-identical (for example the untrained horizon slots of `ynet_slot_scoring`).

    python -m tools.rerun_plan -S ttst.temperature=1.8
    python -m tools.rerun_plan -S short_term_models.cpu.epochs.sgan.sdd=21 -S profile=paper
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Mapping
from pathlib import Path

import yaml

MISSING = object()


def parse_override(text: str) -> tuple[str, object]:
    """`key.path=value` -> (key path, value parsed as YAML, as `dvc exp run -S` does)."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise ValueError(f"-S {text!r}: expected key.path=value")
    return key, yaml.safe_load(value)


def value_at(params: Mapping, key: str) -> object:
    """The value at a dotted key path of a params mapping, or MISSING."""
    node = params
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return MISSING
        node = node[part]
    return node


def declares(declared_keys: Iterable[str], key: str) -> bool:
    """Whether a stage that declares `declared_keys` of params.yaml sees a change of `key`: it
    declares the key itself, a section above it, or a key below it (the whole file: no keys)."""
    declared_keys = list(declared_keys)
    if not declared_keys:
        return True
    return any(key == declared or key.startswith(f"{declared}.") or declared.startswith(f"{key}.")
               for declared in declared_keys)


def changed_stages(declared: Mapping[str, Iterable[str]], keys: Iterable[str]) -> set[str]:
    """The stages (name -> declared params.yaml keys) that declare any of `keys`."""
    keys = list(keys)
    return {stage for stage, stage_keys in declared.items()
            if any(declares(stage_keys, key) for key in keys)}


def downstream(upstream_of: Mapping[str, Iterable[str]], stages: set[str]) -> set[str]:
    """Every stage that reads, directly or through others, an output of `stages` (not those).
    `upstream_of`: stage -> the stages whose outputs it depends on."""
    readers: dict[str, set[str]] = {}
    for stage, upstream in upstream_of.items():
        for source in upstream:
            readers.setdefault(source, set()).add(stage)
    found, frontier = set(), list(stages)
    while frontier:
        for reader in readers.get(frontier.pop(), ()):
            if reader not in found and reader not in stages:
                found.add(reader)
                frontier.append(reader)
    return found


def pipeline_graph(root: Path = Path(".")) -> tuple[dict[str, list[str]], dict[str, set[str]]]:
    """From DVC's own view of dvc.yaml: (stage -> declared params.yaml keys, resolved;
    stage -> the stages it depends on). Stages declaring no params.yaml key are absent from the
    first, and so are frozen ones (the studies of studies/dvc.yaml): no change re-runs them."""
    from dvc.dependency.param import ParamsDependency
    from dvc.repo import Repo

    index = Repo(str(root)).index
    declared = {}
    for stage in index.stages:
        if stage.frozen:
            continue
        for dep in stage.deps:
            if isinstance(dep, ParamsDependency) and Path(dep.def_path).name == "params.yaml":
                declared.setdefault(stage.addressing, []).extend(dep.params)
    graph = index.graph  # edges run from a stage to the stages it depends on
    upstream_of = {stage.addressing: {dep.addressing for dep in graph.successors(stage)}
                   for stage in graph.nodes}
    return declared, upstream_of


def changed_keys(params: Mapping, overrides: Iterable[tuple[str, object]]) -> list[str]:
    """The keys of `overrides` (key, new value) whose value differs from `params`'; a key
    params.yaml does not hold is an error."""
    keys = []
    for key, value in overrides:
        current = value_at(params, key)
        if current is MISSING:
            raise KeyError(f"params.yaml has no key {key!r}")
        if current != value:
            keys.append(key)
    return keys


def plan(keys: Iterable[str], declared: Mapping[str, Iterable[str]],
         upstream_of: Mapping[str, Iterable[str]]) -> tuple[set[str], set[str]]:
    """(changed, downstream) when the params.yaml `keys` (from `changed_keys`) change."""
    changed = changed_stages(declared, keys)
    return changed, downstream(upstream_of, changed)


def trains(stage: str) -> bool:
    """Whether `stage` learns a model: a `train_*` stage, the segmentation, a registered model's fit."""
    return stage.startswith(("train", "fit_model")) or stage == "segmentation"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-S", "--set-param", dest="overrides", action="append", required=True,
                        metavar="KEY=VALUE", help="a params.yaml change, as for dvc exp run")
    args = parser.parse_args(argv)
    try:
        overrides = [parse_override(text) for text in args.overrides]
    except ValueError as error:
        print(f"rerun_plan: {error}")
        return 2
    params = yaml.safe_load(Path("params.yaml").read_text())
    try:
        keys = changed_keys(params, overrides)
    except KeyError as error:
        print(f"rerun_plan: {error.args[0]}")
        return 2
    for key, value in overrides:
        if key not in keys:
            print(f"{key} is already {value!r} in params.yaml: that changes nothing")
    changed, after = plan(keys, *pipeline_graph())
    print(f"params changed in ({len(changed)}): {', '.join(sorted(changed)) or '-'}")
    print(f"downstream, re-run unless their inputs come out byte-identical ({len(after)}): "
          f"{', '.join(sorted(after)) or '-'}")
    training = sorted(filter(trains, changed | after))
    print(f"training stages among them ({len(training)}): {', '.join(training) or 'none'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
