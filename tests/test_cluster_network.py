"""Who can reach the cluster `make repro` runs on (tools/parallel_repro.py): a local run listens
on loopback only, its workers too; a plain tcp:// scheduler on another machine is refused before
anything runs (no connection tried: the address is TEST-NET's 192.0.2.1, never contacted); a
tls:// LocalCluster in a process of its own (which cannot import tools/), with certificates the
test makes (Dask's `Security.temporary`, through cryptography), runs a stage. Nothing here opens a
socket beyond loopback."""

import ipaddress
import os
import socket
import subprocess
import threading
import time
from pathlib import Path

import psutil
import pytest
import yaml

from tests.test_parallel_repro import DVC, PYTHON, clean
from tools import parallel_repro, timed_repro
from tools.parallel_repro import SetupError

NETWORK_TCP = "tcp://192.0.2.1:8786"  # TEST-NET-1 (RFC 5737): refused before any traffic
# a stage that says when it runs, then waits until the test has looked around
LOOK = """\
import pathlib, time
pathlib.Path("running").touch()
deadline = time.monotonic() + 30
while not pathlib.Path("looked").exists() and time.monotonic() < deadline:
    time.sleep(0.05)
pathlib.Path("out.txt").write_text("ok")
"""


@pytest.fixture
def project(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def one_stage_project(root: Path, command: str) -> None:
    subprocess.run([*DVC, "init", "--no-scm", "-q"], cwd=root, check=True)
    (root / "stage.py").write_text(command)
    (root / "dvc.yaml").write_text(yaml.safe_dump({"stages": {"only": {
        "cmd": f"{PYTHON} stage.py", "deps": ["stage.py"], "outs": ["out.txt"]}}}))


def listening_sockets(pids: list[int]) -> list[tuple[int, str, int]]:
    """(pid, address, port) of every TCP/UDP socket these processes listen on."""
    found = []
    for pid in pids:
        try:
            connections = psutil.Process(pid).net_connections(kind="inet")
        except psutil.NoSuchProcess:  # a short-lived child, gone since it was listed
            continue
        for conn in connections:
            if conn.status == psutil.CONN_LISTEN or (conn.type == socket.SOCK_DGRAM
                                                     and not conn.raddr):
                found.append((pid, conn.laddr.ip, conn.laddr.port))
    return found


def no_connection(*_args, **_kwargs):
    raise AssertionError("a connection to the scheduler was tried")


# -- pure parts ---------------------------------------------------------------------------------

def test_a_plain_address_is_refused_only_when_it_leaves_this_machine():
    refused = parallel_repro.address_refusal
    for address in (NETWORK_TCP, "192.0.2.1:8786", "tcp://login-node:8786", "ws://192.0.2.1:80",
                    "ucx://192.0.2.1:13337"):
        assert refused(address, insecure=False), address
        assert refused(address, insecure=True) is None, address
    for address in ("tcp://127.0.0.1:8786", "tcp://127.0.1.1:8786", "tcp://[::1]:8786",
                    "localhost:8786", "tls://192.0.2.1:8786", "wss://login-node:443",
                    "inproc://192.0.2.2/12/1"):
        assert refused(address, insecure=False) is None, address
    with pytest.raises(SetupError, match="'tcp://\\[::1' is not a Dask scheduler address"):
        parallel_repro.check_address("tcp://[::1")


def test_the_refusal_names_what_is_wrong_and_both_fixes():
    message = parallel_repro.address_refusal(NETWORK_TCP, insecure=False)
    assert message.startswith(f"refusing the Dask scheduler at {NETWORK_TCP}: plain TCP")
    assert "tls://192.0.2.1:8786" in message and "distributed.comm.tls.ca-file" in message
    assert "DASK_DISTRIBUTED__COMM__TLS__CA_FILE" in message
    assert "--insecure (make repro DASK_INSECURE=1)" in message


def test_insecure_says_so_only_where_it_lets_plain_tcp_through():
    notice = parallel_repro.insecure_notice(NETWORK_TCP, insecure=True)
    assert "--insecure" in notice and NETWORK_TCP in notice and "plain TCP" in notice
    assert parallel_repro.insecure_notice(NETWORK_TCP, insecure=False) is None
    assert parallel_repro.insecure_notice("tcp://127.0.0.1:8786", insecure=True) is None


def test_a_dashboard_beyond_loopback_is_announced_with_its_risk():
    for wide in ("0.0.0.0:8787", ":8787", "8787", "192.0.2.2:8787"):
        notice = parallel_repro.dashboard_notice(wide)
        assert "open to the network" in notice and "every stage's command and log" in notice
    for narrow in ("127.0.0.1:0", "localhost:8787", "[::1]:8787"):
        assert parallel_repro.dashboard_notice(narrow) is None
    assert parallel_repro.dashboard_link("127.0.0.1", 8787) == "http://127.0.0.1:8787/status"
    assert parallel_repro.dashboard_link("::1", 8787) == "http://[::1]:8787/status"


def test_tls_without_certificates_is_named_with_the_settings_to_make():
    import dask

    with dask.config.set({"distributed.comm.tls.ca-file": None,
                          "distributed.comm.tls.client.cert": None}):
        with pytest.raises(SetupError, match="needs TLS certificates: a CA file and a client "
                                             "certificate: set Dask's config"):
            parallel_repro.check_address("tls://192.0.2.1:8786")


def test_the_certificate_paths_come_from_the_environment_too(tmp_path):
    env = {**os.environ, "DASK_DISTRIBUTED__COMM__TLS__CA_FILE": str(tmp_path / "ca.pem"),
           "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": str(tmp_path / "client.pem"),
           "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY": str(tmp_path / "client.key")}
    shown = subprocess.run(
        [PYTHON, "-c", "from tools import parallel_repro; s = parallel_repro.check_address("
         "'tls://192.0.2.1:8786'); print(s.tls_ca_file, s.tls_client_cert, s.tls_client_key)"],
        cwd=Path(__file__).resolve().parents[1], env=env, capture_output=True, text=True,
        check=True).stdout.split()
    assert shown == [str(tmp_path / name) for name in ("ca.pem", "client.pem", "client.key")]


# -- before anything runs -----------------------------------------------------------------------

def test_a_plain_tcp_scheduler_on_the_network_is_refused_before_anything_runs(project,
                                                                               monkeypatch):
    import distributed

    one_stage_project(project, "open('out.txt', 'w').write('ran')")
    monkeypatch.setattr(parallel_repro, "connect", no_connection)
    monkeypatch.setattr(distributed, "Client", no_connection)
    with pytest.raises(SetupError, match="refusing the Dask scheduler at tcp://192.0.2.1:8786"):
        parallel_repro.run_stages([], root=str(project), address=NETWORK_TCP)
    assert parallel_repro.main(["--address", NETWORK_TCP]) == 2
    with pytest.raises(SystemExit, match="timed_repro: refusing the Dask scheduler"):
        timed_repro.main(["--jobs", "2", "--address", NETWORK_TCP])
    assert not (project / "dvc.lock").exists() and not (project / "out.txt").exists()
    assert not (project / timed_repro.STAGE_TIMES).exists()  # timed_repro wrote nothing either


def test_insecure_lets_plain_tcp_through_and_says_so(project, monkeypatch, capsys):
    one_stage_project(project, "open('out.txt', 'w').write('ran')")
    tried = []

    def stop_at_connect(address, timeout, security=None):
        tried.append((address, security))
        raise SetupError("stopped where it would connect")

    monkeypatch.setattr(parallel_repro, "connect", stop_at_connect)
    with pytest.raises(SetupError, match="stopped where it would connect"):
        parallel_repro.run_stages([], root=str(project), address=NETWORK_TCP, insecure=True)
    assert tried == [(NETWORK_TCP, None)]
    assert "parallel_repro: --insecure: the Dask scheduler at tcp://192.0.2.1:8786 is reached " \
           "over plain TCP" in capsys.readouterr().err


def test_the_dashboard_option_is_for_the_local_cluster_only(project, monkeypatch):
    monkeypatch.setattr(parallel_repro, "connect", no_connection)
    with pytest.raises(SetupError, match="--dashboard is for the local cluster"):
        parallel_repro.run_stages([], root=str(project), address="tls://127.0.0.1:8786",
                                  dashboard="0.0.0.0:8787")


# -- on a cluster -------------------------------------------------------------------------------

@pytest.mark.parametrize("gpus", [[], ["0", "1"]], ids=["cpu", "two-fake-gpus"])
def test_a_local_run_listens_on_loopback_only(project, monkeypatch, capsys, gpus):
    """Every socket the driver (scheduler, in-process worker, dashboards) and its worker processes
    listen on while a stage runs, as `make repro` starts them; the printed dashboard is on
    loopback too."""
    monkeypatch.setattr(parallel_repro, "machine_gpus", lambda: gpus)
    one_stage_project(project, LOOK)
    looked: list[tuple[int, str, int]] = []

    def look_around():
        deadline = time.monotonic() + 60
        while not (project / "running").exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        driver = psutil.Process()
        looked.extend(listening_sockets([driver.pid] + [child.pid for child in
                                                        driver.children(recursive=True)]))
        (project / "looked").touch()

    looker = threading.Thread(target=look_around, daemon=True)
    looker.start()
    code, seconds = parallel_repro.run_stages([], jobs=2, root=str(project))
    looker.join(timeout=5)
    assert code == 0 and set(seconds) == {"only"}
    assert looked, "nothing listened: the dashboard at least should"
    wide = [entry for entry in looked if not ipaddress.ip_address(entry[1]).is_loopback]
    assert wide == [], f"listening beyond loopback: {wide}"
    if gpus:  # the worker processes were looked at too
        assert {pid for pid, _, _ in looked} - {os.getpid()}
    assert "dashboard: http://127.0.0.1:" in capsys.readouterr().out


def write_test_certificates(folder: Path) -> dict[str, str]:
    """A self-signed certificate and its key (Dask's own helper, through cryptography) in files,
    as Dask's config names them: {config key: path}."""
    from distributed import Security

    made = Security.temporary()
    files = {"ca.pem": made.tls_ca_file, "cert.pem": made.tls_client_cert,
             "key.pem": made.tls_client_key}
    for name, text in files.items():
        (folder / name).write_text(text)
        (folder / name).chmod(0o600)
    return {"distributed.comm.tls.ca-file": str(folder / "ca.pem"),
            "distributed.comm.tls.client.cert": str(folder / "cert.pem"),
            "distributed.comm.tls.client.key": str(folder / "key.pem")}


# a tls:// LocalCluster in a process of its own, as a cluster of other machines would be: it
# cannot import tools/, so the stage's task must reach it by value. argv: its folder, holding the
# certificates; it writes its address there and ends once `stop` appears
TLS_CLUSTER = """\
import pathlib, sys, time
from distributed import LocalCluster, Security
folder = pathlib.Path(sys.argv[1])
cert, key = str(folder / "cert.pem"), str(folder / "key.pem")
security = Security(tls_ca_file=str(folder / "ca.pem"), tls_scheduler_cert=cert,
                    tls_scheduler_key=key, tls_worker_cert=cert, tls_worker_key=key,
                    tls_client_cert=cert, tls_client_key=key, require_encryption=True)
with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, protocol="tls",
                  host="127.0.0.1", security=security, resources={"threads": 2},
                  dashboard_address=None) as cluster:
    (folder / "address").write_text(cluster.scheduler_address)
    deadline = time.monotonic() + 120
    while not (folder / "stop").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
"""


def test_a_tls_cluster_runs_a_stage_with_the_certificates_from_dasks_config(project,
                                                                           tmp_path_factory,
                                                                           capsys):
    import dask

    folder = tmp_path_factory.mktemp("tls")
    settings = write_test_certificates(folder)
    one_stage_project(project, "open('out.txt', 'w').write('over tls')")
    cluster = subprocess.Popen([PYTHON, "-c", TLS_CLUSTER, str(folder)], cwd=folder,
                               env={key: value for key, value in os.environ.items()
                                    if key != "PYTHONPATH"})
    try:
        deadline = time.monotonic() + 60
        while not (folder / "address").exists():
            assert cluster.poll() is None and time.monotonic() < deadline, "no TLS cluster"
            time.sleep(0.05)
        address = (folder / "address").read_text()
        assert address.startswith("tls://127.0.0.1:")
        with dask.config.set(settings):
            code, seconds = parallel_repro.run_stages([], root=str(project), address=address)
    finally:
        (folder / "stop").touch()
        cluster.wait(timeout=60)
    assert code == 0 and set(seconds) == {"only"}
    assert (project / "out.txt").read_text() == "over tls" and clean(project)
    assert f"Dask scheduler {address}" in capsys.readouterr().out


def test_the_stage_task_unpickles_where_tools_cannot_be_imported():
    """What the scheduler of another machine does with the task graph: plain pickle would name
    stage_worker, a module only tools/ holds."""
    from distributed.protocol.pickle import dumps

    graph = dumps({"stage-x": (parallel_repro.ByValue(parallel_repro.stage_worker.run_commands),
                               [], ".", {}, "log", False)})
    loaded = subprocess.run(
        [PYTHON, "-c", "import pickle, sys; task = pickle.loads(sys.stdin.buffer.read()); "
         "print(task['stage-x'][0].__name__)"],
        input=graph, cwd="/", capture_output=True, check=True, env={
            key: value for key, value in os.environ.items() if key != "PYTHONPATH"})
    assert loaded.stdout.decode().strip() == "run_commands"
