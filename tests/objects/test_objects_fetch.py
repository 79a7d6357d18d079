"""Fetching VGN's object sets: from a local archive laid out like GitHub's, checked file by
file, atomic, resumable, and with one-line errors."""

import http.server
import io
import os
import re
import shutil
import tarfile
import threading

import pytest

from symgrasp.objects.fetch import (
    ArchiveError,
    DownloadError,
    continues,
    fetch_vgn,
    manifest,
    resume_headers,
    shipped_manifest,
)
from symgrasp.objects.folder import VGN_ROOT

TOP = "Edge-Grasp-Network-4a38e4a"
OBJECTS = ("BakingVanilla_800_tex", "ChocSticks2_800_tex")


@pytest.fixture
def sets(tmp_path, shared):
    """A small stand-in for the sets: real files when the shared copy is at hand."""
    vgn = shared / VGN_ROOT
    folder = tmp_path / "sets"
    (folder / "pile" / "test").mkdir(parents=True)
    names = [f"{o}{s}" for o in OBJECTS for s in (".urdf", "_visual.obj", "_collision.obj")]
    for name in ["LICENSE.edge-grasp-network"] + [f"pile/test/{n}" for n in names]:
        if vgn.is_dir():
            shutil.copyfile(vgn / name, folder / name)
        else:
            (folder / name).write_text(f"stand-in for {name}\n")
    return folder


def make_archive(path, sets, extra=()):
    """A .tar.gz like GitHub's: the sets under TOP/data_robot/urdfs, the licence at TOP/LICENSE,
    a file that is not taken, and the members ``extra`` (TarInfo, a few bytes each)."""
    with tarfile.open(path, "w:gz") as tar:
        tar.add(sets / "LICENSE.edge-grasp-network", f"{TOP}/LICENSE")
        tar.add(sets / "pile", f"{TOP}/data_robot/urdfs/pile")
        tar.add(sets / "LICENSE.edge-grasp-network", f"{TOP}/README.md")
        for member in extra:
            tar.addfile(member, io.BytesIO(b"x" * member.size))
    return path


@pytest.fixture
def archive(tmp_path, sets):
    return make_archive(tmp_path / "4a38e4a.tar.gz", sets)


def fetch(data, url, expected):
    return fetch_vgn(data, url, progress=False, expected=expected)


def nothing_in_place(data):
    return not (data / "objects" / "vgn").exists() and os.listdir(data / "objects") == []


def test_manifest_is_relative_path_to_sha256_prefix(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "b.txt").write_bytes(b"abc")
    assert manifest(tmp_path) == {"a/b.txt": "ba7816bf8f01cfea"}


def test_fetch_puts_the_sets_in_place_then_does_nothing(tmp_path, sets, archive, capsys):
    data = tmp_path / "data"
    target = fetch(data, archive.as_uri(), manifest(sets))
    assert target == data / "objects" / "vgn"
    assert all((target / p).read_bytes() == (sets / p).read_bytes() for p in manifest(sets))
    assert manifest(target) == manifest(sets)
    assert os.listdir(data / "objects") == ["vgn"]
    assert os.listdir(data / "downloads") == []
    assert fetch_vgn(data, "file:///nonexistent.tar.gz", progress=True) == target
    assert capsys.readouterr().err == f"VGN's object sets are already in {target}\n"


def test_a_tampered_file_is_named_and_nothing_is_put_in_place(tmp_path, sets):
    expected = manifest(sets)
    with open(sets / "pile" / "test" / f"{OBJECTS[1]}.urdf", "ab") as file:
        file.write(b" ")
    data = tmp_path / "data"
    url = make_archive(tmp_path / "4a38e4a.tar.gz", sets).as_uri()
    message = rf"differs from the pinned one: pile/test/{OBJECTS[1]}.urdf \(content differs\)"
    with pytest.raises(ArchiveError, match=message):
        fetch(data, url, expected)
    assert nothing_in_place(data)
    assert os.listdir(data / "downloads") == []


@pytest.mark.parametrize(
    "name",
    [
        "../../evil.txt",
        f"{TOP}/data_robot/urdfs/pile/test/../../../../../evil.txt",
        "/tmp/evil.txt",
    ],
)
def test_a_member_leaving_the_archive_is_refused(tmp_path, sets, name):
    member = tarfile.TarInfo(name)
    member.size = 3
    data = tmp_path / "data"
    url = make_archive(tmp_path / "a.tar.gz", sets, [member]).as_uri()
    with pytest.raises(ArchiveError, match="refusing"):
        fetch(data, url, manifest(sets))
    assert nothing_in_place(data)
    assert not (tmp_path / "evil.txt").exists()


def test_a_link_among_the_sets_is_refused(tmp_path, sets):
    link = tarfile.TarInfo(f"{TOP}/data_robot/urdfs/pile/test/passwd.urdf")
    link.type, link.linkname = tarfile.SYMTYPE, "/etc/passwd"
    data = tmp_path / "data"
    with pytest.raises(ArchiveError, match="not a regular file"):
        fetch(data, make_archive(tmp_path / "a.tar.gz", sets, [link]).as_uri(), manifest(sets))
    assert nothing_in_place(data)


def test_a_killed_download_restarts_when_the_server_cannot_resume(tmp_path, sets, archive):
    downloads = tmp_path / "data" / "downloads"
    downloads.mkdir(parents=True)
    (downloads / f"{archive.name}.part").write_bytes(b"garbage" + archive.read_bytes()[:100])
    target = fetch(tmp_path / "data", archive.as_uri(), manifest(sets))
    assert manifest(target) == manifest(sets)


def test_a_fetch_killed_while_extracting_extracts_again(tmp_path, sets, archive):
    data = tmp_path / "data"
    (data / "downloads").mkdir(parents=True)
    shutil.copyfile(archive, data / "downloads" / archive.name)
    (data / "objects" / ".vgn.partial" / "pile").mkdir(parents=True)
    (data / "objects" / ".vgn.partial" / "pile" / "half.obj").write_text("v 0 0 0\n")
    target = fetch(data, f"file:///nonexistent/{archive.name}", manifest(sets))
    assert manifest(target) == manifest(sets)
    assert os.listdir(data / "objects") == ["vgn"]


def test_a_truncated_archive_is_removed_for_the_next_run(tmp_path, sets, archive):
    data = tmp_path / "data"
    (data / "downloads").mkdir(parents=True)
    (data / "downloads" / archive.name).write_bytes(archive.read_bytes()[:-100])
    with pytest.raises(ArchiveError, match=r"not a complete \.tar\.gz archive.*run again"):
        fetch(data, archive.as_uri(), manifest(sets))
    assert nothing_in_place(data)
    assert os.listdir(data / "downloads") == []


@pytest.fixture
def server(archive):
    """A local HTTP server of ``archive`` at /NAME that honours ``Range: bytes=N-``; its
    ``ranges`` lists the Range headers received."""
    body = archive.read_bytes()

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            ranges.append(self.headers.get("Range"))
            if self.path != f"/{archive.name}":
                return self.send_error(404)
            match = re.fullmatch(r"bytes=(\d+)-", self.headers.get("Range", ""))
            start = int(match[1]) if match else 0
            self.send_response(206 if start else 200)
            if start:
                self.send_header("Content-Range", f"bytes {start}-{len(body) - 1}/{len(body)}")
            self.send_header("Content-Length", str(len(body) - start))
            self.end_headers()
            self.wfile.write(body[start:])

        def log_message(self, *args):
            pass

    ranges = []
    with http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler) as httpd:
        thread = threading.Thread(target=httpd.serve_forever, args=(0.05,), daemon=True)
        thread.start()
        httpd.ranges = ranges
        yield httpd
        httpd.shutdown()


def test_a_killed_download_resumes_with_a_range_request(tmp_path, sets, archive, server):
    downloads = tmp_path / "data" / "downloads"
    downloads.mkdir(parents=True)
    half = archive.stat().st_size // 2
    (downloads / f"{archive.name}.part").write_bytes(archive.read_bytes()[:half])
    url = f"http://127.0.0.1:{server.server_port}/{archive.name}"
    target = fetch(tmp_path / "data", url, manifest(sets))
    assert server.ranges == [f"bytes={half}-"]
    assert manifest(target) == manifest(sets)


def test_resume_headers_and_responses():
    assert resume_headers(0) == {}
    assert resume_headers(10) == {"Range": "bytes=10-"}
    assert continues(206, "bytes 10-99/100", 10)
    assert not continues(200, None, 10)  # the server ignored the Range: the whole file
    assert not continues(None, None, 10)  # file://
    assert not continues(206, "bytes 0-99/100", 10)


def test_an_http_error_is_one_line_naming_the_url(tmp_path, server):
    url = f"http://127.0.0.1:{server.server_port}/missing.tar.gz"
    with pytest.raises(DownloadError, match=rf"^could not download {url}: HTTP 404 Not Found;"):
        fetch(tmp_path / "data", url, {})


def test_no_network_says_how_to_do_without(tmp_path):
    data = tmp_path / "data"
    with pytest.raises(DownloadError) as error:
        fetch(data, "file:///nonexistent", {})
    message = str(error.value)
    assert message.startswith("could not download file:///nonexistent: ")
    assert f"copy the object sets into {data / 'objects' / 'vgn'}" in message
    assert "SYMGRASP_DATA" in message
    assert "\n" not in message


def test_a_data_folder_that_is_a_file_is_named(tmp_path):
    data = tmp_path / "data"
    data.write_text("")
    with pytest.raises(NotADirectoryError) as error:
        fetch(data, "file:///nonexistent", {})
    assert error.value.filename == str(data)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_a_data_folder_that_is_not_writable_is_named(tmp_path):
    data = tmp_path / "data"
    data.mkdir(mode=0o500)
    with pytest.raises(PermissionError) as error:
        fetch(data, "file:///nonexistent", {})
    assert error.value.filename == str(data)


def test_the_shipped_manifest_matches_the_sets(vgn_data):
    expected = shipped_manifest()
    assert manifest(vgn_data / VGN_ROOT) == expected
    assert len(expected) == 3 * (303 + 40 + 114 + 16) + 1


def test_the_command_line_checks_against_the_shipped_manifest(tmp_path, archive, capsys):
    from symgrasp.cli import main

    with pytest.raises(SystemExit) as exit:
        main(["objects", "fetch", "vgn", "--data", str(tmp_path / "d"), "--url", archive.as_uri()])
    message = str(exit.value)
    assert message.startswith("error: the archive from file://") and "\n" not in message
    assert "missing" in message and nothing_in_place(tmp_path / "d")
