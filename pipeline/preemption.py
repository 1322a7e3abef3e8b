"""Training that survives preemption: SIGTERM / SIGINT and a time budget become a flag.

Cluster schedulers and cloud GPUs stop jobs with SIGTERM (then SIGKILL a little later), and a
long `paper` run has to advance in pieces of a few minutes. A training loop polls
`Preemption.stop_reason()` between optimiser steps; when it is set, the loop saves a mid-epoch
checkpoint (model, optimiser, RNG states, position in the epoch) and raises `StopRequested`. The
stage's `main` is wrapped in `exit_when_stopped`, which turns that into a message and a non-zero
exit, so DVC records nothing and the next `dvc repro` resumes from the checkpoint and ends with the
same weights as an uninterrupted run.

Exit codes: 143 after SIGTERM, 130 after SIGINT (the shells' 128 + signal), 75 (EX_TEMPFAIL) when
the `runtime.max_minutes` budget ran out. A second signal stops at once, without a checkpoint.
"""

from __future__ import annotations

import functools
import signal
import sys
import threading
import time
from collections.abc import Callable

EXIT_BUDGET = 75
_SIGNAL_EXIT = {signal.SIGTERM: 143, signal.SIGINT: 130}


class StopRequested(Exception):
    """A training loop stopped early on request, after saving a resumable checkpoint."""

    def __init__(self, reason: str, exit_code: int):
        super().__init__(reason)
        self.reason = reason
        self.exit_code = exit_code


class Preemption:
    """Polled between training steps: has a signal arrived, or has the time budget run out?

    Use as a context manager: the handlers are installed on entry (main thread only; elsewhere
    only the budget applies) and the previous ones restored on exit.
    """

    def __init__(self, max_minutes: float = 0.0, clock: Callable[[], float] = time.monotonic):
        self.max_minutes = max_minutes
        self._clock = clock
        self._start = clock()
        self._signal: int | None = None
        self._previous: dict[int, object] = {}

    def __enter__(self) -> Preemption:
        self._start = self._clock()
        if threading.current_thread() is threading.main_thread():
            for signum in _SIGNAL_EXIT:
                self._previous[signum] = signal.signal(signum, self._on_signal)
        return self

    def __exit__(self, *exc) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous.clear()

    def _on_signal(self, signum, frame) -> None:
        if self._signal is not None:  # second signal: stop now, no checkpoint
            raise SystemExit(_SIGNAL_EXIT[signum])
        self._signal = signum
        print(f"\n{signal.Signals(signum).name} received: saving a checkpoint after this step "
              "(send it again to stop at once)", file=sys.stderr, flush=True)

    def elapsed_minutes(self) -> float:
        return (self._clock() - self._start) / 60.0

    def stop_reason(self) -> str | None:
        """Why the loop should stop now, or None to go on."""
        if self._signal is not None:
            return signal.Signals(self._signal).name
        if self.max_minutes and self.elapsed_minutes() >= self.max_minutes:
            return f"time budget of {self.max_minutes:g} min (runtime.max_minutes)"
        return None

    def request(self, where: str) -> StopRequested:
        """The exception a loop raises after checkpointing at `where` (e.g. 'epoch 3, step 40')."""
        reason = self.stop_reason() or "stop requested"
        code = _SIGNAL_EXIT.get(self._signal, EXIT_BUDGET)
        return StopRequested(f"{reason}: checkpoint saved at {where}; run again to resume", code)


NEVER = Preemption()  # a Preemption outside any `with`: no handlers, no budget, never stops


def module_name(function: Callable[..., None]) -> str:
    """The dotted module a function was defined in, also when that module runs as `python -m`
    (where `__module__` is only "__main__" and the real name sits in the module's spec)."""
    module = sys.modules.get(function.__module__)
    spec = getattr(module, "__spec__", None)
    return spec.name if function.__module__ == "__main__" and spec is not None else function.__module__


def exit_when_stopped(main: Callable[..., None]) -> Callable[..., None]:
    """Decorate a stage's `main`: a StopRequested becomes its message and exit code."""

    @functools.wraps(main)
    def wrapper(*args, **kwargs):
        try:
            return main(*args, **kwargs)
        except StopRequested as stop:
            print(f"{module_name(main)}: stopped early, {stop.reason}", file=sys.stderr, flush=True)
            raise SystemExit(stop.exit_code) from None

    return wrapper
