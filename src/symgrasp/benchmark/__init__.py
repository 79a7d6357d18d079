"""The declutter benchmark (VGN's and the paper's protocol)."""

from symgrasp.benchmark.declutter import NONE_FOUND, Attempt, Round, run_round

__all__ = ["NONE_FOUND", "Attempt", "Round", "run_round"]
