"""tools/parallel_repro.py on a Dask cluster: the same outputs and lock as `dvc repro`, GPU stages
spread over the GPU workers, a dead worker's stage rerun (a training resuming), the stop signal
reaching a worker's command, and set-ups that cannot work failing before anything is written.

One module-scoped cluster of two worker processes, each offering 1 thread and a fake GPU
(CUDA_VISIBLE_DEVICES 0 and 1), built as `make repro` builds its own on a 2-GPU machine; each test
gets it with both workers up (`gpu_cluster`), so a test that killed a worker may run in any place
of the order. The tests wait on events (a file appearing, the scheduler's state), not on the
clock."""

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest
import yaml

from tests.test_parallel_repro import DVC, PYTHON, clean, make_project
from tools import parallel_repro, stage_worker
from tools.parallel_repro import SetupError

# a fake GPU stage: records which device it was given and when it ran; it ends once two such
# stages have started (or after 10 s), so two that run side by side overlap however slow the
# machine, and two that run one after the other do not
GPU_STEP = ("import glob, json, os, sys, time; start = time.time(); "
            "open(sys.argv[1] + '.started', 'w').close(); "
            "[time.sleep(0.05) for _ in range(200) if len(glob.glob('*.started')) < 2]; "
            "json.dump({'cuda': os.environ['CUDA_VISIBLE_DEVICES'], 'start': start, "
            "'end': time.time()}, open(sys.argv[1], 'w'))")
# a resumable training: one checkpoint per epoch in a persist output; each attempt noted; on
# SIGTERM it notes it and exits 143, as our trainings do once they saved a checkpoint. Its first
# attempt waits at epoch 2 (creating kill_me) until a SIGTERM ends it
TRAIN = """\
import json, os, pathlib, signal, sys, time
signal.signal(signal.SIGTERM, lambda *_: (open("terminated.txt", "a").write("x"), sys.exit(143)))
checkpoint = pathlib.Path("checkpoints/last.json")
checkpoint.parent.mkdir(exist_ok=True)
first_attempt = not checkpoint.exists()
epoch = 0 if first_attempt else json.loads(checkpoint.read_text())["epoch"]
with open("attempts.txt", "a") as attempts:
    attempts.write(f"{os.getpid()} {epoch}\\n")
for epoch in range(epoch, 6):
    if first_attempt and epoch == 2:
        pathlib.Path("kill_me").touch()
        time.sleep(60)
    checkpoint.write_text(json.dumps({"epoch": epoch + 1}))
pathlib.Path("model.txt").write_text("trained 6 epochs\\n")
"""


@pytest.fixture(scope="module")
def module_gpu_cluster():
    cluster = parallel_repro.start_local_cluster(2, gpus=["0", "1"])
    yield cluster
    cluster.close()


@pytest.fixture
def gpu_cluster(module_gpu_cluster):
    """The module's cluster once both its workers answer: a worker killed by an earlier test is
    restarted by its Nanny, and the scheduler may list the dead one for a moment."""
    from distributed import Client

    deadline = time.monotonic() + 60
    with Client(module_gpu_cluster, set_as_default=False) as client:
        while True:
            try:
                pids = client.run(os.getpid)
                if len(pids) == 2 and all(psutil.pid_exists(pid) for pid in pids.values()):
                    return module_gpu_cluster
            except OSError:  # a dead worker still listed
                pass
            assert time.monotonic() < deadline, "the cluster did not get its two workers back"
            time.sleep(0.2)


@pytest.fixture
def project(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def write_dvc_yaml(root: Path, stages: dict, params: str = "") -> None:
    subprocess.run([*DVC, "init", "--no-scm", "-q"], cwd=root, check=True)
    (root / "params.yaml").write_text(params or "job:\n  threads: 1\n")
    (root / "dvc.yaml").write_text(yaml.safe_dump({"stages": stages}))


# right's first command: wait (up to 30 s) until left is locked, so that dvc.lock lists the stages
# in a serial run's order (DVC appends each stage as it is locked) however the two are timed
AFTER_LEFT_IS_LOCKED = ("import pathlib, time; lock = pathlib.Path('dvc.lock'); "
                        "any('left:' in (lock.read_text() if lock.exists() else '') "
                        "or time.sleep(0.05) for _ in range(600))")


def deterministic_stages() -> dict:
    def write(path: str, text: str) -> str:
        return f"{PYTHON} -c \"open('{path}', 'w').write('{text}')\""
    return {"prep": {"cmd": write("prep.txt", "x"), "outs": ["prep.txt"]},
            "left": {"cmd": write("left.txt", "l"), "deps": ["prep.txt"],
                     "params": ["job.threads"], "outs": ["left.txt"]},
            "right": {"cmd": [f"{PYTHON} -c \"{AFTER_LEFT_IS_LOCKED}\"", write("right.txt", "r"),
                              write("right2.txt", "s")],
                      "deps": ["prep.txt"], "outs": ["right.txt", "right2.txt"]},
            "join": {"cmd": write("join.txt", "y"), "deps": ["left.txt", "right.txt"],
                     "outs": ["join.txt"]}}


def gpu_stages(count: int) -> dict:
    return {f"g{i}": {"cmd": f"{PYTHON} -c \"{GPU_STEP}\" g{i}.json", "params": ["runtime.device"],
                      "outs": [f"g{i}.json"]} for i in range(count)}


def when(path: Path, timeout: float = 30, empty_ok: bool = False) -> str:
    """The file's text once it exists (and, unless `empty_ok`, holds something)."""
    deadline = time.monotonic() + timeout
    while not path.exists() or not (empty_ok or path.read_text()):
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.05)
    return path.read_text()


# -- pure parts ---------------------------------------------------------------------------------

def test_a_stage_asks_for_a_gpu_when_its_runtime_device_is_cuda_or_auto_with_gpus_around():
    assert parallel_repro.stage_resources("shared", "cuda", None, 4, False) == {"threads": 1,
                                                                               "GPU": 1}
    assert parallel_repro.stage_resources("alone", "cuda:1", None, 4, True)["GPU"] == 1
    assert "GPU" in parallel_repro.stage_resources("alone", "auto", None, 4, True)
    assert "GPU" not in parallel_repro.stage_resources("alone", "auto", None, 4, False)
    assert "GPU" not in parallel_repro.stage_resources("alone", "cpu", None, 4, True)
    assert "GPU" not in parallel_repro.stage_resources("shared", None, None, 4, True)


def test_the_local_cluster_has_one_worker_per_gpu_or_one_with_every_core():
    assert parallel_repro.local_worker_specs(2, [], 8.0) == [
        {"nthreads": 2, "resources": {"threads": 2, "memory_gb": 8.0}}]
    two = parallel_repro.local_worker_specs(16, ["0", "3"], 64.0)
    assert [spec["env"] for spec in two] == [{"CUDA_VISIBLE_DEVICES": "0"},
                                              {"CUDA_VISIBLE_DEVICES": "3"}]
    assert two[1]["resources"] == {"threads": 8, "memory_gb": 32.0, "GPU": 1}


def test_gpus_are_counted_from_cuda_visible_devices_else_nvidia_smi():
    listing = "GPU 0: NVIDIA H100 (UUID: GPU-a)\nGPU 1: NVIDIA H100 (UUID: GPU-b)\n"
    assert parallel_repro.visible_gpus(None, listing) == ["0", "1"]
    assert parallel_repro.visible_gpus("2,5", listing) == ["2", "5"]
    assert parallel_repro.visible_gpus("", listing) == []
    assert parallel_repro.visible_gpus("-1", listing) == []
    assert parallel_repro.visible_gpus(None, "") == []


def test_a_command_ended_by_its_machine_is_retried_and_the_stages_own_failure_is_not():
    interrupted = stage_worker.interrupted
    assert interrupted(-signal.SIGKILL, None, False) and interrupted(137, None, False)
    assert interrupted(143, None, False)  # a training that saved its checkpoint on SIGTERM
    assert interrupted(1, None, True)  # whatever it ended with while its worker shut down
    assert not interrupted(1, None, False) and not interrupted(0, None, True)
    assert not interrupted(-signal.SIGTERM, signal.SIGTERM, False)  # the driver's stop


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="prctl is Linux's")
def test_a_command_is_launched_to_die_with_its_worker():
    argv = ["/bin/sh", "-c", "exit 3"]
    launched = stage_worker.launcher(argv)
    assert launched[:3] == [sys.executable, "-c", stage_worker.DIE_WITH_WORKER]
    assert launched[3] == str(os.getpid()) and launched[4:] == argv
    assert subprocess.run(launched).returncode == 3  # it ends as the command does
    assert subprocess.run([*launched[:3], "1", *argv]).returncode == 143  # its parent is gone
    killed = stage_worker.launcher(["/bin/sh", "-c", "kill -KILL $$"])
    assert subprocess.run(killed).returncode == 128 + signal.SIGKILL  # as a shell says it


def test_a_stage_no_worker_can_take_is_named():
    offered = {"tcp://a": {"threads": 2}, "tcp://b": {"threads": 1, "GPU": 1}}
    wanted = {"seg": {"threads": 1, "GPU": 1}, "big": {"threads": 2, "GPU": 1},
              "data": {"threads": 2}, "huge": {"threads": 1, "memory_gb": 4}}
    assert parallel_repro.unplaceable(wanted, offered) == ["big", "huge"]


class FakeClient:
    def __init__(self, services: dict):
        self.services = services
        self.dashboard_link = "http://127.0.0.1:8787/status"

    def scheduler_info(self) -> dict:
        return {"address": "tcp://127.0.0.1:8786", "services": self.services}


def test_the_local_cluster_does_not_profile_and_samples_its_monitors_seldom(gpu_cluster):
    """Dask's own periodic work competes with the stages for the cores: off or seldom, in the
    in-process worker (no GPU) and in worker processes (GPUs) alike."""
    def periodic(dask_worker):
        return {name: callback.callback_time
                for name, callback in dask_worker.periodic_callbacks.items()}

    in_process = parallel_repro.start_local_cluster(2, gpus=[])
    try:
        every = [periodic(in_process.workers[0])]
    finally:
        in_process.close()
    from distributed import Client
    with Client(gpu_cluster, set_as_default=False) as client:
        every += list(client.run(periodic).values())
    for callbacks in every:
        assert "profile" not in callbacks and "profile-cycle" not in callbacks
        assert callbacks["tick"] >= 1000 and callbacks["monitor"] >= 5000
        assert callbacks["memory_monitor"] >= 5000


def test_the_run_says_where_the_scheduler_and_its_dashboard_are():
    offered = {"w1": {"threads": 8, "GPU": 1}}
    with_one = parallel_repro.cluster_line(FakeClient({"dashboard": 8787}), offered)
    assert "tcp://127.0.0.1:8786" in with_one and "1 worker(s)" in with_one
    assert "dashboard: http://127.0.0.1:8787/status" in with_one
    assert parallel_repro.cluster_line(FakeClient({}), offered).endswith("dashboard: none")


def test_a_worker_seeing_other_code_or_no_project_is_told_apart(tmp_path):
    (tmp_path / "dvc.yaml").write_text("stages: {}\n")
    (tmp_path / "step.py").write_text("print(1)\n")
    before = stage_worker.project_fingerprint(str(tmp_path))
    assert parallel_repro.fingerprint_differences(before, before, "/r") == []
    (tmp_path / "step.py").write_text("print(2)\n")
    after = stage_worker.project_fingerprint(str(tmp_path))
    [difference] = parallel_repro.fingerprint_differences(before, after, "/r")
    assert difference.startswith("python_sha256")
    missing = stage_worker.project_fingerprint(str(tmp_path / "nowhere"))
    assert parallel_repro.fingerprint_differences(before, missing, "/r") == ["no DVC project at /r"]


# -- on the cluster -----------------------------------------------------------------------------

def test_the_cluster_writes_the_outputs_and_lock_of_dvc_repro(project, gpu_cluster):
    serial, dask = project / "serial", project / "dask"
    for root in (serial, dask):
        root.mkdir()
        write_dvc_yaml(root, deterministic_stages())
    os.chdir(dask)  # (the project fixture's monkeypatch restores the working directory)
    subprocess.run([*DVC, "repro", "-q"], cwd=serial, check=True)
    code, seconds = parallel_repro.run_stages([], root=str(dask),
                                              address=gpu_cluster.scheduler_address)
    assert code == 0 and set(seconds) == {"prep", "left", "right", "join"}
    assert (dask / "dvc.lock").read_text() == (serial / "dvc.lock").read_text()
    assert (dask / "right2.txt").read_text() == "s" and clean(dask)


def test_gpu_stages_get_a_gpu_each_and_a_third_waits(project, gpu_cluster, capsys):
    write_dvc_yaml(project, gpu_stages(3), params="runtime:\n  device: cuda\n")
    code, _ = parallel_repro.run_stages([], root=str(project),
                                        address=gpu_cluster.scheduler_address)
    assert code == 0
    runs = sorted((json.loads((project / f"g{i}.json").read_text()) for i in range(3)),
                  key=lambda run: run["start"])
    first, second, third = runs
    assert first["start"] < second["end"] and second["start"] < first["end"]  # side by side
    assert {first["cuda"], second["cuda"]} == {"0", "1"}
    assert third["start"] >= min(first["end"], second["end"])  # waited for a free GPU
    assert "[g0] > " in capsys.readouterr().out  # the worker's log reached our stdout, labelled


def test_a_gpu_stage_on_a_cpu_only_cluster_fails_before_anything_is_written(project):
    from distributed import LocalCluster

    write_dvc_yaml(project, {**deterministic_stages(), **gpu_stages(1)},
                   params="job:\n  threads: 1\nruntime:\n  device: cuda\n")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, resources={"threads": 1},
                      dashboard_address=None) as cluster:
        with pytest.raises(SetupError, match="stage 'g0' needs"):
            parallel_repro.run_stages([], root=str(project), address=cluster.scheduler_address)
    assert not (project / "dvc.lock").exists() and not (project / "prep.txt").exists()


def test_a_worker_that_does_not_say_which_project_it_sees_is_named_in_time(project, gpu_cluster,
                                                                          monkeypatch):
    """As on a hung NFS mount: one worker's project check blocks; the run stops within the
    timeout, names that worker alone, and writes nothing."""
    from distributed import Client

    write_dvc_yaml(project, deterministic_stages())
    with Client(gpu_cluster, set_as_default=False) as client:
        hung, answering = sorted(client.scheduler_info()["workers"])
    fingerprint = stage_worker.project_fingerprint

    def hangs_on_one_worker(root, dask_worker=None):  # client.run passes its worker
        if dask_worker is not None and dask_worker.address == hung:
            time.sleep(4)
        return fingerprint(root)

    monkeypatch.setattr(stage_worker, "project_fingerprint", hangs_on_one_worker)
    since = time.monotonic()
    with pytest.raises(SetupError, match="no answer within 1 s") as raised:
        parallel_repro.run_stages([], root=str(project), address=gpu_cluster.scheduler_address,
                                  connect_timeout=1)
    assert time.monotonic() - since < 4
    assert hung in str(raised.value) and answering not in str(raised.value)
    assert not (project / "dvc.lock").exists() and not (project / "prep.txt").exists()


def test_an_unreachable_scheduler_fails_fast_and_names_its_address(project):
    write_dvc_yaml(project, deterministic_stages())
    since = time.monotonic()
    with pytest.raises(SetupError, match="tcp://127.0.0.1:9"):
        parallel_repro.run_stages([], root=str(project), address="tcp://127.0.0.1:9",
                                  connect_timeout=3)
    assert time.monotonic() - since < 20
    assert not (project / "dvc.lock").exists()


def test_a_failed_stage_ends_the_run_and_only_finished_stages_are_locked(project, gpu_cluster):
    make_project(project, right="fail")
    code, seconds = parallel_repro.run_stages([], root=str(project),
                                              address=gpu_cluster.scheduler_address)
    assert code == 1 and set(seconds) == {"prep", "left"}
    assert set(yaml.safe_load((project / "dvc.lock").read_text())["stages"]) == {"prep", "left"}
    assert not (project / "join.txt").exists()


def test_the_stop_signal_reaches_a_command_on_a_worker(project, gpu_cluster):
    trap = ("import signal, sys, time; "
            "signal.signal(signal.SIGTERM, lambda *_: (open('got_term', 'w').write('x'), "
            "sys.exit(143))); open('started', 'w').write('x'); time.sleep(60)")
    write_dvc_yaml(project, {"wait": {"cmd": f"{PYTHON} -c \"{trap}\"", "outs": ["never.txt"]}})
    driver = os.getpid()
    threading.Thread(target=lambda: (when(project / "started"), os.kill(driver, signal.SIGTERM)),
                     daemon=True).start()
    since = time.monotonic()
    code, seconds = parallel_repro.run_stages([], root=str(project),
                                              address=gpu_cluster.scheduler_address)
    assert code == 128 + signal.SIGTERM and seconds == {}
    assert (project / "got_term").exists() and time.monotonic() - since < 30
    assert not (project / "dvc.lock").exists()  # nothing finished, nothing locked


def test_a_command_its_machine_killed_is_retried_and_a_failing_one_is_not(project, gpu_cluster):
    """`dies` is SIGKILLed on its first try (as by the OOM killer, or its machine going down a
    moment before its worker could tell): retried, it finishes; `fails` exits 1: not retried."""
    once = ("import os, pathlib, signal; tries = pathlib.Path('tries'); "
            "tries.write_text(tries.read_text() + 'x' if tries.exists() else 'x'); "
            "len(tries.read_text()) > 1 or os.kill(os.getpid(), signal.SIGKILL); "
            "pathlib.Path('dies.txt').write_text('ok')")
    fail = ("import pathlib, sys; failed = pathlib.Path('failed'); "
            "failed.write_text(failed.read_text() + 'x' if failed.exists() else 'x'); sys.exit(1)")
    write_dvc_yaml(project, {"dies": {"cmd": f"{PYTHON} -c \"{once}\"", "outs": ["dies.txt"]},
                             "fails": {"cmd": f"{PYTHON} -c \"{fail}\"", "deps": ["dies.txt"],
                                       "outs": ["never.txt"]}})
    code, seconds = parallel_repro.run_stages([], root=str(project),
                                              address=gpu_cluster.scheduler_address)
    assert code == 1 and set(seconds) == {"dies"}
    assert (project / "tries").read_text() == "xx" and (project / "dies.txt").read_text() == "ok"
    assert (project / "failed").read_text() == "x"


# DVC runs a command through $SHELL, else /bin/sh; dash (/bin/sh on Debian, and CI sets no SHELL)
# forks the command where bash execs it, so the worker's death must reach a grandchild too
@pytest.mark.parametrize("shell", ["/bin/bash", "/bin/sh"])
def test_a_worker_killed_mid_training_its_stage_resumes_elsewhere(project, gpu_cluster, shell,
                                                                 monkeypatch):
    """As if the OOM killer took the worker: the worker gets SIGKILL after the first epochs, its
    command SIGTERM through its supervisor (rather than running on beside its retry); the task runs
    again, the checkpoint (a persist output) is still there, the training resumes, and the lock is
    an uninterrupted run's."""
    monkeypatch.setenv("SHELL", shell)
    from distributed import Client

    (project / "train.py").write_text(TRAIN)
    write_dvc_yaml(project, {"train": {
        "cmd": f"{PYTHON} train.py", "deps": ["train.py"], "params": ["job.threads"],
        "outs": ["model.txt", {"checkpoints": {"persist": True}}]}})
    with Client(gpu_cluster, set_as_default=False) as client:
        worker_pids = set(client.run(os.getpid).values())

    def kill_the_worker_after_two_epochs():
        pid = int(when(project / "attempts.txt").split()[0])
        when(project / "kill_me", empty_ok=True)
        [worker] = [p.pid for p in psutil.Process(pid).parents() if p.pid in worker_pids]
        os.kill(worker, signal.SIGKILL)

    killer = threading.Thread(target=kill_the_worker_after_two_epochs, daemon=True)
    killer.start()
    code, seconds = parallel_repro.run_stages([], root=str(project),
                                              address=gpu_cluster.scheduler_address)
    killer.join(timeout=1)
    assert code == 0 and set(seconds) == {"train"}
    assert (project / "terminated.txt").read_text() == "x"  # the first try: SIGTERM, once
    attempts = [line.split() for line in (project / "attempts.txt").read_text().splitlines()]
    assert len(attempts) == 2 and int(attempts[1][1]) == 2  # the second resumed at epoch 2
    assert (project / "model.txt").read_text() == "trained 6 epochs\n" and clean(project)


def scheduler_keys(client, prefix: str) -> list[str]:
    """The task keys the scheduler still holds that start with `prefix`."""
    return client.run_on_scheduler(
        lambda dask_scheduler: [str(key) for key in dask_scheduler.tasks
                                if str(key).startswith(prefix)])


def test_a_locked_stage_is_forgotten_so_losing_its_worker_later_does_not_run_it_again(
        project, gpu_cluster):
    """Once `first` is locked the scheduler no longer holds its task; had the runner kept it,
    losing the worker that holds its result (killed here while `second` waits to start) would make
    the scheduler run `first`'s command again, behind DVC's back."""
    from distributed import Client

    ancestors = ("import json, pathlib, psutil; pathlib.Path('first.txt').write_text('1'); "
                 "open('runs.txt', 'a').write(json.dumps([p.pid for p in "
                 "psutil.Process().parents()]) + chr(10))")
    write_dvc_yaml(project, {
        "first": {"cmd": f"{PYTHON} -c \"{ancestors}\"", "outs": ["first.txt"]},
        "second": {"cmd": f"{PYTHON} -c \"open('second.txt', 'w').write('2')\"",
                   "deps": ["first.txt"], "outs": ["second.txt"]}})
    seen: dict[str, object] = {}
    with Client(gpu_cluster, set_as_default=False) as client:
        address_of = {pid: address for address, pid in client.run(os.getpid).items()}

        def on_stage_done(name: str, _seconds: float) -> None:
            if name != "first":
                return
            deadline = time.monotonic() + 10
            while scheduler_keys(client, "stage-first-") and time.monotonic() < deadline:
                time.sleep(0.05)
            seen["still held"] = scheduler_keys(client, "stage-first-")
            [run] = [json.loads(line) for line in (project / "runs.txt").read_text().splitlines()]
            [worker] = [pid for pid in run if pid in address_of]
            os.kill(worker, signal.SIGKILL)
            while address_of[worker] in client.scheduler_info()["workers"]:
                assert time.monotonic() < deadline + 30, "the scheduler never noticed"
                time.sleep(0.05)

        code, seconds = parallel_repro.run_stages([], root=str(project),
                                                  on_stage_done=on_stage_done,
                                                  address=gpu_cluster.scheduler_address)
    assert seen["still held"] == []
    assert code == 0 and set(seconds) == {"first", "second"}
    assert len((project / "runs.txt").read_text().splitlines()) == 1  # first's command ran once
    assert clean(project)
