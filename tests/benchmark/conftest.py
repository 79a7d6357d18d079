"""What the benchmark's tests share: a loaded machine, this process's torch threads set."""

import subprocess
import sys

import pytest

HOG_S = 300
"""Seconds a CPU hog spins at most: it ends on its own should its test's teardown not run."""


@pytest.fixture
def cpu_hog():
    """A busy loop in another process for the test's length: the machine loaded, as a shared
    one is (a round's floats must not depend on it). Yields the process; the test can check it
    still spun at its end."""
    spin = f"import time\nend = time.monotonic() + {HOG_S}\nwhile time.monotonic() < end:\n    pass"
    hog = subprocess.Popen([sys.executable, "-c", spin])
    try:
        yield hog
    finally:
        hog.kill()
        hog.wait()


@pytest.fixture
def caller_threads():
    """``torch.set_num_threads`` for a test, this process's setting restored after it."""
    import torch

    before = torch.get_num_threads()
    yield torch.set_num_threads
    torch.set_num_threads(before)
