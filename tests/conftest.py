"""Fixtures shared by the test folders."""

from pathlib import Path

import pytest

WIDE_JAW = Path(__file__).with_name("wide-jaw.toml")
"""A made-up rigid parallel jaw opening 110 mm: a spec file and nothing else."""


@pytest.fixture(scope="session")
def wide_jaw() -> Path:
    """The path of the made-up 110 mm parallel jaw's spec file."""
    return WIDE_JAW
