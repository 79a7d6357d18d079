"""Bingham distributions on S² and S³ (pure torch)."""

from symgrasp.bingham.normalizer import log_normalizer, second_moments
from symgrasp.bingham.symmetric import sym_to_triu, triu_to_sym

__all__ = ["log_normalizer", "second_moments", "sym_to_triu", "triu_to_sym"]
