"""Where object sets live on disk: the data folder and the named sets inside it.

The data folder is ``$SYMGRASP_DATA`` when set, else ``$XDG_CACHE_HOME/symgrasp`` (by default
``~/.cache/symgrasp``). VGN's sets (Breyer et al., "Volumetric Grasping Network", CoRL 2020)
sit in it as ``objects/vgn/{pile,packed}/{train,test}``, the layout ``symgrasp objects fetch
vgn`` writes.
"""

from __future__ import annotations

import os
from pathlib import Path

from symgrasp.names import MESH_OBJECT_SETS

DATA_ENV = "SYMGRASP_DATA"
"""The environment variable naming the data folder."""

VGN_ROOT = Path("objects") / "vgn"
"""VGN's object sets, relative to the data folder."""


class MissingData(FileNotFoundError):
    """Data a user downloads (an object set, VGN's weights) is not in the data folder; the
    message names what, where it was looked for and how to get it. Commands, scripts and tests
    tell it from other errors: a command or script stops with its one line and exit status
    `EX_NOINPUT`, a test skips with it."""


EX_NOINPUT = 66
"""The exit status of a command or script whose input data is missing (`MissingData`;
sysexits.h: "cannot open input"), so that a caller (the tests) tells missing data from a
failure."""


def user_folder() -> Path:
    """The per-user folder: ``$XDG_CACHE_HOME/symgrasp``, by default ``~/.cache/symgrasp``."""
    cache = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(cache) / "symgrasp"


def data_folder() -> Path:
    """The data folder: ``$SYMGRASP_DATA``, else the per-user folder (`user_folder`)."""
    if os.environ.get(DATA_ENV):
        return Path(os.environ[DATA_ENV]).expanduser()
    return user_folder()


def set_folder(name: str) -> Path:
    """The folder of the named mesh set (``vgn-pile-train`` → ``objects/vgn/pile/train``).

    Raises ValueError for an unknown name, and `MissingData` naming the folder searched and how
    to get the set when it is not in the data folder.
    """
    if name not in MESH_OBJECT_SETS:
        raise ValueError(f"object set must be one of {MESH_OBJECT_SETS}, got {name!r}")
    _, scene, split = name.split("-")
    folder = data_folder() / VGN_ROOT / scene / split
    if not folder.is_dir():
        raise MissingData(
            f"object set {name} is not in the data folder: {folder} does not exist; run "
            f"`symgrasp objects fetch vgn`, or point {DATA_ENV} at a folder holding {VGN_ROOT}"
        )
    return folder
