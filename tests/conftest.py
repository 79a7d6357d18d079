"""Fixtures shared by the test folders.

The data a user downloads (VGN's object sets and weights, MuJoCo Menagerie's hands) is optional:
a test that needs it asks for the `vgn_data`, `vgn_weights` or `menagerie` fixture, or calls
`missing_data` when a script it runs reports the data missing, and is marked ``data``
(automatically for the fixtures). Without the data such a test skips, naming what is missing, so
a newcomer's ``make test`` passes on a fresh clone; with ``SYMGRASP_REQUIRE_DATA=1`` it fails
instead, so that a run meant to cover the data (``pytest -m data`` in .ci/run) cannot pass by
skipping.
"""

import os
import subprocess
import sys
from pathlib import Path
from typing import NoReturn

import numpy as np
import pytest
import torch

from symgrasp.objects.folder import DATA_ENV, VGN_ROOT

ROOT = Path(__file__).resolve().parents[1]
"""The checkout."""

SHARED = Path(os.environ.get(DATA_ENV) or ROOT.parent / "shared")
"""The data a user downloads, as the tests find it: the data folder ``$SYMGRASP_DATA`` names,
else ../shared beside the checkout."""

REQUIRE_DATA = os.environ.get("SYMGRASP_REQUIRE_DATA") == "1"
"""Missing data fails a test instead of skipping it."""

DATA_FIXTURES = {"vgn_data", "vgn_weights", "menagerie"}
"""The fixtures that hand a test the downloaded data; a test using one is marked ``data``."""


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        "data: needs the data a user downloads (skips without it; `pytest -m data` runs these)",
    )


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if DATA_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.data)


def missing_data(reason: str) -> NoReturn:
    """Skip the calling test because the downloaded data ``reason`` names is missing (fail
    under ``SYMGRASP_REQUIRE_DATA=1``). Tests marked ``data`` call it."""
    if REQUIRE_DATA:
        pytest.fail(f"SYMGRASP_REQUIRE_DATA=1, but {reason}")
    pytest.skip(reason)


WIDE_JAW = Path(__file__).with_name("wide-jaw.toml")
"""A made-up rigid parallel jaw opening 110 mm: a spec file and nothing else."""


@pytest.fixture(scope="session")
def wide_jaw() -> Path:
    """The path of the made-up 110 mm parallel jaw's spec file."""
    return WIDE_JAW


@pytest.fixture(scope="session")
def shared() -> Path:
    """The folder of the data a user downloads (`SHARED`), whether or not it holds anything."""
    return SHARED


@pytest.fixture(scope="session")
def vgn_data() -> Path:
    """The data folder holding VGN's object sets (``objects/vgn``); skips the test without one."""
    if not (SHARED / VGN_ROOT).is_dir():
        missing_data(f"VGN's object sets are not in {SHARED / VGN_ROOT}")
    return SHARED


@pytest.fixture(scope="session")
def vgn_weights() -> Path:
    """The data folder holding VGN's network weights (``peers/vgn/vgn_conv.pth``); skips the
    test without them."""
    from symgrasp.peers.vgn import WEIGHTS

    if not (SHARED / WEIGHTS).is_file():
        missing_data(f"VGN's weights are not in {SHARED / WEIGHTS}")
    return SHARED


@pytest.fixture(scope="session")
def menagerie() -> Path:
    """MuJoCo Menagerie's reference hands (``reference/menagerie``); skips the test without them."""
    folder = SHARED / "reference" / "menagerie"
    if not folder.is_dir():
        missing_data(f"the reference hands are not in {folder}")
    return folder


@pytest.fixture(scope="module")
def ray_cluster():
    """A one-node Ray cluster of 2 CPUs (``.address`` is its host:port), started once per test
    module (several seconds) and stopped at its end: left running, it would be the cluster
    that a later script's ``ray.init`` joins. Skips the tests that use it when Ray, the
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


@pytest.fixture
def fake_rounds(monkeypatch):
    """Benchmark rounds without a simulator or a model: ``fake_rounds(play)`` has
    `symgrasp.benchmark.runner` call ``play`` in place of `run_round` (the same arguments; it
    returns a `Round` or raises), its workers holding a stand-in planner of the Franka hand
    and no object set."""
    from symgrasp.benchmark import runner

    class Planner:
        gripper = "franka"

    def use(play) -> None:
        monkeypatch.setattr(runner, "run_round", play)
        monkeypatch.setattr(runner, "_init_worker", lambda config, out: runner._WORKER.update(
            config=config, planner=Planner(), out=out, objects=None))  # fmt: skip

    return use


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


def grasp_rotation(approach, closing) -> np.ndarray:
    """The grasp frame [e_x e_y e_z] (3, 3) of an ``approach`` e_x and a ``closing`` axis e_z
    (each normalised; they must be orthogonal)."""
    e_x = np.asarray(approach, float) / np.linalg.norm(approach)
    e_z = np.asarray(closing, float) / np.linalg.norm(closing)
    return np.c_[e_x, np.cross(e_z, e_x), e_z]


def bingham2d_channels(Rot: np.ndarray, gaps=(20.0, 10.0)) -> np.ndarray:
    """The 9 ``bingham2d`` channels whose Bingham mode is ``Rot``'s e_z, with eigenvalue gaps
    ``gaps`` towards e_x and e_y, and whose approach is ``Rot``'s e_x."""
    from symgrasp.bingham import sym_to_triu

    A = Rot @ np.diag([-gaps[0], -gaps[1], 0.0]) @ Rot.T
    return np.r_[sym_to_triu(torch.tensor(A)).numpy(), Rot[:, 0]]


class FixedNet(torch.nn.Module):
    """A stand-in network that returns prescribed volumes, whatever the TSDF: at each voxel of
    ``voxels`` ``{(i, j, k): (score, validity probability, channels)}``, nothing valid
    elsewhere (validity logit ``background_validity``)."""

    def __init__(self, representation: str, voxels: dict, background_validity: float = -9.0):
        from symgrasp import rotation

        super().__init__()
        r = 40
        self.representation = rotation.get(representation)
        self.score = torch.zeros(1, r, r, r)
        self.validity = torch.full((1, r, r, r), background_validity)
        self.rot = torch.zeros(1, self.representation.channels, r, r, r)
        for (i, j, k), (score, validity, channels) in voxels.items():
            self.score[0, i, j, k] = score
            self.validity[0, i, j, k] = torch.logit(torch.tensor(validity))
            self.rot[0, :, i, j, k] = torch.as_tensor(channels)

    def forward(self, tsdf):
        from symgrasp.model.network import GraspOutput

        b = tsdf.shape[0]
        return GraspOutput(
            self.score.expand(b, -1, -1, -1),
            self.validity.expand(b, -1, -1, -1),
            self.rot.expand(b, -1, -1, -1, -1),
        )
