"""Run the frozen stages of a study (studies/dvc.yaml): the runs the report reads that `make repro`
and `dvc repro` never run nor overwrite.

DVC never runs a frozen stage, which is what keeps a study out of the main pipeline; here the
freeze is lifted in memory for the stages named, each is run when its record or inputs changed
(as `dvc repro --single-item` would: a finished run is skipped, a stopped training resumes from
its scratch folder), its lock entry is written, and the stage stays frozen in dvc.yaml. Stages run
one after the other, in the order given (a target may be a file, a stage or a glob of stages).

    python tools/run_study.py studies/dvc.yaml
    python tools/run_study.py 'studies/dvc.yaml:short_term_seed@sdd-*' --dry
"""

from __future__ import annotations

import argparse
import sys
import time


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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("targets", nargs="+", help="study dvc.yaml files, stages or stage globs")
    parser.add_argument("--dry", action="store_true", help="list what would run, run nothing")
    args = parser.parse_args(argv)
    from dvc.repo import Repo, lock_repo

    repo = Repo()
    with lock_repo(repo):
        stages = study_stages(repo, args.targets)
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
