"""Fault injection: a training stage killed with SIGKILL (no handler, `finally` or `atexit` runs) and
then run again as DVC would run it ends with the very outputs of an uninterrupted run.

Each resumable stage runs in subprocesses on a tiny fixture borrowed from its own tests: once
uninterrupted (the reference), and once per kill point planted by `tests.fault_injection`, followed
by a plain re-run of the same command. They are forked by `tests.fork_server`, which has torch
imported: a fresh interpreter spent 3 to 4 of its 5 CPU seconds importing it.

- `step`: at the N-th optimiser step, mid-epoch (nothing was saved since the last epoch's end);
- `checkpoint`: with the new `last.pt` complete under its temporary name, not yet renamed;
- `output`: half-way through writing an output file to its temporary path (a torn write).

The re-run must end with byte-identical weights files and, where a file records wall-clock times,
identical contents once those times are left out: keys or columns whose name contains "seconds"
(`train_seconds`, `wall_seconds`, `seconds_per_epoch`, the per-epoch `seconds` of the logs and
histories). Those are the only differences between an uninterrupted and a resumed run.
Separately, no temporary file of the killed process may remain in the run's folders afterwards.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import re
import select
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import torch
import yaml

from tests.fault_injection import NOT_REACHED

REPO = Path(__file__).resolve().parents[1]
TIMEOUT_S = 300  # per subprocess; each takes seconds


# ---------------------------------------------------------------------------------------------
# The stages, their fixtures and what they write


@dataclass(frozen=True)
class Kill:
    n: int  # the n-th optimiser step / last.pt rename / write of `target`
    epochs_saved: int | None  # the epochs `last.pt` holds after the kill (None: no last.pt yet)
    target: str | None = None  # `output`: the file name whose write is torn


@dataclass(frozen=True)
class Stage:
    module: str
    build: object  # build(root): write the fixture and params.yaml under `root`
    argv: object  # argv(run): the stage's arguments, outputs under the folder `run`
    # path under `run` -> how to compare: bytes (weights files without times) | torch (loaded:
    # checkpoints and exports that record seconds) | json | csv (all three without the times)
    outputs: dict[str, str]
    kills: dict[str, Kill]  # point -> where the kill strikes

    def output_named(self, name: str) -> str:
        (path,) = [p for p in self.outputs if Path(p).name == name]
        return path


def build_segmentation(root: Path) -> None:
    """test_segmentation_device's stage fixture: one train video, 2 epochs of 3 one-crop steps."""
    from tests.test_segmentation_device import stage_args

    with pytest.MonkeyPatch.context() as patch:  # it chdirs and sets sys.argv: undone on exit
        stage_args(root, patch, "unused", 0)


def build_ynet(root: Path) -> None:
    """test_horizon_stages's cpu-profile fixture (6 train windows, t_f = 10) with params.yaml's
    real `ynet.cpu` settings, 1 thread and 3 epochs of 3 steps."""
    from tests.test_horizon_stages import write_fixture

    write_fixture(root)
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    params["profile"] = "cpu"
    params["ynet"]["cpu"].update(threads=1, epochs=3)
    params["runtime"] = {"device": "cpu", "max_minutes": 0}
    (root / "params.yaml").write_text(yaml.safe_dump(params))


def build_baseline(root: Path) -> None:
    """test_baselines_device's stage fixture (8 train, 4 val windows, t_f = 5), PECNet and S-GAN
    tiny and in small batches: 3 epochs of 4 (PECNet: its reversed copies double the windows) or
    2 (S-GAN) batches."""
    from tests.test_baselines import N_PAST, TINY_PECNET, TINY_SGAN, straight_tracks, window_table

    window_table(straight_tracks(12, 5, seed=5), ["train"] * 8 + ["val"] * 4).to_parquet(
        root / "tf5.parquet")
    pecnet = dataclasses.asdict(dataclasses.replace(TINY_PECNET, epochs=3, batch_size=4))
    sgan = dataclasses.asdict(dataclasses.replace(TINY_SGAN, epochs=3, batch_size=4))
    (root / "params.yaml").write_text(yaml.safe_dump({
        "profile": "cpu", "windows": {"n_past": N_PAST}, "train_baseline": {"seed": 0, "threads": 1},
        "runtime": {"device": "cpu", "max_minutes": 0},
        "pecnet": {"cpu": pecnet, "paper": pecnet}, "sgan": {"cpu": sgan, "paper": sgan}}))


def build_short_term(root: Path) -> None:
    """test_short_term_models's ETH fold (12 train, 4 val windows) and tiny params, Y-net for
    3 epochs of 3 steps on 32-pixel crops."""
    from tests.test_short_term_models import tiny_params, write_ethucy

    write_ethucy(root / "windows")
    params = tiny_params()
    for profile in ("cpu", "paper"):
        params["short_term_models"][profile] = {
            **params["short_term_models"][profile],
            "epochs": {**params["short_term_models"][profile]["epochs"], "ynet": {"sdd": 3, "ethucy": 3}}}
    params["runtime"] = {"device": "cpu", "max_minutes": 0}
    (root / "params.yaml").write_text(yaml.safe_dump(params))


def baseline_argv(model: str):
    return lambda run: ["--model", model, "--horizon", "5", "--table", "tf5.parquet",
                        "--checkpoint-dir", f"{run}/ck", "--metrics", f"{run}/out/train.json"]


BASELINE_OUTPUTS = {"ck/last.pt": "torch", "ck/best.pt": "bytes", "ck/best_mean3.pt": "bytes",
                    "ck/best_mean5.pt": "bytes", "ck/best_mean7.pt": "bytes", "out/train.json": "json"}

STAGES = {
    "segmentation": Stage(
        "pipeline.stages.segmentation", build_segmentation,
        lambda run: ["--sdd", "sdd", "--labels", "labels", "--checkpoint", f"{run}/ck/last.pt",
                     "--model", f"{run}/out/model.pt", "--log", f"{run}/out/train_log.csv"],
        # model.pt records train_seconds, so it is compared as loaded, like last.pt
        {"ck/last.pt": "torch", "out/model.pt": "torch", "out/train_log.csv": "csv"},
        # 6 steps: the 2nd of epoch 2; the 2nd (last) checkpoint; the exported model
        {"step": Kill(5, 1), "checkpoint": Kill(2, 1), "output": Kill(1, 2, "model.pt")}),
    "train_ynet": Stage(
        "pipeline.stages.train_ynet", build_ynet,
        lambda run: ["--windows", "tf10.parquet", "--semantic-maps", "semantic_maps", "--sdd", "sdd",
                     "--n-past", "5", "--checkpoint-dir", f"{run}/ck", "--model", f"{run}/out/model.pt",
                     "--history", f"{run}/out/ynet_train.csv", "--metrics", f"{run}/out/ynet_train.json"],
        {"ck/last.pt": "torch", "ck/best.pt": "bytes", "out/model.pt": "bytes",
         "out/ynet_train.csv": "csv", "out/ynet_train.json": "json"},
        # 9 steps: the 2nd of epoch 2; epoch 2's checkpoint; epoch 2's history (before epoch 3)
        {"step": Kill(5, 1), "checkpoint": Kill(2, 1), "output": Kill(2, 2, "ynet_train.csv")}),
    "train_baseline-pecnet": Stage(
        "pipeline.stages.train_baseline", build_baseline, baseline_argv("pecnet"), BASELINE_OUTPUTS,
        # 12 steps: the 2nd of epoch 2; epoch 2's checkpoint; the training facts at the very end
        {"step": Kill(6, 1), "checkpoint": Kill(2, 1), "output": Kill(1, 3, "train.json")}),
    "train_baseline-sgan": Stage(
        "pipeline.stages.train_baseline", build_baseline, baseline_argv("sgan"), BASELINE_OUTPUTS,
        # 2 batches of 2 discriminator + 1 generator steps per epoch: the 2nd batch of epoch 2;
        # epoch 1's checkpoint; the first best.pt (epoch 1, before any last.pt)
        {"step": Kill(10, 1), "checkpoint": Kill(1, None), "output": Kill(1, None, "best.pt")}),
    "train_short_term_ynet": Stage(
        "pipeline.stages.train_short_term_ynet", build_short_term,
        lambda run: ["--dataset", "eth", "--windows", "windows", "--maps", "windows/ethucy_semantic",
                     "--checkpoint-dir", f"{run}/ck", "--metrics", f"{run}/out/eth_ynet.json"],
        {"ck/last.pt": "torch", "ck/best.pt": "bytes", "ck/history.csv": "csv",
         "out/eth_ynet.json": "json"},
        # 9 steps: the 2nd of epoch 2; epoch 2's checkpoint; the first best.pt (epoch 1)
        {"step": Kill(5, 1), "checkpoint": Kill(2, 1), "output": Kill(1, None, "best.pt")}),
}
CASES = [(stage, point) for stage in STAGES for point in ("step", "checkpoint", "output")]


# ---------------------------------------------------------------------------------------------
# Running


class ForkServer:
    """`python -m <args>` in `root`, each run a process forked by one `tests.fork_server`."""

    def __init__(self, logs: Path):
        self.logs, self.runs = logs, 0
        env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
        self.server = subprocess.Popen([sys.executable, "-m", "tests.fork_server"], cwd=REPO,
                                       env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                       text=True, start_new_session=True)

    def run(self, root: Path, args: list[str]) -> subprocess.CompletedProcess:
        self.runs += 1
        out, err = (self.logs / f"{self.runs}.{name}" for name in ("stdout", "stderr"))
        self.server.stdin.write(json.dumps({"cwd": str(root), "argv": args, "stdout": str(out),
                                            "stderr": str(err)}) + "\n")
        self.server.stdin.flush()
        if not select.select([self.server.stdout], [], [], TIMEOUT_S)[0]:
            os.killpg(self.server.pid, signal.SIGKILL)  # the server and its run
            pytest.fail(f"{args} ran past {TIMEOUT_S} s")
        reply = self.server.stdout.readline()
        assert reply, f"the fork server ended (exit {self.server.wait()})"
        return subprocess.CompletedProcess(args, json.loads(reply)["returncode"],
                                           out.read_text(), err.read_text())

    def close(self) -> None:
        self.server.stdin.close()
        self.server.wait(timeout=60)


def tail(done: subprocess.CompletedProcess) -> str:
    return (f"exit {done.returncode}\n--- stdout\n{done.stdout[-2000:]}\n"
            f"--- stderr\n{done.stderr[-4000:]}")


@dataclass
class Scenario:
    reference: Path  # the uninterrupted run's folder
    resumed: Path  # the killed, then re-run, run's folder
    killed_pid: int
    left_by_kill: dict[str, dict]  # temporary files the SIGKILL left: bytes, epoch (a last.pt's)
    epochs_saved: int | None  # epochs in `last.pt` right after the kill (None: no last.pt)


class Runs:
    """Fixtures built, reference runs made and kill scenarios played once per module."""

    def __init__(self, factory: pytest.TempPathFactory, server: ForkServer):
        self.factory, self.server = factory, server
        self.roots: dict[str, Path] = {}
        self.references: dict[str, Path] = {}
        self.scenarios: dict[tuple[str, str], Scenario] = {}

    def root(self, name: str) -> Path:
        base = name.split("-")[0]  # the two baselines share one fixture
        if base not in self.roots:
            self.roots[base] = self.factory.mktemp(base)
            STAGES[name].build(self.roots[base])
        return self.roots[base]

    def run_clean(self, root: Path, stage: Stage, name: str) -> Path:
        done = self.server.run(root, [stage.module, *stage.argv(f"runs/{name}")])
        assert done.returncode == 0, tail(done)
        return root / "runs" / name

    def reference(self, name: str) -> Path:
        if name not in self.references:
            self.references[name] = self.run_clean(self.root(name), STAGES[name],
                                                   f"{name}-reference")
        return self.references[name]

    def scenario(self, name: str, point: str) -> Scenario:
        key = (name, point)
        if key not in self.scenarios:
            stage, root, folder = STAGES[name], self.root(name), f"{name}-{point}"
            kill = stage.kills[point]
            where = [str(kill.n)] + ([kill.target] if point == "output" else [])
            killed = self.server.run(root, ["tests.fault_injection", point, *where, stage.module,
                                            *stage.argv(f"runs/{folder}")])
            assert killed.returncode != NOT_REACHED, "kill point not reached\n" + tail(killed)
            assert killed.returncode == -signal.SIGKILL, tail(killed)
            pid = int(re.search(r"fault_injection: pid (\d+) SIGKILL", killed.stderr).group(1))
            folder_path = root / "runs" / folder
            left = {path: {"bytes": (folder_path / path).stat().st_size,
                           "epoch": saved_epoch(folder_path / path)
                           if Path(path).name == f".last.pt.tmp{pid}" else None}
                    for path in temporary_files(folder_path)}
            epochs_saved = saved_epoch(folder_path / "ck" / "last.pt")
            resumed = self.run_clean(root, stage, folder)
            self.scenarios[key] = Scenario(self.reference(name), resumed, pid, left, epochs_saved)
        return self.scenarios[key]


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> Iterator[Runs]:
    server = ForkServer(tmp_path_factory.mktemp("logs"))
    yield Runs(tmp_path_factory, server)
    server.close()


# ---------------------------------------------------------------------------------------------
# Comparing


def saved_epoch(path: Path) -> int | None:
    """The epochs completed in a checkpoint file (`pipeline.checkpoints` layout), None if absent."""
    if not path.exists():
        return None
    return torch.load(path, map_location="cpu", weights_only=True)["epoch"]


def is_temporary(path: Path) -> bool:
    """A `pipeline.io.atomic_path` temporary file: `.<name>.tmp<pid>[suffix]`."""
    return path.name.startswith(".") and ".tmp" in path.name


def temporary_files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if is_temporary(p))


def files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")
                  if p.is_file() and not is_temporary(p))


def without_times(value):
    """`value` without the keys that hold wall-clock times (any key containing "seconds").

    Only those differ between an uninterrupted and a killed-then-resumed run: every other key,
    tensor and value must be identical."""
    if isinstance(value, dict):
        return {k: without_times(v) for k, v in value.items()
                if not (isinstance(k, str) and "seconds" in k)}
    if isinstance(value, (list, tuple)):
        return type(value)(without_times(v) for v in value)
    return value


def assert_identical(a, b, where: str) -> None:
    """Equal structure and values; tensors bit for bit (dtype, shape, bytes), floats exactly."""
    assert type(a) is type(b), f"{where}: {type(a).__name__} vs {type(b).__name__}"
    if isinstance(a, torch.Tensor):
        assert (a.dtype, a.shape) == (b.dtype, b.shape), \
            f"{where}: {a.dtype}{tuple(a.shape)} vs {b.dtype}{tuple(b.shape)}"
        bits = [t.detach().contiguous().reshape(-1).view(torch.uint8) for t in (a, b)]
        assert torch.equal(*bits), f"{where}: tensors differ"
    elif isinstance(a, dict):
        assert list(a) == list(b), f"{where}: keys {list(a)} vs {list(b)}"
        for key in a:
            assert_identical(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), f"{where}: length {len(a)} vs {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_identical(x, y, f"{where}[{i}]")
    elif isinstance(a, float) and math.isnan(a):
        assert math.isnan(b), f"{where}: nan vs {b}"
    else:
        assert a == b, f"{where}: {a!r} vs {b!r}"


def csv_without_times(path: Path) -> list[list[str]]:
    """The CSV's cells as written, without its columns of wall-clock times."""
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    keep = [i for i, name in enumerate(rows[0]) if "seconds" not in name]
    return [[row[i] for i in keep] for row in rows]


def assert_same_output(reference: Path, resumed: Path, kind: str, where: str) -> None:
    if kind == "bytes":
        assert reference.read_bytes() == resumed.read_bytes(), f"{where}: bytes differ"
    elif kind == "torch":
        load = lambda p: torch.load(p, map_location="cpu", weights_only=True)  # noqa: E731
        assert_identical(without_times(load(reference)), without_times(load(resumed)), where)
    elif kind == "json":
        assert_identical(without_times(json.loads(reference.read_text())),
                         without_times(json.loads(resumed.read_text())), where)
    else:
        assert csv_without_times(reference) == csv_without_times(resumed), f"{where}: rows differ"


# ---------------------------------------------------------------------------------------------
# Tests


@pytest.mark.parametrize("name, point", CASES)
def test_killed_then_rerun_ends_with_the_outputs_of_an_uninterrupted_run(runs, name, point):
    played = runs.scenario(name, point)
    outputs = STAGES[name].outputs
    assert files(played.reference) == sorted(outputs)
    assert files(played.resumed) == sorted(outputs)
    for path, kind in outputs.items():
        assert_same_output(played.reference / path, played.resumed / path, kind, path)


@pytest.mark.parametrize("name, point", CASES)
def test_the_kill_struck_where_it_was_planted(runs, name, point):
    """Right after the kill, `last.pt` holds the epochs it should (so the re-run resumed from it, or
    started afresh without one), and: a step kill left no temporary file; a checkpoint kill a
    complete checkpoint of the next epoch as `.last.pt.tmp<pid>`; an output kill the torn
    temporary file of its target, shorter than the finished file."""
    played, kill = runs.scenario(name, point), STAGES[name].kills[point]
    assert played.epochs_saved == kill.epochs_saved
    left = played.left_by_kill
    if point == "step":
        assert left == {}
        return
    (path, facts), = left.items()
    target = "last.pt" if point == "checkpoint" else kill.target
    output = STAGES[name].output_named(target)
    assert path == str(Path(output).parent / f".{target}.tmp{played.killed_pid}")
    if point == "checkpoint":
        assert facts["epoch"] == (kill.epochs_saved or 0) + 1
    else:
        assert 0 < facts["bytes"] < (played.reference / output).stat().st_size


@pytest.mark.parametrize("name, point", CASES)
def test_no_temporary_file_remains_after_the_rerun(runs, name, point):
    played = runs.scenario(name, point)
    left = temporary_files(played.resumed)
    # the killed writer's `.<name>.tmp<pid>` is removed by the re-run's next write of that file
    # (`pipeline.io.remove_dead_writers`), so nothing of the kill reaches DVC's cache
    assert left == []
