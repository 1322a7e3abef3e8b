"""`dvc repro` that runs two single-threaded stages at once: the second core is not left idle.

`dvc repro` runs one stage at a time. In the `cpu` profile most of the stage time is
single-threaded (the baselines, the segmentation, every Y-net training, the short-term Y-net
scoring: README "Quick start"), so one at a time the other core idles. Here DVC's own stage objects do everything DVC would (the staleness check, removing the
outputs, the run cache, hashing, committing, the lock update), all in this one process and one at
a time; only the stages' commands run as child processes, up to `jobs` of them at once when every
one of them is single-threaded, otherwise alone. A stage starts only once every stage it depends
on has finished, as with `dvc repro`; outputs and `dvc.lock` are therefore a serial run's.

A stage counts as single-threaded when its dvc.yaml `meta: {threads: N}` says 1 (the data steps,
which no param gives a thread count) or, without one, when every `threads` key (or `eval_threads`
and the like) among its declared params, inside a declared section too, is 1; one that declares
none, or another value, runs alone; in the `cpu` profile only the long-term Y-net scoring, the
semantic maps, the animations and the report do.

    python tools/parallel_repro.py [--jobs N] [-f] [-s] [targets...]
"""

from __future__ import annotations

import argparse
import codecs
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

ALONE, SHARED = "alone", "shared"  # how a stage's command may run: by itself or beside others
PROGRESS_EVERY_S = 30.0  # how often a concurrent stage's progress bar (lines ended by \r) is echoed


def thread_counts(params: Mapping[str, object]) -> list[object]:
    """The value of every `threads` (or `..._threads`) key among a stage's declared params,
    sections included: {"train_baseline": {"seed": 0, "threads": 1}, "eval.cpu": {"threads": 2},
    "short_term_models.cpu.eval_threads": 2} -> [1, 2, 2]."""
    counts = []
    for key, value in params.items():
        if isinstance(value, Mapping):
            counts += thread_counts(value)
        elif str(key).split(".")[-1].endswith("threads"):
            counts.append(value)
    return counts


def sharing(params: Mapping[str, object]) -> str:
    """SHARED if every `threads` key the stage declares is 1 (and it declares one), else ALONE."""
    counts = thread_counts(params)
    return SHARED if counts and all(count == 1 for count in counts) else ALONE


def can_start(kind: str, running: Iterable[str], jobs: int) -> bool:
    """Whether a stage of `kind` may start beside the stages running now (their kinds)."""
    running = list(running)
    if not running:
        return True
    return kind == SHARED and len(running) < jobs and all(other == SHARED for other in running)


def ready(order: list[str], upstream: Mapping[str, set[str]], finished: set[str],
          started: set[str]) -> list[str]:
    """The stages of `order` not started yet whose upstream stages have all finished, in order."""
    return [name for name in order
            if name not in started and upstream.get(name, set()) <= finished]


@dataclass
class Running:
    """A stage's command running as a child process (the stage's name is its key in `running`)."""
    process: subprocess.Popen
    started: float
    echo: threading.Thread
    commands_left: list[str] = field(default_factory=list)
    signalled: bool = False  # the stop signal was passed on (once: a second one kills a training)


def echo_output(name: str, stream, prefix: bool) -> None:
    """Copy a child's output to ours; beside other stages each line carries `[stage]` and a
    progress bar's redraws (lines ended by \\r) are shown every PROGRESS_EVERY_S seconds only."""
    last_progress, pending = 0.0, ""
    decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")  # a character may span reads
    while chunk := stream.read1(65536):
        text = pending + decoder.decode(chunk)
        if not prefix:
            sys.stdout.write(text)
            sys.stdout.flush()
            pending = ""
            continue
        pieces = text.replace("\r\n", "\n").split("\n")
        pending = pieces.pop()
        for line in pieces:
            sys.stdout.write(f"[{name}] {line.split(chr(13))[-1]}\n")
        if "\r" in pending:  # a progress redraw: keep its latest state
            *_, pending = pending.split("\r")
            if time.monotonic() - last_progress > PROGRESS_EVERY_S and pending.strip():
                sys.stdout.write(f"[{name}] {pending}\n")
                last_progress = time.monotonic()
        sys.stdout.flush()
    if pending.strip():
        sys.stdout.write(f"[{name}] {pending}\n" if prefix else pending)
        sys.stdout.flush()


def run_stages(targets: list[str], force: bool = False, jobs: int = 2, single_item: bool = False,
               on_stage_done: Callable[[str, float], None] | None = None,
               root: str = ".") -> tuple[int, dict[str, float]]:
    """Reproduce `targets` (all stages if none) and what they depend on (with `single_item`, the
    targets alone, as `dvc repro --single-item`); (exit code, wall seconds of each stage that
    ran). Stops starting stages after the first failure and returns 1 once the running ones end;
    SIGINT / SIGTERM are passed to the running commands (their trainings save a resumable
    checkpoint) and end the run with 130 / 143."""
    from dvc.repo import Repo, lock_repo
    from dvc.repo.reproduce import collect_stages, plan_repro
    from dvc.stage.cache import RunCacheNotFoundError
    from dvc.stage.run import _enforce_cmd_list, _make_cmd, get_executable, prepare_kwargs

    repo = Repo(root)
    with lock_repo(repo):
        graph = repo.index.graph
        chosen = collect_stages(repo, targets) if targets else None
        planned = chosen if single_item and chosen else plan_repro(graph, chosen)
        stages = {stage.addressing: stage for stage in planned if stage.cmd and not stage.frozen}
        order = list(stages)
        # dvc's graph has an edge from a stage to each stage that produces one of its deps
        upstream = {name: {dep.addressing for dep in graph.successors(stage)} & set(stages)
                    for name, stage in stages.items()}
        kinds = {name: sharing(declared_threads(stage)) for name, stage in stages.items()}
    executable = get_executable()

    finished, started, seconds = set(), set(), {}
    running: dict[str, Running] = {}
    failed, stop_signal = False, None

    def on_signal(signum, _frame):
        # only noted here: the loop passes it on, so a command started while the handler ran
        # (Popen returned, not yet in `running`) gets it too, and none gets it twice
        nonlocal stop_signal
        stop_signal = signum

    def pass_on_stop_signal() -> None:
        if stop_signal is None:
            return
        for child in running.values():
            if not child.signalled:
                child.signalled = True
                # to the command's process group: where /bin/sh is dash (no SHELL set, as in
                # CI) the shell forks the command instead of exec'ing it, and a signal to the
                # shell alone would never reach the training
                try:
                    os.killpg(child.process.pid, stop_signal)
                except ProcessLookupError:
                    pass  # ended already; poll() will say how

    previous_handlers = {sig: signal.signal(sig, on_signal)
                         for sig in (signal.SIGINT, signal.SIGTERM)}

    def launch(name: str, command: str, commands_left: list[str], since: float):
        stage = stages[name]
        kwargs = prepare_kwargs(stage)
        print(f"> {command}", flush=True)
        # its own process group: Ctrl-C reaches it once, passed on to the group by
        # pass_on_stop_signal (a second signal would stop a training without its checkpoint)
        process = subprocess.Popen(_make_cmd(executable, command), stdout=subprocess.PIPE,
                                   stderr=subprocess.STDOUT, start_new_session=True, **kwargs)
        echo = threading.Thread(target=echo_output, args=(name, process.stdout, jobs > 1),
                                daemon=True)
        echo.start()
        running[name] = Running(process, since, echo, commands_left)

    def start(name: str) -> None:
        """DVC's part before the command (in this process), then the command itself."""
        stage = stages[name]
        with lock_repo(repo):
            if not force and not stage.changed():
                print(f"Stage '{name}' didn't change, skipping", flush=True)
                finished.add(name)
                return
            print(f"Running stage '{name}':", flush=True)
            since = time.monotonic()
            stage.remove_outs(ignore_remove=False, force=False)
            if not force:
                try:
                    stage.repo.stage_cache.restore(stage)
                    commit(name, since)
                    return
                except RunCacheNotFoundError:
                    stage.save_deps()
        first, *rest = _enforce_cmd_list(stage.cmd)
        launch(name, first, rest, since)

    def commit(name: str, since: float) -> None:
        stage = stages[name]
        with lock_repo(repo):
            stage.save()
            stage.commit()
            stage.dump(update_pipeline=False)
        seconds[name] = time.monotonic() - since
        finished.add(name)
        print(f"Updating lock file 'dvc.lock' ({name}: {seconds[name]:.0f} s)", flush=True)
        if on_stage_done is not None:
            on_stage_done(name, seconds[name])

    try:
        while True:
            if not failed and stop_signal is None:
                for name in ready(order, upstream, finished, started):
                    if not can_start(kinds[name], (kinds[other] for other in running), jobs):
                        continue  # a later single-threaded stage may still fit beside
                    started.add(name)
                    start(name)
            if not running:
                if failed or stop_signal is not None or len(finished) == len(order):
                    break
                if not ready(order, upstream, finished, started):
                    break  # nothing left that can start (a failure upstream)
                continue
            time.sleep(0.2)
            pass_on_stop_signal()
            for name, child in list(running.items()):
                code = child.process.poll()
                if code is None:
                    continue
                child.echo.join()
                del running[name]
                if code != 0:
                    print(f"ERROR: failed to reproduce '{name}': exited with {code}", flush=True)
                    failed = True
                elif child.commands_left:
                    if stop_signal is None:
                        launch(name, child.commands_left[0], child.commands_left[1:],
                               child.started)
                    # stopped between two of its commands: unfinished, so not locked
                else:
                    commit(name, child.started)
    finally:
        for sig, handler in previous_handlers.items():
            signal.signal(sig, handler)
    if stop_signal is not None:
        return 128 + stop_signal, seconds
    return (1 if failed else 0), seconds


def declared_threads(stage) -> dict[str, object]:
    """What `sharing` reads of a stage: its dvc.yaml `meta: {threads: N}` if it has one (what a
    data step says of itself; DVC ignores `meta`, and a data step may declare another stage's
    `threads` param to pass it on, as ynet_slot_scoring does), else its declared params."""
    meta = stage.meta if isinstance(stage.meta, Mapping) else {}
    return {"meta.threads": meta["threads"]} if "threads" in meta else params_of(stage)


def params_of(stage) -> dict[str, object]:
    """The values of the params keys `stage` declares (all its params files)."""
    from dvc.dependency.param import ParamsDependency

    values = {}
    for dep in stage.deps:
        if isinstance(dep, ParamsDependency):
            values.update(dep.read_params())
    return values


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("targets", nargs="*", help="stages to reproduce (default: all)")
    parser.add_argument("-f", "--force", action="store_true", help="run even unchanged stages")
    parser.add_argument("-s", "--single-item", action="store_true",
                        help="the targets alone, not what they depend on")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="most single-threaded stages at once (default: the CPU count)")
    args = parser.parse_args(argv)
    code, seconds = run_stages(args.targets, force=args.force, jobs=args.jobs,
                               single_item=args.single_item)
    print(f"parallel_repro: {len(seconds)} stages, exit {code}")
    return code


if __name__ == "__main__":
    sys.exit(main())
