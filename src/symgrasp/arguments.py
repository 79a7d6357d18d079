"""Building blocks of command-line options, argparse only: bounded numbers as argparse types
and a configuration field's documentation as an option's help. The ``symgrasp`` command
(`symgrasp.cli`) and the options a package offers scripts (`symgrasp.parallel.options`) share
them, so that a value is checked, and a field described, the same way everywhere.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def integer(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse type: an integer in [lo, hi]."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be an integer in [{lo}, {hi}], got {text!r}")
        return value

    return parse


def number(lo: float, hi: float) -> Callable[[str], float]:
    """An argparse type: a finite number in [lo, hi]."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not lo <= value <= hi:  # NaN fails too
            raise argparse.ArgumentTypeError(f"must be a number in [{lo:g}, {hi:g}], got {text!r}")
        return value

    return parse


def sentence(doc: str) -> str:
    """A field's documentation (`symgrasp.fields.field_docs`) as an option's help: lower case,
    no final full stop, ``%`` escaped for argparse."""
    if len(doc) > 1 and doc[0].isupper() and doc[1].islower():
        doc = doc[0].lower() + doc[1:]
    return doc.removesuffix(".").replace("%", "%%")
