"""tools/timed_repro.py (the stage clock of `make repro`) and the report's "Where the time goes"."""

import json
from pathlib import Path

import pytest

from pipeline.report.lookups import Absent
from pipeline.report.run_provenance import stage_profile
from tools import timed_repro

DVC_OUTPUT = [  # (seconds, line) as `dvc repro` prints them
    (0.0, "Stage 'fetch' didn't change, skipping\n"),
    (1.0, "Running stage 'tracks':\n"),
    (1.1, "> python -m pipeline.stages.tracks ...\n"),
    (30.0, "tracks: 23 videos\n"),
    (31.5, "Updating lock file 'dvc.lock'\n"),
    (32.0, "Running stage 'windows@30':\n"),
    (92.0, "Updating lock file 'dvc.lock'\n"),
    (93.0, "Running stage 'train_ynet':\n"),
    (99.0, "ERROR: failed to reproduce 'train_ynet': exited with 1\n"),
]


def test_each_stage_that_ran_is_clocked_from_its_start_to_its_lock_update():
    assert timed_repro.stage_seconds(DVC_OUTPUT) == {"tracks": 30.5, "windows@30": 60.0}


def test_a_run_updates_the_stages_it_ran_and_keeps_the_others():
    previous = {"stages": {"tracks": {"seconds": 10.0, "run_started": "earlier"},
                           "fetch": {"seconds": 4.0, "run_started": "earlier"}}}
    run = {"started": "now", "seconds": 99.0}
    merged = timed_repro.merged_times(previous, {"tracks": 30.5, "windows@30": 60.0}, run)
    assert merged["stages"] == {"fetch": {"seconds": 4.0, "run_started": "earlier"},
                                "tracks": {"seconds": 30.5, "run_started": "now"},
                                "windows@30": {"seconds": 60.0, "run_started": "now"}}
    assert merged["last_run"] == run and list(merged["stages"]) == sorted(merged["stages"])
    # a stage dvc.yaml no longer defines loses its old time
    current = timed_repro.merged_times(previous, {"tracks": 30.5}, run, current={"tracks"})
    assert current["stages"] == {"tracks": {"seconds": 30.5, "run_started": "now"}}


def test_main_writes_the_times_and_renders_the_report_again(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    calls = []

    def fake_dvc(args, on_stage_done=None):
        calls.append(args)
        assert (tmp_path / timed_repro.STAGE_TIMES).exists()  # in place before the report runs
        return 0, DVC_OUTPUT[:7] if args == ["repro"] else []

    monkeypatch.setattr(timed_repro, "run_dvc", fake_dvc)
    monkeypatch.setattr(timed_repro, "current_stages", lambda: {"tracks", "windows@30"})
    assert timed_repro.main([]) == 0
    record = json.loads((tmp_path / timed_repro.STAGE_TIMES).read_text())
    assert set(record["stages"]) == {"tracks", "windows@30"}
    assert record["last_run"]["stages_run"] == ["tracks", "windows@30"]
    assert calls == [["repro"], ["repro", "report"]]
    calls.clear()
    monkeypatch.setattr(timed_repro, "run_dvc", lambda args, on_stage_done=None: (0, DVC_OUTPUT[:1]))  # nothing ran
    assert timed_repro.main([]) == 0
    assert json.loads((tmp_path / timed_repro.STAGE_TIMES).read_text()) == record


def test_a_run_stopped_midway_keeps_the_stages_it_finished(tmp_path, monkeypatch):
    """The file is written after every stage: killed during train_ynet, tracks and windows@30 stay
    clocked, and the run says it never saw dvc exit."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(timed_repro, "current_stages", lambda: {"tracks", "windows@30", "train_ynet"})

    def killed_dvc(args, on_stage_done=None):
        for end in (5, 7):  # the lines up to each lock update, as dvc prints them
            on_stage_done(DVC_OUTPUT[:end])
        raise KeyboardInterrupt  # the session ends here

    monkeypatch.setattr(timed_repro, "run_dvc", killed_dvc)
    with pytest.raises(KeyboardInterrupt):
        timed_repro.main([])
    record = json.loads((tmp_path / timed_repro.STAGE_TIMES).read_text())
    assert record["stages"] == {"tracks": {"seconds": 30.5, "run_started": record["last_run"]["started"]},
                                "windows@30": {"seconds": 60.0, "run_started": record["last_run"]["started"]}}
    assert record["last_run"]["exit_code"] is None


def test_the_report_lists_stages_longest_first_with_their_share(tmp_path):
    path = tmp_path / "stage_times.json"
    path.write_text(json.dumps(timed_repro.merged_times(
        {}, {"tracks": 30.0, "windows@30": 90.0}, {"started": "now", "seconds": 125.0})))
    profile = stage_profile(path)
    assert [(r["stage"], r["share"]) for r in profile["rows"]] == [("windows@30", 0.75), ("tracks", 0.25)]
    assert profile["total"] == 120.0 and profile["last_run"]["seconds"] == 125.0


@pytest.mark.parametrize("content, kind", [(None, "missing"), ("{not json", "invalid"),
                                           ('{"stages": {}, "last_run": null}', "missing"),
                                           ('{"stages": {"a": {}}, "last_run": {}}', "invalid")])
def test_the_report_says_why_there_are_no_stage_times(tmp_path, content, kind):
    path = tmp_path / "stage_times.json"
    if content is not None:
        path.write_text(content)
    absent = stage_profile(path)
    assert isinstance(absent, Absent) and absent.kind == kind and "stage_times.json" in absent.reason


def test_current_stages_are_those_dvc_yaml_defines(monkeypatch):
    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    names = timed_repro.current_stages()
    assert {"report", "evaluate_ynet", "train_baseline@sgan-30"} <= names
    assert not any(name.startswith("evaluate_constant_velocity") for name in names)  # dropped


def test_a_run_of_named_stages_renders_the_report_only_if_it_ran(tmp_path, monkeypatch):
    """`dvc repro report` after `timed_repro.py tracks` would run every other stale stage, unclocked."""
    monkeypatch.chdir(tmp_path)
    calls = []

    def fake_dvc(args, on_stage_done=None):
        calls.append(args)
        return 0, DVC_OUTPUT[:7] if args[0] == "repro" and len(calls) == 1 else []

    monkeypatch.setattr(timed_repro, "run_dvc", fake_dvc)
    monkeypatch.setattr(timed_repro, "current_stages", lambda: {"tracks", "windows@30"})
    assert timed_repro.main(["tracks", "windows"]) == 0
    assert calls == [["repro", "tracks", "windows"]]
    assert timed_repro.rerender_report(["--force"], {"tracks": 1.0})
    assert timed_repro.rerender_report(["evaluate_ynet", "report"], {"report": 5.0})
    assert not timed_repro.rerender_report(["evaluate_ynet"], {"evaluate_ynet": 5.0})


def test_jobs_is_taken_out_of_the_dvc_arguments():
    assert timed_repro.split_jobs(["--jobs", "2", "-f", "report"]) == (2, ["-f", "report"])
    assert timed_repro.split_jobs(["train_ynet"]) == (1, ["train_ynet"])
    for bad in (["--jobs"], ["--jobs", "two"], ["--jobs", "0"]):
        with pytest.raises(SystemExit, match="--jobs"):
            timed_repro.split_jobs(bad)


def test_address_is_taken_out_of_the_dvc_arguments():
    assert timed_repro.split_address(["--address", "tcp://h:8786", "-f"]) == ("tcp://h:8786",
                                                                              ["-f"])
    assert timed_repro.split_address(["report"]) == (None, ["report"])
    with pytest.raises(SystemExit, match="--address"):
        timed_repro.split_address(["--address"])


def test_with_jobs_parallel_repro_runs_the_stages_each_clocked(tmp_path, monkeypatch):
    """`make repro` passes --jobs 2: parallel_repro runs the stages, each finished stage is written
    to the file at once, and the record says how many ran at most at once."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(timed_repro, "current_stages", lambda: {"tracks", "windows@30", "report"})
    calls, written = [], []

    def fake_parallel(args, jobs, on_stage_done, address=None, insecure=False, dashboard=None):
        calls.append((args, jobs))
        for name, seconds in (("tracks", 30.5), ("windows@30", 60.0)):
            on_stage_done(name, seconds)
            written.append(json.loads((tmp_path / timed_repro.STAGE_TIMES).read_text()))
        return 0, {"tracks": 30.5, "windows@30": 60.0}

    monkeypatch.setattr(timed_repro, "run_parallel", fake_parallel)
    monkeypatch.setattr(timed_repro, "run_dvc", lambda args, on_stage_done=None: (0, []))
    assert timed_repro.main(["--jobs", "2", "-f"]) == 0
    assert calls == [(["-f"], 2)]
    assert list(written[0]["stages"]) == ["tracks"] and written[0]["last_run"]["exit_code"] is None
    record = json.loads((tmp_path / timed_repro.STAGE_TIMES).read_text())
    assert record["stages"]["windows@30"]["seconds"] == 60.0
    assert record["last_run"]["jobs"] == 2 and record["last_run"]["exit_code"] == 0
    assert record["last_run"]["command"] == "tools/parallel_repro.py --jobs 2 -f"


def test_insecure_and_dashboard_are_taken_out_and_passed_on(tmp_path, monkeypatch):
    """`make repro DASK_INSECURE=1 DASHBOARD=...` reaches parallel_repro; neither goes to dvc."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(timed_repro, "current_stages", lambda: {"tracks"})
    calls = []

    def fake_parallel(args, jobs, on_stage_done, address=None, insecure=False, dashboard=None):
        calls.append((args, jobs, address, insecure, dashboard))
        return 0, {}

    monkeypatch.setattr(timed_repro, "run_parallel", fake_parallel)
    assert timed_repro.main(["--jobs", "1", "--dashboard", "0.0.0.0:8787", "tracks"]) == 0
    assert timed_repro.main(["--jobs", "2", "--address", "tcp://192.0.2.1:8786", "--insecure",
                             "-f"]) == 0
    assert calls == [(["tracks"], 1, None, False, "0.0.0.0:8787"),  # the dashboard: parallel
                     (["-f"], 2, "tcp://192.0.2.1:8786", True, None)]
    with pytest.raises(SystemExit, match="--dashboard needs"):
        timed_repro.main(["--dashboard"])


def test_parallel_runs_take_stage_names_and_force_only():
    with pytest.raises(SystemExit, match="--dry"):
        timed_repro.run_parallel(["--dry"], 2, lambda name, seconds: None)
