"""Atomic writes (`pipeline/io.py`): a failed write leaves the old output, a killed writer's
temporary files are removed by the next write of the same target, a live writer's are not."""

import os
import subprocess
import sys

import pytest

from pipeline.io import atomic_dir, remove_dead_writers, write_json, write_text, write_with


def dead_pid() -> int:
    """The pid of a process that has ended."""
    child = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                           capture_output=True, text=True, check=True)
    return int(child.stdout)


def test_a_failed_write_keeps_the_old_output_and_leaves_nothing(tmp_path):
    target = tmp_path / "m.json"
    write_json({"ade": 1.0}, target)
    with pytest.raises(RuntimeError, match="stopped"):
        with atomic_dir(tmp_path / "folder"):
            raise RuntimeError("stopped")

    def broken(_):
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        write_with(target, broken)
    assert target.read_text() == '{\n  "ade": 1.0\n}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json"]


def test_a_killed_writers_leftovers_go_with_the_next_write(tmp_path):
    gone = dead_pid()
    left_file = tmp_path / f".last.pt.tmp{gone}"
    left_dir = tmp_path / f".maps.tmp{gone}.abc123"
    live = tmp_path / f".last.pt.tmp{os.getppid()}"  # a running process: maybe still writing
    other = tmp_path / f".last.pt.old.tmp{gone}"  # another target's
    for path in (left_file, live, other):
        path.write_text("half")
    left_dir.mkdir()
    (left_dir / "part.npz").write_text("half")
    write_text(tmp_path / "last.pt", "full")
    assert not left_file.exists() and live.exists() and other.exists()
    with atomic_dir(tmp_path / "maps") as staged:
        (staged / "maps.npz").write_text("full")
    assert not left_dir.exists() and (tmp_path / "maps" / "maps.npz").read_text() == "full"
    assert remove_dead_writers(tmp_path / "last.pt") == []
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["last.pt", "maps", live.name, other.name])
