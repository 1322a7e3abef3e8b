"""`python -m <module> <args>` runs forked from one process that imported the heavy third-party
libraries once: each run is still a process of its own (its own pid, killed alone by a SIGKILL,
exiting through the interpreter's normal shutdown), without the seconds of CPU that importing
torch again costs. tests/test_faults.py runs its 35 stage runs so.

    python -m tests.fork_server   # then one JSON request a line on stdin, one reply a line

A request {"cwd", "argv": [module, *args], "stdout", "stderr"} (file paths) is answered, once its
run ended, with {"returncode"}: the exit status, or minus the signal that ended it (as
`subprocess`). Only the libraries of `PRELOAD` are imported beforehand, none of the repository's
modules: a run imports those itself, after whatever its module patches first
(`tests.fault_injection` plants its faults before the stage module is imported), as in a fresh
process. The server has no other thread when it forks (with OMP_NUM_THREADS=1; pandas is left
out: pyarrow starts jemalloc's background thread on import).
"""

from __future__ import annotations

import gc
import importlib
import json
import os
import runpy
import sys

# most of what the training stages import besides the repository (torch._dynamo: on the first
# optimiser); 4 of the 5 CPU seconds of a stage's tiny run in a fresh process
PRELOAD = ("numpy", "yaml", "tqdm", "cv2", "torch", "torch._dynamo")


def run_here(request: dict) -> None:
    """Become `python -m argv[0] argv[1:]` in `cwd`, output to the request's files; the module's
    exit, exception or signal ends the process as it would a fresh one."""
    os.chdir(request["cwd"])
    for fd, path, flags in ((0, os.devnull, os.O_RDONLY),
                            (1, request["stdout"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC),
                            (2, request["stderr"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC)):
        os.dup2(os.open(path, flags, 0o644), fd)
    module, *args = request["argv"]
    sys.argv = [module, *args]
    sys.path[0] = os.getcwd()  # as `python -m` sets it
    runpy.run_module(module, run_name="__main__", alter_sys=True)


def serve() -> None:
    for name in PRELOAD:
        importlib.import_module(name)
    assert len(os.listdir("/proc/self/task")) == 1, "a thread would be lost in every fork"
    gc.freeze()  # what is imported stays out of the runs' collections (fewer pages copied)
    for line in sys.stdin:
        request = json.loads(line)
        sys.stdout.flush()
        pid = os.fork()
        if pid == 0:
            run_here(request)
            return  # the run finished: the interpreter exits as after `python -m`
        _, status = os.waitpid(pid, 0)
        print(json.dumps({"returncode": os.waitstatus_to_exitcode(status)}), flush=True)


if __name__ == "__main__":
    serve()
