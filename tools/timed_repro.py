"""`dvc repro` with a clock: where the pipeline's time goes, stage by stage, for the report.

`make repro` runs this instead of a bare `dvc repro`. It passes its arguments to `dvc repro`,
echoes dvc's output as it comes, and stamps each line with the time it arrived: a stage's wall time
runs from dvc's "Running stage '<name>':" to its "Updating lock file" (the command plus dvc's
hashing of the outputs). The times go to `reports/stage_times.json`, merged with those already
there (a stage that did not run keeps the time of its last run; a stage dvc.yaml no longer defines
loses it), with a record of this run: when, how long in all, which stages ran, on how many cores.
The file is written after every stage, so a run stopped midway (exit_code null) keeps the times of
the stages it finished. If any stage ran, the report is rendered once
more, so its provenance section shows this run's times (the report stage reads the file); after a
run of named stages, only if the report was among them (else `dvc repro report` would run every
other stale stage, unclocked).

With `--jobs N` (what `make repro` passes: the CPU count, 2 on our machine) the stages run
through tools/parallel_repro.py, which runs up to N single-threaded stages at once; each stage is
then clocked from its start to its lock update as before, so on 2 cores the stages' times sum to
more than the run's wall time (the record's `seconds`). parallel_repro runs the commands on a Dask cluster: a LocalCluster of
this machine, listening on loopback only (`--dashboard HOST:PORT` opens its dashboard wider, with
a warning), or with `--address tls://host:port` (which implies the parallel run) a running one: a
plain tcp:// address on another machine is refused before anything runs, unless `--insecure`.

    python -m tools.timed_repro [--jobs N] [--dashboard HOST:PORT]
                                [--address tls://host:port [--insecure]] [dvc repro arguments...]
"""

from __future__ import annotations

import datetime as dt
import json
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from pipeline.io import write_json  # atomic: temp file, then rename

STAGE_TIMES = Path("reports/stage_times.json")
RUNNING = re.compile(r"^Running stage '(?P<stage>[^']+)':")
DONE = "Updating lock file"


def stage_seconds(stamped_lines: Iterable[tuple[float, str]]) -> dict[str, float]:
    """Wall seconds of each stage that ran to the end, from dvc repro's output lines stamped with
    the (monotonic) time each arrived. A stage that failed (no lock update) has no entry."""
    seconds, current = {}, None
    for stamp, line in stamped_lines:
        started = RUNNING.match(line)
        if started:
            current = (started["stage"], stamp)
        elif current is not None and line.startswith(DONE):
            seconds[current[0]] = stamp - current[1]
            current = None
    return seconds


def merged_times(previous: dict, ran: dict[str, float], run: dict,
                 current: set[str] | None = None) -> dict:
    """`previous` (the file's content, or {}) updated with this run: each stage that ran gets its
    new time and the run's start; the others keep theirs, except those not among `current` (the
    stages dvc.yaml defines now, when given): a renamed or dropped stage's old time goes."""
    stages = {name: entry for name, entry in (previous.get("stages") or {}).items()
              if current is None or name in current}
    for name, seconds in ran.items():
        stages[name] = {"seconds": round(seconds, 1), "run_started": run["started"]}
    return {"stages": dict(sorted(stages.items())), "last_run": run}


def current_stages() -> set[str]:
    """The names of the stages dvc.yaml defines now (foreach items as `stage@item`)."""
    from dvc.repo import Repo  # here: the clock tool itself needs no dvc import to be tested

    return {stage.addressing for stage in Repo().index.stages}


def run_dvc(args: list[str], on_stage_done: Callable[[list[tuple[float, str]]], None] | None = None
            ) -> tuple[int, list[tuple[float, str]]]:
    """`dvc <args>`, its output echoed and stamped line by line; (exit code, stamped lines).
    `on_stage_done(stamped lines so far)` runs after each lock update (a stage finished)."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}  # dvc's own lines must arrive when printed
    stamped = []  # dvc of the Python running this, whatever PATH says
    with subprocess.Popen([sys.executable, "-m", "dvc", *args], stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT,
                          text=True, bufsize=1, env=env) as process:
        for line in process.stdout:
            stamped.append((time.monotonic(), line))
            sys.stdout.write(line)
            sys.stdout.flush()
            if on_stage_done is not None and line.startswith(DONE):
                on_stage_done(stamped)
    return process.returncode, stamped


def split_jobs(args: list[str]) -> tuple[int, list[str]]:
    """(--jobs N, the other arguments): ["--jobs", "2", "-f"] -> (2, ["-f"]); 1 without it."""
    if "--jobs" not in args:
        return 1, list(args)
    at = args.index("--jobs")
    try:
        jobs = int(args[at + 1])
    except (IndexError, ValueError):
        raise SystemExit("timed_repro: --jobs needs a whole number") from None
    if jobs < 1:
        raise SystemExit("timed_repro: --jobs must be >= 1")
    return jobs, args[:at] + args[at + 2:]


def split_value(args: list[str], flag: str, what: str) -> tuple[str | None, list[str]]:
    """(the value after `flag`, the other arguments): split_value(["--address", "tls://h:8786",
    "-f"], "--address", ...) -> ("tls://h:8786", ["-f"]); None without it."""
    if flag not in args:
        return None, list(args)
    at = args.index(flag)
    if at + 1 >= len(args):
        raise SystemExit(f"timed_repro: {flag} needs {what}")
    return args[at + 1], args[:at] + args[at + 2:]


def split_address(args: list[str]) -> tuple[str | None, list[str]]:
    """(--address A, the other arguments); None without it."""
    return split_value(args, "--address", "a scheduler address, tls://host:port")


def split_flag(args: list[str], flag: str) -> tuple[bool, list[str]]:
    """(whether `flag` is there, the other arguments)."""
    return flag in args, [arg for arg in args if arg != flag]


def run_parallel(args: list[str], jobs: int, on_stage_done: Callable[[str, float], None],
                 address: str | None = None, insecure: bool = False,
                 dashboard: str | None = None) -> tuple[int, dict[str, float]]:
    """tools/parallel_repro.py's run of `args`: stage names, -f / --force, -s / --single-item."""
    from tools import parallel_repro

    flags = {arg for arg in args if arg.startswith("-")}
    known = {"-f", "--force", "-s", "--single-item"}
    if flags - known:
        raise SystemExit(f"timed_repro --jobs {jobs}: only stage names, -f and -s, not "
                         f"{' '.join(sorted(flags - known))} (run without --jobs)")
    targets = [arg for arg in args if not arg.startswith("-")]
    try:
        return parallel_repro.run_stages(targets, force=bool(flags & {"-f", "--force"}), jobs=jobs,
                                         single_item=bool(flags & {"-s", "--single-item"}),
                                         on_stage_done=on_stage_done, address=address,
                                         insecure=insecure, dashboard=dashboard)
    except parallel_repro.SetupError as error:
        raise SystemExit(f"timed_repro: {error}") from None


def refuse_address(address: str | None, insecure: bool) -> None:
    """Stop before anything is written or run if `address` is one parallel_repro refuses (plain
    TCP to another machine without --insecure, TLS without certificates)."""
    if address is None:
        return
    from tools import parallel_repro

    try:
        parallel_repro.check_address(address, insecure)
    except parallel_repro.SetupError as error:
        raise SystemExit(f"timed_repro: {error}") from None


def main(argv: list[str] | None = None) -> int:
    jobs, args = split_jobs(sys.argv[1:] if argv is None else argv)
    address, args = split_address(args)
    dashboard, args = split_value(args, "--dashboard", "where the dashboard listens, HOST:PORT")
    insecure, args = split_flag(args, "--insecure")
    refuse_address(address, insecure)
    parallel = jobs > 1 or address is not None or dashboard is not None
    started = dt.datetime.now(dt.UTC)
    clock = time.monotonic()
    if not STAGE_TIMES.exists():  # the report stage reads it: a first run needs it in place
        write_json({"stages": {}, "last_run": None}, STAGE_TIMES)
    previous = json.loads(STAGE_TIMES.read_text())
    current = current_stages()

    command = " ".join(["tools/parallel_repro.py", "--jobs", str(jobs),
                        *(["--address", address] if address else []),
                        *(["--insecure"] if insecure and address else []), *args] if parallel
                       else ["dvc", "repro", *args])

    def record(ran: dict[str, float], code: int | None) -> dict[str, float]:
        """Write the times so far; a run stopped before dvc exits keeps exit_code None."""
        if ran:
            run = {"started": started.strftime("%Y-%m-%d %H:%M:%S UTC"),
                   "seconds": round(time.monotonic() - clock, 1),
                   "command": command, "exit_code": code, "jobs": jobs,
                   "stages_run": sorted(ran), "cpu_count": os.cpu_count()}
            write_json(merged_times(previous, ran, run, current), STAGE_TIMES)
        return ran

    if not parallel:
        code, stamped = run_dvc(["repro", *args], lambda lines: record(stage_seconds(lines), None))
        ran = record(stage_seconds(stamped), code)
    else:
        ran_so_far: dict[str, float] = {}

        def on_stage_done(name: str, seconds: float) -> None:
            ran_so_far[name] = seconds
            record(ran_so_far, None)

        code, ran = run_parallel(args, jobs, on_stage_done, address, insecure, dashboard)
        record(ran, code)
    if not ran:
        return code
    print(f"timed_repro: {len(ran)} stages in {time.monotonic() - clock:.0f} s; times in {STAGE_TIMES}")
    if code == 0 and rerender_report(args, ran):  # the page shows the times of the run that just ended
        code, _ = run_dvc(["repro", "report"])
    return code


def rerender_report(args: list[str], ran: dict[str, float]) -> bool:
    """Whether to render the report again after a successful run: after a whole-pipeline run (no
    stage named in `args`), where only the report is then stale, or when the report itself ran.
    After `timed_repro.py evaluate_ynet` with other stages stale, `dvc repro report` would run
    all of those too, unclocked."""
    named_stages = [arg for arg in args if not arg.startswith("-")]
    return not named_stages or "report" in ran


if __name__ == "__main__":
    sys.exit(main())
