import functools
import http.server
import threading

import pytest

from pipeline.config import FetchParams
from pipeline.data.fetch import FetchError, fetch_source
from tests.fixtures import write_manifest


@pytest.fixture
def source(tmp_path):
    """A location holding a small 'sdd' source and its manifest."""
    root = tmp_path / "mirror" / "sdd"
    (root / "annotations" / "gates" / "video2").mkdir(parents=True)
    (root / "annotations" / "gates" / "video2" / "annotations.txt").write_text('1 0 0 1 1 0 0 0 0 "Pedestrian"\n')
    (root / "H_SDD.txt").write_text("ratios\n")
    manifest = tmp_path / "manifests" / "sdd.sha256"
    write_manifest(root, manifest)
    return tmp_path / "mirror", manifest


def test_fetch_copies_and_verifies(tmp_path, source):
    mirror, manifest = source
    out = tmp_path / "data" / "raw" / "sdd"
    used = fetch_source("sdd", manifest, out, FetchParams(locations=[str(mirror)]))
    assert used == str(mirror)
    assert (out / "H_SDD.txt").read_text() == "ratios\n"
    assert (out / "annotations/gates/video2/annotations.txt").exists()
    assert sorted(p.name for p in out.parent.iterdir()) == ["sdd"]  # no staging left behind


def test_fetch_falls_back_to_next_location(tmp_path, source):
    mirror, manifest = source
    out = tmp_path / "out" / "sdd"
    missing = tmp_path / "nowhere"
    used = fetch_source("sdd", manifest, out, FetchParams(locations=[str(missing), str(mirror)]))
    assert used == str(mirror)


def test_wrong_checksum_fails_cleanly(tmp_path, source):
    mirror, manifest = source
    (mirror / "sdd" / "H_SDD.txt").write_text("tampered\n")
    out = tmp_path / "out" / "sdd"
    with pytest.raises(FetchError) as error:
        fetch_source("sdd", manifest, out, FetchParams(locations=[str(mirror)]))
    message = str(error.value)
    assert "checksum mismatch H_SDD.txt" in message and str(mirror) in message
    assert list(out.parent.iterdir()) == []  # neither the output nor a staging folder


def test_missing_source_names_every_location(tmp_path, source):
    _, manifest = source
    out = tmp_path / "out" / "sdd"
    locations = [str(tmp_path / "a"), str(tmp_path / "b")]
    with pytest.raises(FetchError) as error:
        fetch_source("sdd", manifest, out, FetchParams(locations=locations))
    message = str(error.value)
    assert all(location in message for location in locations)
    assert "missing H_SDD.txt" in message
    assert not out.exists()


def test_failed_refetch_keeps_previous_output(tmp_path, source):
    mirror, manifest = source
    out = tmp_path / "out" / "sdd"
    fetch_source("sdd", manifest, out, FetchParams(locations=[str(mirror)]))
    (mirror / "sdd" / "H_SDD.txt").unlink()
    with pytest.raises(FetchError):
        fetch_source("sdd", manifest, out, FetchParams(locations=[str(mirror)]))
    assert (out / "H_SDD.txt").read_text() == "ratios\n"


@pytest.fixture
def http_server(source):
    mirror, _ = source
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(mirror))
    handler.log_message = lambda *args: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def test_fetch_over_http(tmp_path, source, http_server):
    _, manifest = source
    out = tmp_path / "out" / "sdd"
    used = fetch_source("sdd", manifest, out, FetchParams(locations=[http_server], timeout_s=5))
    assert used == http_server
    assert (out / "H_SDD.txt").read_text() == "ratios\n"


def test_http_404_is_reported_as_missing(tmp_path, source, http_server):
    mirror, manifest = source
    (mirror / "sdd" / "H_SDD.txt").unlink()
    with pytest.raises(FetchError, match=r"missing H_SDD.txt .*HTTP 404"):
        fetch_source("sdd", manifest, tmp_path / "out" / "sdd",
                     FetchParams(locations=[http_server], timeout_s=5))
