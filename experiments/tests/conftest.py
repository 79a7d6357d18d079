"""Fixtures of the lab's tests. The data a user downloads is found as the library's tests find it
(tests/conftest.py: the data folder, the ``data`` marker, `missing_data` and the fixtures that
hand a test the data), one rule for both; the lab adds a campaign plan's steps as its driver
reads them."""

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.conftest import (  # noqa: F401  (the hooks and fixtures take effect here too)
    menagerie,
    missing_data,
    pytest_collection_modifyitems,
    pytest_configure,
    shared,
    vgn_data,
)

ROOT = Path(__file__).resolve().parents[2]
"""The checkout."""


def campaign_steps(*plans: str) -> dict[str, dict]:
    """The steps of the campaign ``plans`` (paths from the checkout), read together as the
    driver reads them (``experiments/campaign.py show``), by name; ``{root}`` is /root."""
    shown = subprocess.run(
        [sys.executable, "experiments/campaign.py", "show", *plans, "--root", "/root"],
        cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT / "src")}, capture_output=True,
        text=True,
    )  # fmt: skip
    assert shown.returncode == 0, shown.stderr
    return {s["name"]: s for s in map(json.loads, shown.stdout.splitlines())}
