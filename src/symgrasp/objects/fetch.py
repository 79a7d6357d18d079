"""Downloading VGN's object sets into the data folder (``symgrasp objects fetch vgn``).

The sets come from the MIT-licensed repository ``HaojHuang/Edge-Grasp-Network`` at a pinned
commit: its folder ``data_robot/urdfs/{pile,packed}/{train,test}`` becomes
``<data>/objects/vgn/{pile,packed}/{train,test}`` and its root ``LICENSE`` becomes
``<data>/objects/vgn/LICENSE.edge-grasp-network``.

GitHub generates its archives on request and does not keep them byte-stable, so the archive
itself has no checksum: every extracted file is checked instead against ``vgn_manifest.json``,
shipped with the package (relative path → first 16 hex digits of its SHA-256). It was
written from a copy of the sets as ``json.dumps(manifest(folder), indent=0, sort_keys=True)``
and a final newline; a test checks it against that copy when it is at hand.

A fetch is safe to kill at any point: the download grows in ``<data>/downloads/NAME.part``
(continued with an HTTP Range request by the next run when the server allows it), and the
files are extracted and checked in a hidden folder next to the target, which is renamed into
place only when complete.
"""

from __future__ import annotations

import errno
import gzip
import hashlib
import http.client
import json
import os
import shutil
import sys
import tarfile
import urllib.error
import urllib.parse
import urllib.request
import urllib.response
import zlib
from importlib import resources
from pathlib import Path, PurePosixPath

from tqdm import tqdm

from symgrasp.atomic import move_into_place
from symgrasp.folders import output_folder
from symgrasp.names import MESH_OBJECT_SETS
from symgrasp.objects.folder import DATA_ENV, VGN_ROOT, data_folder

VGN_ARCHIVE_URL = "https://github.com/HaojHuang/Edge-Grasp-Network/archive/4a38e4a.tar.gz"
"""The pinned archive: Edge-Grasp-Network at commit 4a38e4a."""

MANIFEST = "vgn_manifest.json"
"""The manifest's file name inside the package ``symgrasp.objects``."""

UPSTREAM_SETS = PurePosixPath("data_robot", "urdfs")
"""Where the sets are inside the archive, below its top folder."""

LICENSE = "LICENSE.edge-grasp-network"
"""The repository's root ``LICENSE``, as named in the data folder."""

TIMEOUT_S = 60.0
"""Seconds without an answer from the server before a download gives up."""

CHUNK_BYTES = 1 << 20
"""Bytes read from the server at a time."""

_SETS = {tuple(name.split("-")[1:]) for name in MESH_OBJECT_SETS}  # ("pile", "train"), …


class DownloadError(OSError):
    """The archive could not be downloaded; the message names the URL and the reason."""


class ArchiveError(ValueError):
    """The archive is unreadable, holds an unsafe member, or differs from the pinned one."""


def manifest(folder: Path) -> dict[str, str]:
    """Every file below ``folder``: its POSIX path relative to ``folder`` → the first 16 hex
    digits of its SHA-256."""
    folder = Path(folder)
    return {
        path.relative_to(folder).as_posix(): hashlib.sha256(path.read_bytes()).hexdigest()[:16]
        for path in sorted(folder.rglob("*"))
        if path.is_file()
    }


def shipped_manifest() -> dict[str, str]:
    """The manifest of VGN's sets shipped with the package."""
    text = resources.files("symgrasp.objects").joinpath(MANIFEST).read_text(encoding="utf-8")
    return json.loads(text)


def fetch_vgn(
    data: Path | None = None,
    url: str = VGN_ARCHIVE_URL,
    progress: bool = True,
    expected: dict[str, str] | None = None,
) -> Path:
    """Download VGN's object sets into ``<data>/objects/vgn`` and return that folder.

    ``data`` defaults to `folder.data_folder`; ``url`` may be any URL urllib opens
    (``file://`` included); ``progress`` shows a download bar and says on stderr when the
    sets are already there; ``expected`` is the manifest the extracted files must match
    (default: `shipped_manifest`). Does nothing when the folder exists. The archive is
    removed once the sets are in place, and after a failed extraction or check, so that the
    next run downloads it afresh.

    Raises DownloadError (an OSError) when the download fails, ArchiveError (a ValueError)
    when the archive is unreadable, unsafe or not the pinned one, OSError naming the data
    folder when it is a file or not writable, and ValueError when another fetch holds it
    (`symgrasp.folders.output_folder`).
    """
    data = data_folder() if data is None else Path(data)
    target = data / VGN_ROOT
    if target.is_dir():
        if progress:
            print(f"VGN's object sets are already in {target}", file=sys.stderr)
        return target
    expected = shipped_manifest() if expected is None else expected
    _check_writable(data)
    with output_folder(data, None, "data"):  # one fetch at a time: they would share a download
        if target.is_dir():  # put in place by the fetch that held the folder before
            return target
        try:
            archive = download(url, data / "downloads", progress)
        except DownloadError as error:
            raise DownloadError(
                f"{error}; on a machine without network, copy the object sets into {target} "
                f"(see docs/objects.md) or point {DATA_ENV} at a folder holding {VGN_ROOT}"
            ) from error
        staging = target.with_name(f".{target.name}.partial")
        shutil.rmtree(staging, ignore_errors=True)  # left by a fetch killed while extracting
        try:
            _extract(archive, staging)
            _verify(staging, expected, url)
            move_into_place(staging, target)
        except ArchiveError as error:
            archive.unlink(missing_ok=True)
            raise ArchiveError(
                f"{error}; {archive} was removed, run again to download it afresh"
            ) from error
        finally:
            shutil.rmtree(staging, ignore_errors=True)
        archive.unlink()
        return target


def _check_writable(data: Path) -> None:
    """Raise an OSError naming ``data`` when it cannot hold the sets; create it otherwise."""
    if data.exists() and not data.is_dir():
        raise NotADirectoryError(
            errno.ENOTDIR, f"the data folder is a file, not a folder; set {DATA_ENV}", str(data)
        )
    data.mkdir(parents=True, exist_ok=True)
    if not os.access(data, os.W_OK | os.X_OK):
        raise PermissionError(
            errno.EACCES, f"the data folder is not writable; set {DATA_ENV}", str(data)
        )


def resume_headers(offset: int) -> dict[str, str]:
    """The request headers that ask for the bytes from ``offset`` on (none from 0)."""
    return {"Range": f"bytes={offset}-"} if offset else {}


def continues(status: int | None, content_range: str | None, offset: int) -> bool:
    """Whether a response (its HTTP status and ``Content-Range``; None for ``file://``)
    carries the bytes from ``offset`` on, rather than the whole file from the start."""
    return (
        offset > 0
        and status == http.HTTPStatus.PARTIAL_CONTENT
        and (content_range or "").startswith(f"bytes {offset}-")
    )


def download(url: str, folder: Path, progress: bool = True) -> Path:
    """Download ``url`` into ``folder`` under the URL's file name and return its path.

    A complete earlier download is reused. The bytes go to ``NAME.part`` first, renamed to
    ``NAME`` when the server has sent them all; a ``.part`` left by a killed run is continued
    when the server honours the Range request, and restarted otherwise. Raises DownloadError
    on network and HTTP errors, keeping the ``.part`` for the next run.
    """
    done = folder / (Path(urllib.parse.urlsplit(url).path).name or "download")
    if done.is_file():
        return done
    folder.mkdir(parents=True, exist_ok=True)
    part = done.with_name(f"{done.name}.part")
    offset = part.stat().st_size if part.is_file() else 0
    response = _open(url, offset)
    with response:
        resumed = continues(response.status, response.headers.get("Content-Range"), offset)
        start = offset if resumed else 0
        length = response.headers.get("Content-Length")
        total = start + int(length) if length else None
        with (
            open(part, "ab" if resumed else "wb") as file,
            tqdm(
                total=total,
                initial=start,
                desc=done.name,
                unit="B",
                unit_scale=True,
                unit_divisor=1024,
                disable=not progress,
            ) as bar,
        ):
            while chunk := _read(response, url):
                file.write(chunk)
                bar.update(len(chunk))
    size = part.stat().st_size
    if total is not None and size != total:
        raise DownloadError(
            f"could not download {url}: the server closed the connection after {size} of "
            f"{total} bytes; run again to resume"
        )
    return move_into_place(part, done)


def _open(url: str, offset: int) -> http.client.HTTPResponse | urllib.response.addinfourl:
    """The response to a request for ``url`` from byte ``offset`` on."""
    request = urllib.request.Request(url, headers=resume_headers(offset))
    try:
        return urllib.request.urlopen(request, timeout=TIMEOUT_S)
    except urllib.error.HTTPError as error:
        if error.code == http.HTTPStatus.REQUESTED_RANGE_NOT_SATISFIABLE and offset:
            return _open(url, 0)  # the file changed or the .part is whole: start over
        raise DownloadError(
            f"could not download {url}: HTTP {error.code} {error.reason}"
        ) from error
    except urllib.error.URLError as error:
        raise DownloadError(f"could not download {url}: {error.reason}") from error
    except (OSError, http.client.HTTPException) as error:
        raise DownloadError(f"could not download {url}: {error}") from error


def _read(response: http.client.HTTPResponse | urllib.response.addinfourl, url: str) -> bytes:
    try:
        return response.read(CHUNK_BYTES)
    except (OSError, http.client.HTTPException) as error:
        raise DownloadError(
            f"could not download {url}: {str(error) or type(error).__name__} while reading; "
            "run again to resume"
        ) from error


def _extract(archive: Path, folder: Path) -> None:
    """Extract VGN's sets and the licence from the repository archive ``archive`` (a
    ``.tar.gz`` with one top folder) into ``folder``, in the data folder's layout.

    Raises ArchiveError for an unreadable archive, a member with an absolute path or ``..``
    anywhere in it, and a link or special file among the members extracted.
    """
    try:
        with tarfile.open(archive, "r:gz") as tar:
            for member in tar:
                destination = _destination(archive, member)
                if destination is None or member.isdir():
                    continue
                if not member.isfile():
                    raise ArchiveError(f"{archive}: refusing {member.name!r}, not a regular file")
                path = folder / destination
                path.parent.mkdir(parents=True, exist_ok=True)
                with tar.extractfile(member) as source, open(path, "wb") as file:
                    shutil.copyfileobj(source, file)
    except (tarfile.TarError, EOFError, zlib.error, gzip.BadGzipFile) as error:
        raise ArchiveError(f"{archive} is not a complete .tar.gz archive: {error}") from error


def _destination(archive: Path, member: tarfile.TarInfo) -> PurePosixPath | None:
    """Where ``member`` goes relative to the sets' folder; None for members not taken."""
    path = PurePosixPath(member.name)
    if path.is_absolute() or ".." in path.parts or "\\" in member.name:
        raise ArchiveError(f"{archive}: refusing {member.name!r}, a path leaving the archive")
    inner = PurePosixPath(*path.parts[1:]) if len(path.parts) > 1 else None
    if inner == PurePosixPath("LICENSE"):
        return PurePosixPath(LICENSE)
    if inner is None or len(inner.parts) != 5 or inner.parts[:2] != UPSTREAM_SETS.parts:
        return None
    scene, split, name = inner.parts[2:]
    return PurePosixPath(scene, split, name) if (scene, split) in _SETS else None


def _verify(folder: Path, expected: dict[str, str], url: str) -> None:
    """Raise ArchiveError naming the first files in ``folder`` that differ from ``expected``."""
    found = manifest(folder)
    wrong = sorted(p for p in expected.keys() | found.keys() if found.get(p) != expected.get(p))
    if not wrong:
        return
    problems = [f"{p} ({_problem(p in expected, p in found)})" for p in wrong[:5]]
    more = f" and {len(wrong) - 5} more" if len(wrong) > 5 else ""
    raise ArchiveError(
        f"the archive from {url} differs from the pinned one: {', '.join(problems)}{more}"
    )


def _problem(expected: bool, found: bool) -> str:
    """What is wrong with a file expected or found, and not both with the same digest."""
    return "missing" if not found else "unexpected" if not expected else "content differs"
