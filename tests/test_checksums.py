import hashlib
import pickle

import pandas as pd
import pytest

from pipeline.data.checksums import ChecksumError, load_verified_pickle, read_manifest, sha256_file


def test_manifest_round_trip(tmp_path):
    (tmp_path / "a.txt").write_text("hello")
    digest = hashlib.sha256(b"hello").hexdigest()
    manifest = tmp_path / "m.sha256"
    manifest.write_text(f"{digest}  ./a.txt\n\n")
    assert read_manifest(manifest) == {"a.txt": digest}
    assert sha256_file(tmp_path / "a.txt") == digest


@pytest.mark.parametrize("line, message", [
    ("nothex  a.txt", "not a '<sha256>  <path>' line"),
    ("0" * 64 + "  ../escape.txt", "leaves the source root"),
    ("0" * 64 + "  /etc/passwd", "leaves the source root"),
])
def test_manifest_rejects_bad_lines(tmp_path, line, message):
    manifest = tmp_path / "m.sha256"
    manifest.write_text(line + "\n")
    with pytest.raises(ChecksumError, match=message) as error:
        read_manifest(manifest)
    assert "m.sha256:1" in str(error.value)


def test_pickle_not_loaded_when_checksum_differs(tmp_path, monkeypatch):
    pd.DataFrame({"a": [1]}).to_pickle(tmp_path / "w.pkl")
    calls = []
    monkeypatch.setattr(pickle, "load", lambda *a, **k: calls.append(1))
    monkeypatch.setattr(pd, "read_pickle", lambda *a, **k: calls.append(1))
    with pytest.raises(ChecksumError, match="does not match"):
        load_verified_pickle(tmp_path, "w.pkl", {"w.pkl": "0" * 64})
    with pytest.raises(ChecksumError, match="not in the manifest"):
        load_verified_pickle(tmp_path, "w.pkl", {})
    assert calls == []


def test_pickle_loaded_when_checksum_matches(tmp_path):
    pd.DataFrame({"a": [1, 2]}).to_pickle(tmp_path / "w.pkl")
    table = load_verified_pickle(tmp_path, "w.pkl", {"w.pkl": sha256_file(tmp_path / "w.pkl")})
    assert table["a"].tolist() == [1, 2]
