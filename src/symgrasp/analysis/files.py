"""Atomic writers for the figures' text, JSON and PNG files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from symgrasp.atomic import write_atomic


def write_text(path: Path, text: str) -> Path:
    """``text`` as UTF-8 at ``path``, atomically."""
    return write_atomic(path, lambda file: file.write(text.encode("utf-8")))


def write_json(path: Path, data: dict[str, Any]) -> Path:
    """``data`` as indented JSON at ``path``, atomically."""
    return write_text(path, json.dumps(data, indent=1, ensure_ascii=False) + "\n")


def save_figure(figure: Figure, path: Path) -> Path:
    """``figure`` as a PNG at ``path``, atomically; the figure is closed."""
    try:
        return write_atomic(path, lambda file: figure.savefig(file, format="png", dpi=120))
    finally:
        plt.close(figure)
