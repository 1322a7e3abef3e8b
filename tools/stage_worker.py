"""What a Dask worker does for tools/parallel_repro.py: run a stage's commands, stop them, and say
which project it sees. Only the standard library and `distributed`: parallel_repro ships these
functions to the workers by value (cloudpickle), so a worker needs the project's venv on its
PATH, not tools/ on its sys.path.

A worker runs a stage's commands as today's runner did: through DVC's shell line, each in its own
process group (a Ctrl-C in the driver's terminal must not reach a training twice: once from the
terminal, once passed on), output appended to a log file on the shared filesystem that the driver
tails. `StageCommands`, a worker plugin, remembers which commands run on its worker so that
`stop_commands` (sent by the driver through `client.run`) can signal their process groups, and so
that a worker shutting down (a SLURM job's end) sends them SIGTERM: trainings then save a
resumable checkpoint before the task is retried elsewhere.

A worker killed outright (SIGKILL, the OOM killer) cannot pass anything on, and a command in its
own session would outlive it, running beside its own retry; on Linux each command therefore runs
under a supervisor that the kernel tells when the worker thread that started it dies
(`DIE_WITH_WORKER`) and that passes SIGTERM on to the command's whole process group, so the
command saves its checkpoint as on any SIGTERM, whichever shell DVC runs it through. A command that ends by a signal the driver did not send, or while
its worker shuts down, is a fault of the machine rather than of the stage (`interrupted`): the task
raises, so that Dask runs it again (`retries=1`) instead of the run failing.
"""

from __future__ import annotations

import hashlib
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

from distributed import WorkerPlugin, get_worker

PLUGIN_NAME = "ynet-stage-commands"
# `python -c DIE_WITH_WORKER <worker pid> argv...`: a small supervisor that asks the kernel for
# SIGUSR1 once the thread that started it dies (prctl PR_SET_PDEATHSIG), then runs the command as
# its child in its own process group. The kernel's signal reaches only the supervisor, and DVC's
# shell may fork the command instead of exec'ing it (dash, /bin/sh on Debian, does), so the
# supervisor passes the worker's death on as SIGTERM to the whole group: shell and command alike.
# It ignores SIGTERM and SIGINT itself (the driver's stop reaches the group, the command among
# it) and exits with the command's code (128 + N for a signal, as a shell does).
# A launcher rather than a preexec_fn, which is not safe in a process with threads (a worker).
DIE_WITH_WORKER = """\
import ctypes, os, signal, sys
worker, argv = int(sys.argv[1]), sys.argv[2:]
signal.signal(signal.SIGTERM, signal.SIG_IGN)
signal.signal(signal.SIGINT, signal.SIG_IGN)
signal.signal(signal.SIGUSR1, lambda *_: os.killpg(0, signal.SIGTERM))
ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGUSR1)
if os.getppid() != worker:
    sys.exit(143)
child = os.fork()
if child == 0:
    for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGUSR1):
        signal.signal(signum, signal.SIG_DFL)
    os.execvp(argv[0], argv)
code = os.waitstatus_to_exitcode(os.waitpid(child, 0)[1])
sys.exit(128 - code if code < 0 else code)
"""
# a command's exit code that says it was killed, through a shell that forked it (dash does), or
# a training that saved its checkpoint on SIGTERM (exit 143)
KILLED_CODES = {128 + signal.SIGKILL, 128 + signal.SIGTERM}


class CommandInterrupted(RuntimeError):
    """A stage command ended by its machine, not by its own failure: raised so Dask retries it."""


class StageCommands(WorkerPlugin):
    """Per worker: the stage commands running there (pid -> Popen) and the stop signal, once sent.
    parallel_repro registers a fresh one at the start of every run, so a stop is per run."""

    name = PLUGIN_NAME

    def __init__(self):
        self.running: dict[int, subprocess.Popen] = {}
        self.stopping: int | None = None
        self.leaving = False  # the worker shuts down: what its commands end with is retried

    def setup(self, worker):
        self.running, self.stopping, self.leaving = {}, None, False

    def teardown(self, worker):
        self.leaving = True
        signal_groups(self.running.values(), signal.SIGTERM)


def signal_groups(processes, signum: int) -> int:
    """Send `signum` to each process's group (DVC's shell may fork the command instead of
    exec'ing it: dash does); how many were still there."""
    sent = 0
    for process in list(processes):
        try:
            os.killpg(process.pid, signum)
            sent += 1
        except ProcessLookupError:
            pass  # ended already
    return sent


def interrupted(code: int, stopping: int | None, leaving: bool) -> bool:
    """Whether a command's exit `code` is its machine's doing, to be retried: killed by a signal
    the driver did not send (its worker's machine going down, the OOM killer), or ended while its
    worker was shutting down. The driver's stop, and any other exit, are the stage's own."""
    if code == 0 or stopping is not None:
        return False
    return leaving or code < 0 or code in KILLED_CODES


def launcher(argv: list[str]) -> list[str]:
    """`argv` behind DIE_WITH_WORKER where the kernel offers it (Linux), else as it is."""
    if not sys.platform.startswith("linux"):
        return argv
    return [sys.executable, "-c", DIE_WITH_WORKER, str(os.getpid()), *argv]


def run_commands(commands: list[tuple[str, list[str]]], cwd: str, env: dict[str, str],
                 log_path: str, gpu: bool) -> dict:
    """A Dask task: run a stage's commands ((shown line, argv) each) one after the other, output
    appended to `log_path`; stops at the first that fails or once a stop signal came, and raises
    CommandInterrupted if its machine ended it (`interrupted`). The command sees only the worker's
    GPU (its CUDA_VISIBLE_DEVICES) if the stage asked for one, else none."""
    worker = get_worker()
    commands_plugin = worker.plugins[PLUGIN_NAME]
    visible = os.environ.get("CUDA_VISIBLE_DEVICES", "") if gpu else ""
    full_env = {**os.environ, **env, "PYTHONUNBUFFERED": "1", "CUDA_VISIBLE_DEVICES": visible}
    result = {"code": 0, "complete": False, "worker": worker.address, "host": socket.gethostname(),
              "cuda_visible_devices": visible, "seconds": 0.0}
    started = time.monotonic()
    with open(log_path, "ab", buffering=0) as log:
        for shown, argv in commands:
            if commands_plugin.stopping is not None:
                break  # stopped between two of its commands: unfinished
            log.write(f"> {shown}\n".encode())
            process = subprocess.Popen(launcher(argv), cwd=cwd, env=full_env, stdout=log,
                                       stderr=subprocess.STDOUT, start_new_session=True,
                                       close_fds=True)
            commands_plugin.running[process.pid] = process
            if commands_plugin.stopping is not None:  # the stop came while it started
                signal_groups([process], commands_plugin.stopping)
            try:
                result["code"] = process.wait()
            finally:
                commands_plugin.running.pop(process.pid, None)
            if interrupted(result["code"], commands_plugin.stopping, commands_plugin.leaving):
                raise CommandInterrupted(f"{shown!r} ended with {result['code']} on "
                                         f"{worker.address}: its machine's doing, retried")
            if result["code"] != 0:
                break
        else:
            result["complete"] = True
    result["seconds"] = time.monotonic() - started
    return result


def stop_commands(signum: int, dask_worker=None) -> int:
    """Through `client.run`: pass the driver's stop signal to every stage command on this worker
    and start no further command of theirs; how many got it."""
    commands_plugin = dask_worker.plugins.get(PLUGIN_NAME)
    if commands_plugin is None:
        return 0
    commands_plugin.stopping = signum
    return signal_groups(commands_plugin.running.values(), signum)


def project_fingerprint(root: str) -> dict:
    """Which project a machine sees at `root`: whether there is one, its git HEAD and a hash of its
    tracked .py files (working-tree contents, so an uncommitted edit counts). Outside git: every
    .py file below `root` but in hidden folders and .venv."""
    path = Path(root)
    found = (path / "dvc.yaml").is_file() or (path / ".dvc").is_dir()
    fingerprint = {"host": socket.gethostname(), "project": found, "git_head": None,
                   "python_sha256": None}
    if not found:
        return fingerprint
    git = subprocess.run(["git", "rev-parse", "HEAD"], cwd=path, capture_output=True, text=True)
    if git.returncode == 0:
        fingerprint["git_head"] = git.stdout.strip()
        listed = subprocess.run(["git", "ls-files", "-z", "--", "*.py"], cwd=path,
                                capture_output=True, text=True, check=True).stdout
        files = sorted(name for name in listed.split("\0") if name)
    else:
        files = sorted(str(p.relative_to(path)) for p in path.rglob("*.py")
                       if not any(part.startswith(".") for part in p.relative_to(path).parts))
    digest = hashlib.sha256()
    for name in files:
        digest.update(name.encode() + b"\0")
        if (path / name).is_file():
            digest.update(hashlib.sha256((path / name).read_bytes()).digest())
    fingerprint["python_sha256"] = digest.hexdigest()
    return fingerprint
