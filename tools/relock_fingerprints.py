"""Re-record in dvc.lock the code fingerprints of stages whose code changed but whose outputs cannot
have: a refactor, a docstring, a moved function. Only for that, and only with the evidence (the
stage re-run outside DVC gives byte-identical outputs, or a test shows it); otherwise `dvc repro`.

    dvc repro code_fingerprints            # first: the fingerprints of the code as it is now
    python -m tools.relock_fingerprints    # then: list what it would re-record, change nothing
    python -m tools.relock_fingerprints --write
    python -m tools.relock_fingerprints --write segmentation train_ynet_horizon   # only these
    python -m tools.relock_fingerprints --write --absent-ok   # a checkout without the outputs
    python -m tools.relock_fingerprints --write --params horizon_analysis  # params too (below)

It refuses when any stale stage it is to re-record has another change than a modified fingerprint
dep (data, params, outputs, a fingerprint not yet written), naming those stages: they must run.
Stage names narrow it to those stages (a foreach group's name to all its items), so a docstring can
be re-recorded while other stages of the pipeline still wait to run.

With `--params` a changed params dep counts too, and the stage's params are re-recorded from
params.yaml as it is: for a key that was removed (a switch off in every profile) or added (a value
the stage now reads, such as the registered models' labels) where the evidence shows the outputs
cannot change; never for a value that does change what a stage computes.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

from tools.timed_repro import current_stages  # dvc.yaml's stage names, via DVC's API

FINGERPRINTS = "data/code_fingerprints/"
ABSENT = ("deleted", "not in cache")  # `dvc status` of a file that is not in this checkout


def fingerprint_only(changes: list, absent_ok: bool = False, params_ok: bool = False) -> bool:
    """A stage's `dvc status --json` entry holds only modified fingerprint deps. With `absent_ok`
    (a checkout that lacks the outputs: a new machine, no cache) a data file missing from the
    workspace (`deleted`, or `not in cache` for an output) is no change either: its record in
    dvc.lock stands as it is. With `params_ok` a changed params dep (`{"params.yaml": {key:
    state}}`) is allowed as well."""
    for change in changes:
        if not isinstance(change, dict) or not set(change) <= {"changed deps", "changed outs"}:
            return False
        for kind, paths in change.items():
            for path, state in paths.items():
                fingerprint = path.startswith(FINGERPRINTS)
                if kind == "changed deps" and fingerprint and state == "modified":
                    continue
                if kind == "changed deps" and params_ok and isinstance(state, dict):
                    continue
                if absent_ok and not fingerprint and state in ABSENT:
                    continue
                return False
    return True


def current_params(names: Iterable[str]) -> dict[str, dict[str, dict]]:
    """stage -> {params file: {key: value}} as DVC reads them now, keys sorted as dvc.lock has them."""
    from dvc.dependency.param import ParamsDependency
    from dvc.repo import Repo

    wanted, found = set(names), {}
    for stage in Repo(".").index.stages:
        if stage.addressing in wanted:
            found[stage.addressing] = {
                dep.def_path: dict(sorted(dep.read_params().items()))
                for dep in stage.deps if isinstance(dep, ParamsDependency)}
    return found


def selected(status: dict, targets: list[str]) -> dict:
    """The entries of `dvc status --json` for `targets`: a stage's name, or a foreach group's name
    for each of its items (`train_ynet_horizon` -> `train_ynet_horizon@5`, ...); no targets: all."""
    if not targets:
        return status
    return {stage: changes for stage, changes in status.items()
            if any(stage == target or stage.startswith(f"{target}@") for target in targets)}


def unknown(targets: list[str], stage_names: Iterable[str]) -> list[str]:
    """The targets that name no stage and no foreach group of `stage_names`."""
    return [target for target in targets
            if not selected(dict.fromkeys(stage_names), [target])]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="re-record (default: only list)")
    parser.add_argument("--absent-ok", action="store_true",
                        help="outputs missing from this checkout (a new machine) count as unchanged")
    parser.add_argument("--params", action="store_true",
                        help="re-record changed params too (only with the evidence: docstring)")
    parser.add_argument("stages", nargs="*", help="only these stages or foreach groups (default: all)")
    args = parser.parse_args(argv)
    missing = unknown(args.stages, current_stages()) if args.stages else []
    if missing:
        print(f"no such stage in dvc.yaml: {', '.join(missing)}")
        return 2
    status = json.loads(subprocess.run(["dvc", "status", "--json"], check=True,
                                       capture_output=True, text=True).stdout or "{}")
    if "code_fingerprints" in status:
        print("code_fingerprints is stale: run `dvc repro code_fingerprints` first")
        return 1
    status = selected(status, args.stages)
    must_run = sorted(stage for stage, changes in status.items()
                      if not fingerprint_only(changes, args.absent_ok, args.params))
    if must_run:
        print("these stages changed beyond their code fingerprint and must run:\n  "
              + "\n  ".join(must_run))
        return 1
    if not status:
        print("nothing to re-record: dvc status is clean" + (" for those stages" if args.stages else ""))
        return 0
    what = "code fingerprint" + (" and params" if args.params else "")
    print(f"{len(status)} stages differ only in their {what}: {', '.join(sorted(status))}")
    if not args.write:
        print("(--write re-records them)")
        return 0
    from dvc.utils.serialize import modify_yaml

    recorded = {}  # path -> (md5, size): one file is the fingerprint of every item of a foreach
    params = current_params(status) if args.params else {}
    with modify_yaml("dvc.lock") as lock:
        for name in status:
            if params.get(name):
                lock["stages"][name]["params"] = params[name]
            for dep in lock["stages"][name]["deps"]:
                if dep["path"].startswith(FINGERPRINTS):
                    if dep["path"] not in recorded:
                        data = Path(dep["path"]).read_bytes()
                        recorded[dep["path"]] = hashlib.md5(data).hexdigest(), len(data)
                    dep["md5"], dep["size"] = recorded[dep["path"]]
    print("re-recorded; `dvc status` should now be clean" + (" for those stages" if args.stages else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
