"""Preemption: signals and a time budget become a stop the training loops poll."""

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from pipeline.preemption import EXIT_BUDGET, Preemption, StopRequested, exit_when_stopped

REPO = Path(__file__).resolve().parents[1]


def test_sigterm_sets_the_reason_and_the_handlers_are_restored():
    before = signal.getsignal(signal.SIGTERM)
    with Preemption() as preemption:
        assert preemption.stop_reason() is None
        os.kill(os.getpid(), signal.SIGTERM)
        assert preemption.stop_reason() == "SIGTERM"
        stop = preemption.request("epoch 1, step 2")
        assert stop.exit_code == 143 and "epoch 1, step 2" in stop.reason
    assert signal.getsignal(signal.SIGTERM) is before


def test_sigint_exits_130_and_a_second_signal_stops_at_once():
    with Preemption() as preemption:
        os.kill(os.getpid(), signal.SIGINT)
        assert preemption.request("x").exit_code == 130
        with pytest.raises(SystemExit) as second:
            os.kill(os.getpid(), signal.SIGINT)
        assert second.value.code == 130


def test_the_time_budget_runs_out_on_the_clock():
    now = [0.0]
    preemption = Preemption(max_minutes=2, clock=lambda: now[0])
    with preemption:
        now[0] = 119.0
        assert preemption.stop_reason() is None
        now[0] = 120.0
        assert "time budget of 2 min" in preemption.stop_reason()
        assert preemption.request("x").exit_code == EXIT_BUDGET == 75


def test_no_budget_never_stops():
    preemption = Preemption(max_minutes=0, clock=lambda: 1e9)
    assert preemption.stop_reason() is None


def test_exit_when_stopped_turns_the_stop_into_the_exit_code(capsys):
    @exit_when_stopped
    def main():
        raise StopRequested("SIGTERM: checkpoint saved at epoch 3", 143)

    with pytest.raises(SystemExit) as exited:
        main()
    assert exited.value.code == 143
    assert "checkpoint saved at epoch 3" in capsys.readouterr().err


def test_a_stage_run_with_python_m_names_itself_when_stopped(tmp_path):
    """`python -m pkg.stage` runs the module as "__main__": the message names pkg.stage instead."""
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "stage.py").write_text(
        "from pipeline.preemption import StopRequested, exit_when_stopped\n"
        "@exit_when_stopped\n"
        "def main():\n"
        "    raise StopRequested('budget spent', 75)\n"
        "if __name__ == '__main__':\n"
        "    main()\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(REPO)])}
    run = subprocess.run([sys.executable, "-m", "pkg.stage"], cwd=tmp_path, env=env,
                         capture_output=True, text=True)
    assert run.returncode == 75
    assert "pkg.stage: stopped early, budget spent" in run.stderr
    assert "__main__" not in run.stderr
