"""Fixtures shared by the test folders."""

from pathlib import Path

import pytest

WIDE_JAW = Path(__file__).with_name("wide-jaw.toml")
"""A made-up rigid parallel jaw opening 110 mm: a spec file and nothing else."""


@pytest.fixture(scope="session")
def wide_jaw() -> Path:
    """The path of the made-up 110 mm parallel jaw's spec file."""
    return WIDE_JAW


@pytest.fixture(scope="session")
def ray_cluster():
    """A one-node Ray cluster of 2 CPUs (``.address`` is its host:port), started once per session
    (several seconds) and stopped at its end; skips the tests that use it when Ray, the
    optional extra 'cluster', is not installed."""
    pytest.importorskip("ray")
    from ray.cluster_utils import Cluster

    cluster = Cluster(
        initialize_head=True, head_node_args={"num_cpus": 2, "include_dashboard": False}
    )
    try:
        yield cluster
    finally:
        cluster.shutdown()


def _without_timings(value):
    """``value`` (a round record, a summary, lists of them) without its planning times."""
    if isinstance(value, dict):
        return {k: _without_timings(v) for k, v in value.items() if not k.startswith("planning_s")}
    if isinstance(value, list):
        return [_without_timings(v) for v in value]
    return value


@pytest.fixture
def without_timings():
    """Benchmark records and summaries without their planning times, which no run repeats."""
    return _without_timings
