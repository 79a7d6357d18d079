"""Detectors other than symgrasp's own, behind the planner interface."""
