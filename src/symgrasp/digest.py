"""A file's identity by its bytes: the SHA-256 that tells two files of one name apart (a
checkpoint, peer weights, a campaign's kept outputs). Imports nothing heavy, so tools that only
compare files (experiments/campaign.py) load no torch."""

from __future__ import annotations

import hashlib
from pathlib import Path


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of the bytes of the file at ``path`` (hex), read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
