"""Download path of sindybench.datasets against a small HTTP server on 127.0.0.1 (no real network)."""

import hashlib
import io
import threading
import zipfile
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np
import pytest

from sindybench.datasets import (
    DownloadError,
    RemoteFile,
    extract_zip,
    fetch_file,
    fetch_files,
    load_cascaded_tanks,
)
from sindybench.datasets import _cascaded_tanks

GOOD = bytes(range(256)) * 400  # 102400 bytes
GOOD_SHA = hashlib.sha256(GOOD).hexdigest()
OTHER = b"second file in the archive\n" * 10
OTHER_SHA = hashlib.sha256(OTHER).hexdigest()


def _zip(members):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, payload in members.items():
            zf.writestr(name, payload)
    return buf.getvalue()


class _Handler(BaseHTTPRequestHandler):
    routes = {}
    hits = {}

    def log_message(self, *args):  # keep the test output clean
        pass

    def do_GET(self):
        type(self).hits[self.path] = type(self).hits.get(self.path, 0) + 1
        if self.path == "/cut.bin":
            # announce the whole file, send half of it, then drop the connection
            self.send_response(200)
            self.send_header("Content-Length", str(len(GOOD)))
            self.end_headers()
            self.wfile.write(GOOD[: len(GOOD) // 2])
            self.wfile.flush()
            self.close_connection = True
            return
        body = type(self).routes.get(self.path)
        if body is None:
            self.send_error(404)
            return
        self.send_response(200)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)


@pytest.fixture(scope="module")
def server():
    corrupted = bytearray(GOOD)
    corrupted[1000] ^= 0xFF
    _Handler.routes = {
        "/good.bin": GOOD,
        "/bad.bin": bytes(corrupted),
        "/archive.zip": _zip({"pkg/good.bin": GOOD, "pkg/other.txt": OTHER}),
        "/nested.zip": _zip({"Inner.zip": _zip({"deep/good.bin": GOOD}), "readme.txt": b"outer"}),
        "/evil.zip": _zip({"pkg/good.bin": GOOD, "../../evil.bin": b"escaped"}),
        "/notzip.zip": b"this is not a zip archive",
    }
    httpd = ThreadingHTTPServer(("127.0.0.1", 0), _Handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()
    thread.join()


def _leftovers(folder):
    return sorted(p.name for p in folder.rglob("*") if p.is_file())


def test_good_file_is_verified_and_moved_into_place(server, tmp_path):
    remote = RemoteFile("demo/good.bin", f"{server}/good.bin", GOOD_SHA)
    path = fetch_file(remote, data_home=tmp_path)
    assert path == tmp_path / "demo" / "good.bin"
    assert path.read_bytes() == GOOD
    assert _leftovers(tmp_path) == ["good.bin"]  # no temporary file left
    # a second call finds the file and does not download again
    before = _Handler.hits.get("/good.bin", 0)
    assert fetch_file(remote, data_home=tmp_path) == path
    assert _Handler.hits.get("/good.bin", 0) == before


def test_url_override_points_at_a_mirror(server, tmp_path):
    remote = RemoteFile("demo/good.bin", "https://example.invalid/good.bin", GOOD_SHA)
    assert fetch_file(remote, data_home=tmp_path, url=f"{server}/good.bin").read_bytes() == GOOD


@pytest.mark.parametrize(
    "source, message",
    [
        ("bad.bin", "checksum mismatch for demo/good.bin"),  # corrupted file
        ("cut.bin", r"interrupted|failed after"),  # connection cut half way
        ("missing.bin", "HTTP 404"),
    ],
)
def test_failed_download_raises_and_leaves_nothing(server, tmp_path, source, message):
    remote = RemoteFile("demo/good.bin", f"{server}/{source}", GOOD_SHA)
    with pytest.raises(DownloadError, match=message):
        fetch_file(remote, data_home=tmp_path)
    assert _leftovers(tmp_path) == []


def test_archive_members_share_one_download(server, tmp_path):
    remotes = [
        RemoteFile("demo/good.bin", f"{server}/archive.zip", GOOD_SHA, "pkg/good.bin"),
        RemoteFile("demo/sub/other.txt", f"{server}/archive.zip", OTHER_SHA, "pkg/other.txt"),
    ]
    before = _Handler.hits.get("/archive.zip", 0)
    paths = fetch_files(remotes, data_home=tmp_path)
    assert _Handler.hits["/archive.zip"] == before + 1
    assert paths[0].read_bytes() == GOOD and paths[1].read_bytes() == OTHER
    assert _leftovers(tmp_path) == ["good.bin", "other.txt"]  # the archive itself is not kept


def test_nested_archive_member(server, tmp_path):
    remote = RemoteFile("demo/good.bin", f"{server}/nested.zip", GOOD_SHA, ("Inner.zip", "deep/good.bin"))
    assert fetch_file(remote, data_home=tmp_path).read_bytes() == GOOD
    assert _leftovers(tmp_path) == ["good.bin"]


@pytest.mark.parametrize(
    ("route", "member", "sha", "match"),
    [
        ("/archive.zip", "pkg/absent.bin", GOOD_SHA, "no member 'pkg/absent.bin'"),
        ("/archive.zip", "pkg/other.txt", GOOD_SHA, "checksum mismatch"),
        ("/evil.zip", "pkg/good.bin", GOOD_SHA, "outside"),
        ("/notzip.zip", "pkg/good.bin", GOOD_SHA, "not a valid zip archive"),
    ],
)
def test_bad_archives_raise_and_leave_nothing(server, tmp_path, route, member, sha, match):
    home = tmp_path / "home"
    remote = RemoteFile("demo/good.bin", f"{server}{route}", sha, member)
    with pytest.raises(DownloadError, match=match):
        fetch_file(remote, data_home=home)
    assert _leftovers(tmp_path) == []


def test_extract_zip_refuses_escaping_members(tmp_path):
    archive = tmp_path / "evil.zip"
    archive.write_bytes(_zip({"ok.txt": b"fine", "../escaped.txt": b"bad"}))
    target = tmp_path / "target"
    with pytest.raises(DownloadError, match="outside"):
        extract_zip(archive, target)
    assert not (tmp_path / "escaped.txt").exists() and _leftovers(target) == []
    absolute = tmp_path / "abs.zip"
    absolute.write_bytes(_zip({"/etc/abs.txt": b"bad"}))
    with pytest.raises(DownloadError, match="outside"):
        extract_zip(absolute, target)
    good = tmp_path / "good.zip"
    good.write_bytes(_zip({"a/b.txt": b"x", "c.txt": b"y"}))
    out = extract_zip(good, target)
    assert sorted(p.name for p in out) == ["b.txt", "c.txt"] and (target / "a" / "b.txt").read_bytes() == b"x"
    with pytest.raises(DownloadError, match="no member"):
        extract_zip(good, target, members=["zzz.txt"])


def test_loader_downloads_declared_archive_member(server, tmp_path, data_home, monkeypatch):
    """The cascaded-tanks declaration (member path, sha256) works end to end on a served archive."""
    (declared,) = _cascaded_tanks.REMOTES
    payload = (data_home / "cascaded_tanks" / "dataBenchmark.mat").read_bytes()
    _Handler.routes["/CascadedTanksFiles.zip"] = _zip({declared.member: payload, "CascadedTanksFiles/readme.txt": b""})
    monkeypatch.setattr(_cascaded_tanks, "REMOTES", (declared._replace(url=f"{server}/CascadedTanksFiles.zip"),))
    data = load_cascaded_tanks(data_home=tmp_path)
    reference = load_cascaded_tanks(data_home=data_home)
    np.testing.assert_array_equal(data.test.y, reference.test.y)
    assert _leftovers(tmp_path) == ["dataBenchmark.mat"]


@pytest.mark.parametrize("route", ["/bad.bin", "/cut.bin", "/missing.bin"])
def test_failed_download_leaves_no_empty_folder(server, tmp_path, route):
    remote = RemoteFile("demo/sub/good.bin", f"{server}{route}", GOOD_SHA)
    with pytest.raises(DownloadError):
        fetch_file(remote, data_home=tmp_path / "home")
    assert list(tmp_path.iterdir()) == []


def test_missing_file_is_reported_before_any_download(server, tmp_path):
    remotes = [
        RemoteFile("demo/good.bin", f"{server}/good.bin", GOOD_SHA),
        RemoteFile("demo/by_hand.bin", None, GOOD_SHA),
    ]
    before = _Handler.hits.get("/good.bin", 0)
    with pytest.raises(FileNotFoundError, match="no public download address"):
        fetch_files(remotes, data_home=tmp_path / "home")
    with pytest.raises(FileNotFoundError, match="download_if_missing=False"):
        fetch_files(remotes, data_home=tmp_path / "home", download_if_missing=False)
    assert _Handler.hits.get("/good.bin", 0) == before
    assert list(tmp_path.iterdir()) == []  # not even the data home was created
