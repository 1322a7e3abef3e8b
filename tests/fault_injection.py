"""Run a stage with a SIGKILL planted in it: the child side of tests/test_faults.py.

    python -m tests.fault_injection step <n> <stage module> <stage args...>
    python -m tests.fault_injection checkpoint <n> <stage module> <stage args...>
    python -m tests.fault_injection output <n> <file name> <stage module> <stage args...>

Installs one patch, then calls `<stage module>.main(<stage args>)` as `python -m` would:

- `step`: the n-th optimiser step of the run (1-based, counted over every optimiser: S-GAN's
  discriminator and generator steps both count) kills the process before it steps.
- `checkpoint`: the n-th `os.replace` whose destination ends in `last.pt` kills the process before it
  renames: the checkpoint is complete under its temporary name (`pipeline.io.atomic_path`), `last.pt`
  still the previous one (or absent).
- `output`: the n-th write through `pipeline.io.write_with` of a file named `<file name>` writes the
  file to its temporary path, truncates it to half its bytes and kills the process (a torn write).

The kill is SIGKILL sent to the process itself: no handler, `finally` or `atexit` runs, as when the
OOM killer, a scheduler's hard stop or `kill -9` ends a training run. A run that never reaches its
kill point exits with status `NOT_REACHED` after saying so, so the caller can tell it from a kill.
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
from pathlib import Path

POINTS = ("step", "checkpoint", "output")
NOT_REACHED = 3


def die(why: str) -> None:
    """SIGKILL this process (after flushing what it printed, so the caller can read it)."""
    print(f"fault_injection: pid {os.getpid()} SIGKILL {why}", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    os.kill(os.getpid(), signal.SIGKILL)
    raise AssertionError("SIGKILL did not kill")  # never reached


def kill_at_step(n: int) -> None:
    """Optimiser step n kills before stepping: every concrete optimiser class in torch.optim."""
    import torch

    calls = [0]

    def patched(real):
        def step(self, *args, **kwargs):
            calls[0] += 1
            if calls[0] == n:
                die(f"before optimiser step {n} ({type(self).__name__})")
            return real(self, *args, **kwargs)
        return step

    classes = [cls for cls in vars(torch.optim).values()
               if isinstance(cls, type) and issubclass(cls, torch.optim.Optimizer)
               and cls is not torch.optim.Optimizer and "step" in vars(cls)]
    assert torch.optim.Adam in classes
    for cls in classes:
        cls.step = patched(cls.step)


def kill_at_checkpoint(n: int) -> None:
    """The n-th rename onto a `last.pt` kills first (the new checkpoint lies under its temp name)."""
    real, calls = os.replace, [0]

    def replace(src, dst, *args, **kwargs):
        if str(dst).endswith("last.pt"):
            calls[0] += 1
            if calls[0] == n:
                written = Path(src).stat().st_size
                die(f"before renaming {src} ({written} bytes) over {dst}")
        return real(src, dst, *args, **kwargs)

    os.replace = replace


def kill_in_output(n: int, name: str) -> None:
    """The n-th write of a file named `name` stops half-way: half its bytes at the temporary path."""
    import pipeline.io

    real, calls = pipeline.io.write_with, [0]

    def write_with(path, write, suffix="", mode=None):
        if Path(path).name != name:
            return real(path, write, suffix, mode)
        calls[0] += 1
        if calls[0] != n:
            return real(path, write, suffix, mode)

        def torn(tmp: Path) -> None:
            write(tmp)
            size = os.path.getsize(tmp)
            os.truncate(tmp, size // 2)
            die(f"with {size // 2} of {size} bytes of {path} written to {tmp}")

        return real(path, torn, suffix, mode)

    pipeline.io.write_with = write_with


def main(argv: list[str]) -> None:
    usage = (f"usage: python -m tests.fault_injection {{step,checkpoint}} N MODULE ARGS... | "
             "output N FILE_NAME MODULE ARGS...")
    if len(argv) < 3 or argv[0] not in POINTS or not argv[1].isdigit() or int(argv[1]) < 1:
        raise SystemExit(usage)
    point, n, rest = argv[0], int(argv[1]), argv[2:]
    if point == "step":
        kill_at_step(n)
    elif point == "checkpoint":
        kill_at_checkpoint(n)
    else:
        if len(rest) < 2:
            raise SystemExit(usage)
        name, rest = rest[0], rest[1:]
        kill_in_output(n, name)
    module, stage_argv = rest[0], rest[1:]
    importlib.import_module(module).main(stage_argv)
    print(f"fault_injection: {module} finished without reaching {point} {n}", file=sys.stderr)
    raise SystemExit(NOT_REACHED)


if __name__ == "__main__":
    main(sys.argv[1:])
