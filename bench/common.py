"""What every speed benchmark `bench/bench_*.py` shares (not a benchmark itself).

- `parser`: argparse with `--smoke`: tiny sizes on synthetic inputs (or fixtures), a few seconds,
  the benchmark's own code path; `tests/test_bench_smoke.py` runs every benchmark so, so a changed
  signature breaks a test instead of the next person who runs the benchmark.
- `require`: a benchmark that times a trained model or a pipeline output a fresh clone lacks names
  each missing path and the `dvc repro` that makes it, and exits NEEDS_PIPELINE; `make bench`
  lists it as waiting for the pipeline and goes on with the next.
- `tiny_ynet`: a Y-net of a few channels, what a smoke run builds instead of a trained one.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

NEEDS_PIPELINE = 3  # exit status: a pipeline output is missing (1: an error, 2: bad arguments)
SMOKE_HELP = ("tiny sizes on synthetic inputs, one thread, a few seconds: checks that the benchmark "
              "runs")
TINY_CHANNELS = {"encoder_channels": [4, 4, 8, 8, 8], "decoder_channels": [8, 8, 8, 4, 4]}


def parser(doc: str) -> argparse.ArgumentParser:
    """The benchmark's parser, with `--smoke`; `--help` prints its docstring `doc`."""
    first, _, rest = doc.partition("\n")
    out = argparse.ArgumentParser(description=first, epilog=rest.strip() or None,
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    out.add_argument("--smoke", action="store_true", help=SMOKE_HELP)
    return out


def repro(stage: str) -> str:
    """How to make an output of `stage`."""
    return f"run `dvc repro {stage}`"


def missing(needs: dict[Path, str]) -> dict[Path, str]:
    """The `needs` {path: how to make it} whose path is not on disk."""
    return {Path(path): how for path, how in needs.items() if not Path(path).exists()}


def say_needs(bench: str, absent: dict[Path, str]) -> None:
    for path, how in absent.items():
        print(f"{bench}: needs {path}: {how}", flush=True)


def require(bench: str, needs: dict[Path, str]) -> None:
    """Exit NEEDS_PIPELINE, naming every missing path of `needs` {path: how to make it, e.g.
    `repro("train_ynet")`}; return when all are there."""
    absent = missing(needs)
    if absent:
        say_needs(bench, absent)
        raise SystemExit(NEEDS_PIPELINE)


def tiny_ynet(settings):
    """`settings` (a `YnetSettings`) with a few channels per layer and batches of 2: an untrained
    model that runs the same code in milliseconds."""
    return dataclasses.replace(settings, batch_size=2, **TINY_CHANNELS)
