"""Run the frozen stages of a study (studies/dvc.yaml): the runs the report reads that `make repro`
and `dvc repro` never run nor overwrite.

DVC never runs a frozen stage, which is what keeps a study out of the main pipeline; here the
freeze is lifted in memory for the stages named, each is run when its record or inputs changed
(as `dvc repro --single-item` would: a finished run is skipped, a stopped training resumes from
its scratch folder), its lock entry is written, and the stage stays frozen in dvc.yaml. Stages run
one after the other, in the order given (a target may be a file, a stage or a glob of stages).

    python -m tools.run_study studies/dvc.yaml
    python -m tools.run_study 'studies/dvc.yaml:short_term_seed@sdd-*' --dry
    python -m tools.run_study studies/dvc.yaml --relock-code   # after a refactor: see below

`--relock-code` runs nothing: for the stages whose only change is their code fingerprint it
re-records the fingerprint in the study's lock file, as tools/relock_fingerprints.py does for
dvc.lock (whose `dvc status` does not look into frozen stages). Only for a change that cannot move
a study's record (a refactor, a docstring), and only with the evidence; otherwise run the study.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import time
from pathlib import Path


def study_stages(repo, targets: list[str]) -> list:
    """The frozen stages the targets name, in order, each once; a non-frozen one is refused (it
    belongs to a pipeline that `dvc repro` runs)."""
    chosen, seen = [], set()
    for target in targets:
        glob = "*" in target or "?" in target
        for stage in repo.stage.collect(target, glob=glob):
            if stage.addressing in seen:
                continue
            if not stage.frozen:
                raise SystemExit(f"run_study: {stage.addressing} is not frozen: run it with "
                                 "`dvc repro`, not as a study")
            seen.add(stage.addressing)
            chosen.append(stage)
    return chosen


def relock_code(stages: list, root: Path) -> int:
    """Re-record the code fingerprints of `stages` (frozen, lifted in memory) whose one change is
    that fingerprint; refuse, naming them, where any has another change."""
    from dvc.utils.serialize import modify_yaml
    from tools.relock_fingerprints import FINGERPRINTS, fingerprint_only

    stale, must_run = [], []
    for stage in stages:
        stage.frozen = False
        try:
            changes = stage.status().get(stage.addressing, [])
        finally:
            stage.frozen = True
        if changes:
            (stale if fingerprint_only(changes) else must_run).append(stage)
    if must_run:
        print("these studies changed beyond their code fingerprint and must run:\n  "
              + "\n  ".join(stage.addressing for stage in must_run))
        return 1
    if not stale:
        print("nothing to re-record: every study's code fingerprint is as recorded")
        return 0
    by_lock: dict[Path, list] = {}
    for stage in stale:
        by_lock.setdefault(Path(stage.dvcfile.path).with_suffix(".lock"), []).append(stage)
    for lock_path, locked in by_lock.items():
        with modify_yaml(str(lock_path)) as lock:
            for stage in locked:
                for dep in lock["stages"][stage.addressing.rpartition(":")[2]]["deps"]:
                    if dep["path"].startswith(FINGERPRINTS):
                        data = (root / dep["path"]).read_bytes()
                        dep["md5"], dep["size"] = hashlib.md5(data).hexdigest(), len(data)
    print(f"re-recorded the code fingerprints of {len(stale)} studies: "
          + ", ".join(stage.addressing for stage in stale))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("targets", nargs="+", help="study dvc.yaml files, stages or stage globs")
    parser.add_argument("--dry", action="store_true", help="list what would run, run nothing")
    parser.add_argument("--relock-code", action="store_true",
                        help="run nothing; re-record the code fingerprints of studies whose only "
                             "change they are (a refactor: see the docstring)")
    args = parser.parse_args(argv)
    from dvc.repo import Repo, lock_repo

    repo = Repo()
    with lock_repo(repo):
        stages = study_stages(repo, args.targets)
        if args.relock_code:
            return relock_code(stages, Path(repo.root_dir))
        for stage in stages:
            stage.frozen = False
            try:
                changed = stage.changed()
                print(f"{stage.addressing}: {'runs' if changed else 'up to date'}", flush=True)
                if args.dry or not changed:
                    continue
                started = time.perf_counter()
                stage.run()
                stage.dump(update_pipeline=False)  # the lock entry; dvc.yaml keeps `frozen`
                print(f"{stage.addressing}: done in {time.perf_counter() - started:.0f} s", flush=True)
            finally:
                stage.frozen = True
    return 0


if __name__ == "__main__":
    sys.exit(main())
