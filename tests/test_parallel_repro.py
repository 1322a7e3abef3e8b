"""tools/parallel_repro.py on its default cluster (a LocalCluster of this machine): single-threaded
stages run two at a time, with the lock a serial `dvc repro` would write, and a rerun after a stop
goes on from what the stopped run made. The integration tests build a four-stage DVC project in a
temp folder: prep -> (left, right) -> join, where left and right record when they ran. They wait
on events, not on the clock: two stages that may run side by side each wait until the other has
started, so they overlap however slow the machine; a stopped command waits for the signal."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import dvc  # noqa: F401  (now, not first inside a capsys test: dvc's log handlers keep the
import pytest  # sys.stdout of dvc's import, and a test's capsys stream is closed after it)
import yaml

from tools import parallel_repro
from tools.parallel_repro import ALONE, SHARED

PYTHON = sys.executable
DVC = [PYTHON, "-m", "dvc"]  # the dvc of the venv running the tests, whatever PATH says
# a stage of the fixture: argv out, how, patience. "meet" (the default): note its start in
# started/ and wait until another stage has started too, or `patience` seconds (so a stage that
# must run alone ends soon); "fail": meet, then exit 3; "wait": a minute unless a signal ends it;
# "interrupt": send the runner SIGINT (as Ctrl-C would) and wait until the runner passes it on,
# which ends it; "interrupt-but-finish": the same, but it notes the signal and then finishes
STEP = textwrap.dedent("""\
    import json, os, pathlib, signal, sys, time
    out, how, patience = sys.argv[1], sys.argv[2], float(sys.argv[3])
    start = time.time()
    started = pathlib.Path("started")
    started.mkdir(exist_ok=True)
    (started / out).touch()
    passed_on = []
    if how == "interrupt-but-finish":
        signal.signal(signal.SIGINT, lambda *_: passed_on.append(1))
    if how.startswith("interrupt"):
        os.kill(int(os.environ["RUNNER_PID"]), signal.SIGINT)
        deadline = time.monotonic() + 30
        while not passed_on and time.monotonic() < deadline:
            time.sleep(0.05)  # "interrupt": the runner's SIGINT ends it here
    elif how == "wait":
        time.sleep(60)
    else:
        deadline = time.monotonic() + patience
        while len(list(started.iterdir())) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
    if how == "fail":
        sys.exit(3)
    json.dump({"start": start, "end": time.time()}, open(out, "w"))
    """)


def test_a_stage_shares_the_machine_only_if_every_threads_key_it_declares_is_one():
    assert parallel_repro.sharing({"train_baseline.threads": 1, "profile": "cpu"}) == SHARED
    assert parallel_repro.sharing({"train_baseline": {"seed": 0, "threads": 1}}) == SHARED
    two_sections = {"train_baseline": {"threads": 1}, "eval.cpu": {"threads": 2}}
    assert parallel_repro.sharing(two_sections) == ALONE
    assert parallel_repro.sharing({"profile": "cpu"}) == ALONE  # says nothing: runs alone
    assert parallel_repro.sharing({"short_term_models.cpu.eval_threads": 2}) == ALONE
    assert parallel_repro.sharing({"ynet.cpu": {"threads": 1}, "stm.cpu.eval_threads": 1}) == SHARED
    assert parallel_repro.sharing({"epochs": {5: 3, 10: 3}, "threads": 1}) == SHARED  # int keys


def test_a_single_threaded_stage_asks_for_one_thread_and_another_for_a_whole_worker():
    assert parallel_repro.stage_resources(SHARED, None, None, 2, False) == {"threads": 1}
    assert parallel_repro.stage_resources(ALONE, None, None, 2, False) == {"threads": 2}
    assert parallel_repro.stage_resources(ALONE, "cpu", 8, 4, True) == {"threads": 4,
                                                                        "memory_gb": 8.0}


def test_a_stage_is_ready_once_its_upstream_stages_finished():
    order = ["prep", "left", "right", "join"]
    upstream = {"left": {"prep"}, "right": {"prep"}, "join": {"left", "right"}}
    assert parallel_repro.ready(order, upstream, set(), set()) == ["prep"]
    assert parallel_repro.ready(order, upstream, {"prep"}, {"prep"}) == ["left", "right"]
    assert parallel_repro.ready(order, upstream, {"prep", "left"}, {"prep", "left", "right"}) == []
    assert parallel_repro.ready(order, upstream, {"prep", "left", "right"},
                                {"prep", "left", "right"}) == ["join"]


def make_project(root: Path, threads: int = 1, right: str = "", left: str = "",
                 right_meta: int | None = None, patience: float = 30) -> None:
    """`right`: "fail" (exits 3), "interrupt" (sends the runner SIGINT) or "interrupt-but-finish"
    (sends it, notes it, succeeds, and a second command follows), else it succeeds once it met
    left. `left`: "wait" sleeps a minute unless a signal ends it. `right_meta`: right declares no
    params but `meta: {threads: right_meta}`. `patience`: how long left and right wait for each
    other (short where they must not run together)."""
    subprocess.run([*DVC, "init", "--no-scm", "-q"], cwd=root, check=True)
    (root / "step.py").write_text(STEP)
    (root / "params.yaml").write_text(f"job:\n  threads: {threads}\n  other: 5\n")
    stages = {
        "prep": {"cmd": f"{PYTHON} -c \"open('prep.txt', 'w').write('x')\"",
                 "outs": ["prep.txt"]},
        "left": {"cmd": f"{PYTHON} step.py left.json {left or 'meet'} {patience}",
                 "deps": ["prep.txt", "step.py"], "params": ["job.threads"], "outs": ["left.json"]},
        "right": {"cmd": f"{PYTHON} step.py right.json {right or 'meet'} {patience}",
                  "deps": ["prep.txt", "step.py"], "params": ["job"], "outs": ["right.json"]},
        "join": {"cmd": f"{PYTHON} -c \"open('join.txt', 'w').write('y')\"",
                 "deps": ["left.json", "right.json"], "outs": ["join.txt"]},
    }
    if right_meta is not None:
        del stages["right"]["params"]
        stages["right"]["meta"] = {"threads": right_meta}
    if right == "interrupt-but-finish":
        stages["right"]["cmd"] = [stages["right"]["cmd"],
                                  f"{PYTHON} -c \"open('right.done', 'w').write('z')\""]
    (root / "dvc.yaml").write_text(yaml.safe_dump({"stages": stages}))


def forget_starts(root: Path) -> None:
    """Before another run whose stages must meet (or not) afresh."""
    for marker in (root / "started").glob("*"):
        marker.unlink()


def interval(root: Path, name: str) -> tuple[float, float]:
    record = json.loads((root / f"{name}.json").read_text())
    return record["start"], record["end"]


def overlap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    return a[0] < b[1] and b[0] < a[1]


@pytest.fixture
def project(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def clean(root: Path) -> bool:
    from dvc.repo import Repo

    return Repo(str(root)).status() == {}


def test_single_threaded_stages_run_together_and_the_lock_is_complete(project):
    make_project(project)
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert code == 0 and set(seconds) == {"prep", "left", "right", "join"}
    left, right = interval(project, "left"), interval(project, "right")
    assert overlap(left, right)
    first_right = right
    assert (project / "join.txt").stat().st_mtime >= max(left[1], right[1])
    assert clean(project)  # dvc status: every stage's lock entry matches, as after dvc repro
    lock = yaml.safe_load((project / "dvc.lock").read_text())
    assert set(lock["stages"]) == {"prep", "left", "right", "join"}
    assert lock["stages"]["right"]["params"]["params.yaml"]["job"] == {"threads": 1, "other": 5}

    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert (code, seconds) == (0, {})  # nothing changed: nothing runs

    (project / "params.yaml").write_text("job:\n  threads: 1\n  other: 6\n")  # only right reads it
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert code == 0 and set(seconds) == {"right", "join"} and clean(project)

    (project / "params.yaml").write_text("job:\n  threads: 1\n  other: 5\n")  # seen before
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert code == 0 and set(seconds) == {"right", "join"} and clean(project)
    assert interval(project, "right") == first_right  # restored from dvc's run cache, not rerun


def test_stages_with_more_threads_or_one_job_run_one_at_a_time(project):
    make_project(project, threads=2, patience=1.5)  # the first waits that long for the other
    assert parallel_repro.run_stages([], jobs=2, root=str(project))[0] == 0
    assert not overlap(interval(project, "left"), interval(project, "right"))
    forget_starts(project)
    code, seconds = parallel_repro.run_stages([], force=True, jobs=1, root=str(project))
    assert code == 0 and len(seconds) == 4
    assert not overlap(interval(project, "left"), interval(project, "right"))


def test_a_stage_meta_threads_decides_over_the_params_it_passes_on():
    class Stage:
        meta = {"threads": 1}

    params = {"eval.cpu": {"threads": 2}}
    assert parallel_repro.sharing(parallel_repro.declared_threads(Stage(), params)) == SHARED
    Stage.meta = None  # no meta: the params decide
    assert parallel_repro.sharing(parallel_repro.declared_threads(Stage(), params)) == ALONE


@pytest.mark.parametrize("threads", [1, 2])
def test_a_data_step_declares_its_threads_in_its_meta(project, threads):
    """A stage no param gives a thread count (a data step) says it in dvc.yaml's `meta`, which DVC
    ignores: the lock is complete and clean either way."""
    make_project(project, right_meta=threads, patience=30 if threads == 1 else 1.5)
    assert parallel_repro.run_stages([], jobs=2, root=str(project))[0] == 0
    assert overlap(interval(project, "left"), interval(project, "right")) == (threads == 1)
    assert clean(project)


def test_a_named_target_runs_with_what_it_depends_on_only(project):
    make_project(project, patience=1.5)  # left, run without right, waits no longer for it
    code, seconds = parallel_repro.run_stages(["left"], jobs=2, root=str(project))
    assert code == 0 and set(seconds) == {"prep", "left"}
    assert not (project / "right.json").exists()
    code, seconds = parallel_repro.run_stages(["left", "right"], force=True, single_item=True,
                                              jobs=2, root=str(project))
    assert code == 0 and set(seconds) == {"left", "right"}  # not prep: as dvc repro -f -s


def test_a_failed_stage_stops_the_run_and_is_not_locked(project, capsys):
    make_project(project, right="fail")
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert code == 1
    assert set(seconds) == {"prep", "left"}  # left, beside the failing right, still finished
    assert not (project / "join.txt").exists()
    lock = yaml.safe_load((project / "dvc.lock").read_text())
    assert set(lock["stages"]) == {"prep", "left"}
    assert "failed to reproduce 'right': exited with 3" in capsys.readouterr().out


# DVC runs a command through $SHELL, else /bin/sh. bash execs a lone command; dash (/bin/sh on
# Debian, and CI sets no SHELL) forks it, so the signal must go to the command's process group
SHELLS = pytest.mark.parametrize("shell", ["/bin/bash", "/bin/sh"])


@SHELLS
def test_a_signal_reaches_the_running_stages_and_ends_the_run(project, monkeypatch, shell):
    """Ctrl-C (or the session's SIGTERM): the commands get it (a training saves its checkpoint),
    nothing more starts, nothing half-done is locked, and the exit code says which signal."""
    monkeypatch.setenv("SHELL", shell)
    make_project(project, left="wait", right="interrupt")
    monkeypatch.setenv("RUNNER_PID", str(os.getpid()))  # inherited: no shell's ppid to rely on
    since = time.monotonic()
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert time.monotonic() - since < 30  # left, waiting a minute, was ended by the signal
    assert code == 130 and set(seconds) == {"prep"}
    assert not (project / "left.json").exists() and not (project / "join.txt").exists()


@SHELLS
def test_a_stage_stopped_between_its_commands_is_not_locked(project, monkeypatch, shell):
    monkeypatch.setenv("SHELL", shell)
    make_project(project, left="wait", right="interrupt-but-finish")
    monkeypatch.setenv("RUNNER_PID", str(os.getpid()))
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert code == 130 and set(seconds) == {"prep"}
    assert (project / "right.json").exists()  # its first command ignored the signal and finished
    assert not (project / "right.done").exists()  # the second never started
    assert set(yaml.safe_load((project / "dvc.lock").read_text())["stages"]) == {"prep"}


def test_a_stage_that_finishes_after_the_stop_starts_nothing_downstream(project, monkeypatch,
                                                                         capsys):
    """`first` passes the stop on to itself (as Ctrl-C would), notes it and finishes: it is locked,
    as it finished, but `then`, which its output makes ready, is not started: not even DVC's part
    of it (which would remove its outputs). Through bash, which execs the command: dash would
    fork it and die of the signal itself, failing the stage."""
    monkeypatch.setenv("SHELL", "/bin/bash")
    subprocess.run([*DVC, "init", "--no-scm", "-q"], cwd=project, check=True)
    (project / "step.py").write_text(STEP)
    (project / "dvc.yaml").write_text(yaml.safe_dump({"stages": {
        "first": {"cmd": f"{PYTHON} step.py first.json interrupt-but-finish 30",
                  "deps": ["step.py"], "outs": ["first.json"]},
        "then": {"cmd": f"{PYTHON} -c \"open('then.txt', 'w').write('t')\"",
                 "deps": ["first.json"], "outs": ["then.txt"]}}}))
    monkeypatch.setenv("RUNNER_PID", str(os.getpid()))
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert code == 130 and set(seconds) == {"first"}
    assert set(yaml.safe_load((project / "dvc.lock").read_text())["stages"]) == {"first"}
    assert "Running stage 'then'" not in capsys.readouterr().out
    assert not (project / parallel_repro.LOG_DIR / "then.log").exists()
    assert not (project / "then.txt").exists()


# a resumable training, as ours: steps within epochs, a checkpoint in a persist output after every
# epoch and, on SIGTERM, mid-epoch at the step it stopped at (then exit 143); each run notes the
# state it started from. Its first run waits at epoch 1, step 2 for the test to stop it
TRAINING = textwrap.dedent("""\
    import json, pathlib, signal, sys, time
    EPOCHS, STEPS, STOP_AT = 3, 4, [1, 2]
    stop = []
    signal.signal(signal.SIGTERM, lambda signum, _: stop.append(signum))
    checkpoint = pathlib.Path("checkpoints/last.json")
    checkpoint.parent.mkdir(exist_ok=True)
    first_run = not checkpoint.exists()
    state = {"epoch": 0, "step": 0, "done": []} if first_run else json.loads(checkpoint.read_text())
    with open("attempts.txt", "a") as attempts:
        attempts.write(json.dumps(state) + "\\n")
    done = state["done"]
    for epoch in range(state["epoch"], EPOCHS):
        for step in range(state["step"] if epoch == state["epoch"] else 0, STEPS):
            if first_run and [epoch, step] == STOP_AT:
                pathlib.Path("stop_me").touch()
                deadline = time.monotonic() + 30
                while not stop and time.monotonic() < deadline:
                    time.sleep(0.05)
            if stop:
                checkpoint.write_text(json.dumps({"epoch": epoch, "step": step, "done": done}))
                sys.exit(128 + stop[0])
            done.append([epoch, step])
        checkpoint.write_text(json.dumps({"epoch": epoch + 1, "step": 0, "done": done}))
    pathlib.Path("model.json").write_text(json.dumps(done))
    """)


def signal_when(path: Path, signum: int, timeout: float = 60) -> threading.Thread:
    """Send this process `signum` once `path` exists (as the session ending `make repro` would)."""
    driver = os.getpid()

    def wait_then_signal():
        deadline = time.monotonic() + timeout
        while not path.exists():
            if time.monotonic() > deadline:
                return
            time.sleep(0.05)
        os.kill(driver, signum)

    thread = threading.Thread(target=wait_then_signal, daemon=True)
    thread.start()
    return thread


@SHELLS
def test_a_rerun_after_a_stop_resumes_the_training_at_its_step(project, monkeypatch, shell):
    """`make repro` stopped mid-epoch, then run again: the stage's checkpoint folder (a persist
    output) is as the stop left it, and the training goes on at the step it stopped at; every step
    is trained exactly once."""
    monkeypatch.setenv("SHELL", shell)
    subprocess.run([*DVC, "init", "--no-scm", "-q"], cwd=project, check=True)
    (project / "train.py").write_text(TRAINING)
    (project / "dvc.yaml").write_text(yaml.safe_dump({"stages": {"train": {
        "cmd": f"{PYTHON} train.py", "deps": ["train.py"],
        "outs": ["model.json", {"checkpoints": {"persist": True}}]}}}))
    signal_when(project / "stop_me", signal.SIGTERM)
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    assert code == 128 + signal.SIGTERM and seconds == {}
    stopped = json.loads((project / "checkpoints" / "last.json").read_text())
    assert (stopped["epoch"], stopped["step"]) == (1, 2)  # mid-epoch

    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))  # the rerun
    assert code == 0 and set(seconds) == {"train"}
    attempts = [json.loads(line) for line in (project / "attempts.txt").read_text().splitlines()]
    assert attempts == [{"epoch": 0, "step": 0, "done": []}, stopped]  # from it, intact
    every_step = [[epoch, step] for epoch in range(3) for step in range(4)]
    assert json.loads((project / "model.json").read_text()) == every_step
    assert clean(project)


def test_output_beside_other_stages_is_labelled_and_progress_bars_thinned(capsys):
    """Each line gets its stage's name; a progress bar's redraws (\\r) are shown at most every
    PROGRESS_EVERY_S seconds; a character split between two reads comes out whole."""
    bar = "█".encode()
    chunks = [b"epoch 1: loss " + bar[:1], bar[1:] + b" 3.2\ntrain:  10%|\rtrain:  20%|",
              b"\rtrain:  25%|", b"\rtrain:  30%|\nepoch 2: loss 3.0\n"]

    class Stream:
        def read1(self, _size):
            return chunks.pop(0) if chunks else b""

    parallel_repro.echo_output("train@a", Stream(), prefix=True)
    assert capsys.readouterr().out.splitlines() == [
        "[train@a] epoch 1: loss █ 3.2",
        "[train@a] train:  20%|",  # the bar's latest state when first seen
        "[train@a] train:  30%|",  # 25 % came within 30 s of 20 %: not shown; a finished line is
        "[train@a] epoch 2: loss 3.0"]


LOCK = """\
schema: '2.0'
stages:
  # a comment DVC keeps
  prep:
    cmd: python -c "open('prep.txt', 'w')"
    outs:
    - path: prep.txt
      md5: 9dd4e461268c8034f5c8564e155c67a6
      size: 1
      ratio: 0.001
"""


def test_the_lock_just_dumped_is_not_parsed_again_and_the_same_bytes_are_written(tmp_path,
                                                                                 monkeypatch):
    from dvc.utils.serialize import _yaml, modify_yaml

    def updates(path: Path, with_cache: bool) -> int:
        parses = []
        real_parse, real_dump = _yaml.parse_yaml_for_update, _yaml._dump

        def counting(text, where):
            parses.append(where)
            return real_parse(text, where)

        monkeypatch.setattr(_yaml, "parse_yaml_for_update", counting)
        path.write_text(LOCK)
        with parallel_repro.lock_parsed_once() if with_cache else contextlib.nullcontext():
            for step in range(4):
                with modify_yaml(path) as data:
                    data["stages"][f"stage{step}"] = {"cmd": f"run {step}", "outs": [
                        {"path": f"out{step}", "md5": f"{step:032x}", "size": step, "ratio": 0.1}]}
                    data["stages"]["prep"]["outs"][0]["size"] = step
            path.write_text(path.read_text() + "# edited by hand\n")  # another text: parsed
            with modify_yaml(path) as data:
                data["stages"]["prep"]["cmd"] = "again"
            with pytest.raises(RuntimeError), modify_yaml(path) as data:  # an update that fails
                data["stages"]["prep"]["cmd"] = "half-done"
                raise RuntimeError
            with modify_yaml(path) as data:  # after it: parsed again, not the half-changed data
                data["stages"]["join"] = {"cmd": "join"}
            twin = path.with_name("twin-" + path.name)  # the same text in another file: parsed
            twin.write_text(path.read_text())
            with modify_yaml(twin) as data:
                data["stages"]["twin"] = {"cmd": "twin"}
        # put back as they were on entry
        assert (_yaml.parse_yaml_for_update, _yaml._dump) == (counting, real_dump)
        monkeypatch.setattr(_yaml, "parse_yaml_for_update", real_parse)
        return len(parses)

    plain, cached = tmp_path / "plain.lock", tmp_path / "cached.lock"
    assert updates(plain, with_cache=False) == 8
    assert updates(cached, with_cache=True) == 4  # first, hand-edited, after the failure, twin
    assert cached.read_bytes() == plain.read_bytes()
    twins = [(tmp_path / f"twin-{name}.lock").read_bytes() for name in ("plain", "cached")]
    assert twins[0] == twins[1]
    assert "half-done" not in cached.read_text() and "a comment DVC keeps" in cached.read_text()
