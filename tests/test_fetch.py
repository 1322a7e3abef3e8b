import functools
import http.server
import re
import threading
from pathlib import Path

import pytest

from pipeline.config.fetch import (FETCH_SOURCES, FetchParams, UpstreamLocation,
                                   parse_upstream_source)
from pipeline.config.loading import ParamsError, from_dict, load_section, read_params
from pipeline.data.checksums import read_manifest
from pipeline.data.fetch import FetchError, fetch_source, file_address
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


# ---------------------------------------------------------------------------------------------
# Upstream mappings: sources fetched from their public repositories' own layouts

OPENTRAJ = "crowdbotp/OpenTraj/" + "a" * 40
SOCIALVAE = "xupei0610/SocialVAE/" + "b" * 40

# manifest path (the mirror's layout) -> where the file lies in the fake upstream tree
UPSTREAM_LAYOUT = {
    "sdd": {
        "annotations/gates/video2/annotations.txt": f"{OPENTRAJ}/datasets/SDD/gates/video2/annotations.txt",
        "annotations/gates/video2/reference.jpg": f"{OPENTRAJ}/datasets/SDD/gates/video2/reference.jpg",
        "H_SDD.txt": f"{OPENTRAJ}/datasets/SDD/H_SDD.txt",
    },
    "ethucy-scenes": {
        "README-ETH.md": f"{OPENTRAJ}/datasets/ETH/README.md",
        "eth/H.txt": f"{OPENTRAJ}/datasets/ETH/seq_eth/H.txt",
        "zara1/H.txt": f"{OPENTRAJ}/datasets/UCY/zara01/H.txt",
    },
    "trajnet-sdd": {  # split across two repositories
        "test/coupa_0.txt": f"{SOCIALVAE}/data/sdd/test/coupa_0.txt",
        "H_SDD.txt": f"{OPENTRAJ}/datasets/SDD/H_SDD.txt",
    },
}


def mapping(base: str) -> dict:
    """The `fetch.locations` entry that maps UPSTREAM_LAYOUT, served at `base`."""
    return {"name": "upstream", "sources": {
        "sdd": {"base": f"{base}/{OPENTRAJ}/datasets/SDD",
                "map": [{"from": "annotations/", "to": ""}, {"from": "", "to": ""}]},
        "ethucy-scenes": {"base": f"{base}/{OPENTRAJ}/datasets",
                          "map": [{"from": "README-ETH.md", "to": "ETH/README.md"},
                                  {"from": "eth/", "to": "ETH/seq_eth/"},
                                  {"from": "zara1/", "to": "UCY/zara01/"}]},
        "trajnet-sdd": {"base": f"{base}/{SOCIALVAE}/data/sdd",
                        "map": [{"from": "test/", "to": "test/"},
                                {"from": "H_SDD.txt", "to": "datasets/SDD/H_SDD.txt",
                                 "base": f"{base}/{OPENTRAJ}"}]},
    }}


@pytest.fixture
def upstream(tmp_path):
    """Each source in the mirror's layout (with its manifest) and a tree laid out like the upstream
    repositories (`<owner>/<repo>/<sha>/...`) holding the same bytes; returns (sources, tree,
    manifests)."""
    sources, tree, manifests = tmp_path / "expected", tmp_path / "github", tmp_path / "manifests"
    for source, files in UPSTREAM_LAYOUT.items():
        for rel, upstream_path in files.items():
            data = (b"H_SDD ratios\n" if rel == "H_SDD.txt" else f"{source}:{rel}\n".encode())
            for path in (sources / source / rel, tree / upstream_path):
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(data)
        write_manifest(sources / source, manifests / f"{source}.sha256")
    return sources, tree, manifests


@pytest.fixture
def serve():
    """Start an HTTP server on 127.0.0.1 for a folder; returns (base URL, list of paths requested)."""
    servers = []

    def start(directory):
        requested = []

        class Handler(http.server.SimpleHTTPRequestHandler):
            def do_GET(self):
                requested.append(self.path)
                super().do_GET()

            def log_message(self, *args):
                pass

        server = http.server.ThreadingHTTPServer(
            ("127.0.0.1", 0), functools.partial(Handler, directory=str(directory)))
        threading.Thread(target=server.serve_forever, args=(0.05,), daemon=True).start()
        servers.append(server)
        return f"http://127.0.0.1:{server.server_address[1]}", requested

    yield start
    for server in servers:
        server.shutdown()
        server.server_close()


def same_tree(a, b) -> bool:
    files = lambda root: {p.relative_to(root): p.read_bytes() for p in root.rglob("*") if p.is_file()}
    return files(a) == files(b)


@pytest.mark.parametrize("name", list(UPSTREAM_LAYOUT))
def test_fetch_through_upstream_mapping(tmp_path, upstream, serve, name):
    sources, tree, manifests = upstream
    base, requested = serve(tree)
    out = tmp_path / "out" / name
    params = FetchParams(locations=[str(tmp_path / "no-mirror"), mapping(base)], timeout_s=5)
    assert fetch_source(name, manifests / f"{name}.sha256", out, params) == "upstream"
    assert same_tree(out, sources / name)
    assert sorted(requested) == sorted("/" + p for p in UPSTREAM_LAYOUT[name].values())


def test_upstream_mapping_to_local_clones(tmp_path, upstream):
    """A mapping's bases may be folders (e.g. clones of the repositories) as well as URLs."""
    sources, tree, manifests = upstream
    out = tmp_path / "out" / "ethucy-scenes"
    used = fetch_source("ethucy-scenes", manifests / "ethucy-scenes.sha256", out,
                        FetchParams(locations=[mapping(str(tree))]))
    assert used == "upstream" and same_tree(out, sources / "ethucy-scenes")


def test_changed_upstream_file_is_a_checksum_mismatch_and_nothing_is_written(tmp_path, upstream, serve):
    _, tree, manifests = upstream
    (tree / OPENTRAJ / "datasets/SDD/gates/video2/annotations.txt").write_text("changed upstream\n")
    base, _ = serve(tree)
    out = tmp_path / "out" / "sdd"
    with pytest.raises(FetchError) as error:
        fetch_source("sdd", manifests / "sdd.sha256", out,
                     FetchParams(locations=[mapping(base)], timeout_s=5))
    message = str(error.value)
    assert "upstream: 1 of 3 files failed" in message
    assert "checksum mismatch annotations/gates/video2/annotations.txt" in message
    assert f"{base}/{OPENTRAJ}/datasets/SDD/gates/video2/annotations.txt" in message
    assert list(out.parent.iterdir()) == []  # neither the output nor a staging folder


def test_missing_upstream_file_is_reported_by_name(tmp_path, upstream, serve):
    _, tree, manifests = upstream
    (tree / SOCIALVAE / "data/sdd/test/coupa_0.txt").unlink()
    base, _ = serve(tree)
    with pytest.raises(FetchError, match=rf"missing test/coupa_0.txt \({base}/{SOCIALVAE}/data/sdd/"
                                         r"test/coupa_0.txt: HTTP 404\)"):
        fetch_source("trajnet-sdd", manifests / "trajnet-sdd.sha256", tmp_path / "out" / "t",
                     FetchParams(locations=[mapping(base)], timeout_s=5))


def test_mirror_first_leaves_upstream_untouched(tmp_path, upstream, serve):
    sources, tree, manifests = upstream
    base, requested = serve(tree)
    out = tmp_path / "out" / "sdd"
    used = fetch_source("sdd", manifests / "sdd.sha256", out,
                        FetchParams(locations=[str(sources), mapping(base)], timeout_s=5))
    assert used == str(sources) and same_tree(out, sources / "sdd")
    assert requested == []


def test_source_not_in_a_mapping_is_not_offered_there(tmp_path, upstream, serve):
    sources, tree, manifests = upstream
    (manifests / "sgan.sha256").write_text(f"{'0' * 64}  datasets/eth/test/biwi_eth.txt\n")
    base, requested = serve(tree)
    with pytest.raises(FetchError) as error:
        fetch_source("sgan", manifests / "sgan.sha256", tmp_path / "out" / "sgan",
                     FetchParams(locations=[str(sources), mapping(base)], timeout_s=5))
    message = str(error.value)
    assert f"{sources}: 1 of 1 files failed" in message and "missing datasets/eth/test" in message
    assert "upstream: does not offer 'sgan' (not among its sources)" in message
    assert requested == []


def test_manifest_path_without_a_rule_is_reported_unmapped(tmp_path, upstream, serve):
    _, tree, manifests = upstream
    base, _ = serve(tree)
    location = mapping(base)
    location["sources"]["ethucy-scenes"]["map"].pop()  # no rule for zara1/
    with pytest.raises(FetchError, match=r"unmapped zara1/H.txt \(no rule"):
        fetch_source("ethucy-scenes", manifests / "ethucy-scenes.sha256", tmp_path / "o" / "e",
                     FetchParams(locations=[location], timeout_s=5))


def test_rules_match_folders_by_prefix_and_files_exactly():
    source = parse_upstream_source({"base": "https://h/r", "map": [
        {"from": "eth/", "to": "ETH/seq_eth/"}, {"from": "README.md", "to": "ETH/README.md"},
        {"from": "sub dir/", "to": "x y/", "base": "/clone"}]}, "here")
    assert source.resolve("eth/H.txt") == "https://h/r/ETH/seq_eth/H.txt"
    assert source.resolve("eth_ucy/H.txt") is None  # "eth/" is a folder, not a string prefix
    assert source.resolve("README.md") == "https://h/r/ETH/README.md"
    assert source.resolve("README.md.bak") is None
    assert source.resolve("sub dir/a b.txt") == "/clone/x y/a b.txt"  # local: not quoted
    url = parse_upstream_source({"base": "https://h/r"}, "here").resolve("a b/c#d.txt")
    assert url == "https://h/r/a%20b/c%23d.txt"  # no map: same paths, quoted into the URL


def upstream_entry(**source) -> dict:
    return {"name": "up", "sources": {"sdd": {"base": "https://h/r", **source}}}


@pytest.mark.parametrize("entry, message", [
    (3, r": expected a mapping, got int 3"),
    ({"name": "up"}, r": missing key\(s\) \['sources'\]; allowed: \['name', 'sources'\]"),
    ({"name": "up", "sources": {}, "url": "x"}, r"unknown key\(s\) \['url'\]"),
    ({"name": "", "sources": {"sdd": {"base": "x"}}}, r"\.name: expected a non-empty string"),
    ({"name": "up", "sources": {"kitti": {"base": "x"}}},
     r" \(up\)\.sources: unknown source\(s\) \['kitti'\]; known: \['sdd'"),
    ({"name": "up", "sources": {"sdd": {"map": []}}}, r"\.sources\.sdd: missing key\(s\) \['base'\]"),
    ({"name": "up", "sources": {"sdd": {"base": "ftp://h/r"}}},
     r"\.sources\.sdd\.base: 'ftp://h/r' is not a folder path or an http\(s\) URL"),
    (upstream_entry(map=[]), r"\.sources\.sdd\.map: expected a non-empty list"),
    (upstream_entry(map=[["annotations/", ""]]), r"\.map\[0\]: expected a mapping, got list"),
    (upstream_entry(map=[{"from": "a/"}]), r"\.map\[0\]: missing key\(s\) \['to'\]"),
    (upstream_entry(map=[{"from": "a/", "to": "b/", "bse": "x"}]), r"unknown key\(s\) \['bse'\]"),
    (upstream_entry(map=[{"from": "../a/", "to": "b/"}]), r"\.map\[0\]\.from: '\.\./a/' must be a relative"),
    (upstream_entry(map=[{"from": "a/", "to": "/b/"}]), r"\.map\[0\]\.to: '/b/' must be a relative"),
    (upstream_entry(map=[{"from": "a//b/", "to": "b/"}]), r"\.map\[0\]\.from: 'a//b/' must be a relative"),
    (upstream_entry(map=[{"from": "a/", "to": "b.txt"}]), r"folder 'a/' must map to a folder ending in '/'"),
    (upstream_entry(map=[{"from": "a.txt", "to": "b/"}]), r"file 'a.txt' must map to a file path"),
    (upstream_entry(map=[{"from": "a/", "to": 3}]), r"\.map\[0\]\.to: expected a string, got int 3"),
    (upstream_entry(map=[{"from": "a/", "to": "b/", "base": "ftp://x"}]),
     r"\.map\[0\]\.base: 'ftp://x' is not a folder path"),
    (upstream_entry(map=[{"from": "a/", "to": "b/"}, {"from": "a/x.txt", "to": "c.txt"}]),
     r"\.map\[1\] \(from 'a/x.txt'\) is never used: map\[0\] \(from 'a/'\) matches its paths first"),
    (upstream_entry(map=[{"from": "", "to": ""}, {"from": "a/", "to": "b/"}]),
     r"\.map\[1\] \(from 'a/'\) is never used: map\[0\] \(from ''\)"),
])
def test_bad_upstream_mappings_fail_clearly(entry, message):
    with pytest.raises(ParamsError, match=r"^params\.yaml:fetch: locations\[1\].*" + message):
        from_dict(FetchParams, {"locations": ["../shared/data", entry]}, "params.yaml:fetch")


def test_upstream_names_must_differ():
    entry = upstream_entry()
    with pytest.raises(ParamsError, match=r"upstream name\(s\) \['up'\] used twice"):
        from_dict(FetchParams, {"locations": [entry, entry]}, "fetch")


def test_params_yaml_maps_every_manifest_file_upstream_at_a_pinned_commit():
    """The mirror comes first; then every file of every source resolves, through params.yaml's
    upstream mapping, to a raw GitHub URL at a full 40-hex commit (no file left unmapped)."""
    params = load_section(FetchParams, "fetch", read_params())
    locations = params.parsed_locations()
    assert locations[0] == "../shared/data"
    upstreams = [loc for loc in locations if isinstance(loc, UpstreamLocation)]
    assert len(upstreams) == 1
    pinned = re.compile(r"^https://raw\.githubusercontent\.com/[\w.-]+/[\w.-]+/[0-9a-f]{40}/\S+$")
    assert sorted(upstreams[0].sources) == sorted(FETCH_SOURCES) == sorted(params.sources)
    for source in params.sources:
        manifest = read_manifest(Path("manifests") / f"{source}.sha256")
        urls = {rel: file_address(upstreams[0], source, rel) for rel in manifest}
        unmapped = [rel for rel, url in urls.items() if url is None]
        assert not unmapped, (source, unmapped)
        assert all(pinned.match(url) for url in urls.values()), source
        assert len(set(urls.values())) == len(urls), source  # no two files from one URL
