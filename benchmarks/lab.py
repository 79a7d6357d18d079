"""Puts the checkout's root on ``sys.path``, so that a benchmark run as ``python
benchmarks/NAME.py`` imports the lab's helper as ``experiments.scripts``, outside the installed
package. Every benchmark imports this module before that helper."""

import sys
from pathlib import Path

ROOT = str(Path(__file__).resolve().parents[1])
if ROOT not in sys.path:
    sys.path.insert(1, ROOT)  # after the script's own folder
