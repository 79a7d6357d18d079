"""The Ray backend on a local one-node cluster of 2 CPUs (the module's `ray_cluster`): the
same bytes as the process pool for a dataset and a benchmark, a killed worker's task run
again, a raising task recorded and not retried, and a cluster of other versions refused."""

import hashlib
import json
import math
import os
import signal
import threading
from pathlib import Path

import pytest

from symgrasp.cli import main
from symgrasp.config import ParallelConfig
from symgrasp.parallel import Failure, Job, open_executor

pytest.importorskip("ray")

TINY = ["--objects", "blocks", "--gripper", "franka", "--pool-size", "2", "--grasps", "40"]
TINY += ["--directions", "8"]


def _files(root):
    """Every file under ``root`` (manifest, databases, scenes) by path, as its SHA-256."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(Path(root).rglob("*"))
        if p.is_file()
    }


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """A 12-scene dataset made by the process pool of 2 workers."""
    root = tmp_path_factory.mktemp("pool") / "data"
    main(["data", "generate", *TINY, "--scenes", "12", "--workers", "2", "--out", str(root)])
    return root


def _ray(cluster, *extra):
    return ["--backend", "ray", "--ray-address", cluster.address, *extra]


def test_a_raising_task_is_a_failure_not_retried(ray_cluster):
    with open_executor(ParallelConfig("ray", ray_address=ray_cluster.address)) as executor:
        assert executor.workers == 2 and not executor.in_process
        values = dict(executor.map(Job(math.sqrt), [4, -1, 9], "sqrt"))
    assert values[4] == 2.0 and values[9] == 3.0
    assert isinstance(values[-1], Failure) and values[-1].error == "ValueError: math domain error"


def test_a_dataset_made_on_ray_is_the_process_pools(ray_cluster, reference, tmp_path):
    main(["data", "generate", *TINY, "--scenes", "12", *_ray(ray_cluster), "--out", str(tmp_path)])
    assert _files(tmp_path) == _files(reference)


def _worker_pids(cluster, title):
    """Processes of ``cluster``'s raylet whose title is ``title`` (Ray names a busy worker
    ``ray::<task>``)."""
    raylet = cluster.head_node.all_processes["raylet"][0].process.pid
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            parent = int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
            busy = Path(f"/proc/{pid}/cmdline").read_bytes().startswith(title)
        except (OSError, IndexError, ValueError):
            continue
        if parent == raylet and busy:
            yield int(pid)


def test_a_worker_killed_mid_task_is_run_again_and_the_dataset_is_unchanged(
    ray_cluster, reference, tmp_path
):
    (tmp_path / "data").mkdir()
    for db in (reference / "db").iterdir():  # the databases cached: the kill lands in a scene
        (tmp_path / "data" / "db").mkdir(exist_ok=True)
        (tmp_path / "data" / "db" / db.name).write_bytes(db.read_bytes())
    killed, stop = [], threading.Event()

    def kill_one_busy_worker():
        while not stop.is_set() and not killed:
            for pid in _worker_pids(ray_cluster, b"ray::_run"):
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                break

    watcher = threading.Thread(target=kill_one_busy_worker)
    watcher.start()
    try:
        argv = ["data", "generate", *TINY, "--scenes", "12", *_ray(ray_cluster)]
        main([*argv, "--out", str(tmp_path / "data")])
    finally:
        stop.set()
        watcher.join()
    assert len(killed) == 1
    manifest = json.loads((tmp_path / "data" / "manifest.json").read_text())
    assert manifest["scene_ids"] == list(range(12)) and "failed" not in manifest
    assert sorted(p.name for p in (tmp_path / "data" / "scenes").iterdir()) == [
        f"scene_{i:06d}.npz" for i in range(12)
    ]
    assert _files(tmp_path / "data") == _files(reference)


def test_a_benchmark_played_on_ray_is_the_process_pools(ray_cluster, tmp_path, without_timings):
    argv = ["bench", "declutter", "--rounds", "3", "--num-objects", "1", "--seed", "7"]
    main([*argv, "--workers", "2", "--out", str(tmp_path / "pool")])
    main([*argv, *_ray(ray_cluster), "--out", str(tmp_path / "ray")])
    pool, ray = (
        [json.loads(line) for line in (tmp_path / run / "rounds.jsonl").read_text().splitlines()]
        for run in ("pool", "ray")
    )
    assert [r["seed"] for r in ray] == [7, 8, 9] and "error" not in str(ray)
    assert without_timings(ray) == without_timings(pool)
    pool, ray = (
        json.loads((tmp_path / run / "results.json").read_text()) for run in ("pool", "ray")
    )
    assert without_timings(ray) == without_timings(pool)
    assert (tmp_path / "ray" / "config.json").read_bytes() == (
        tmp_path / "pool" / "config.json"
    ).read_bytes()


def test_a_cluster_of_other_versions_is_refused_before_anything_is_written(
    ray_cluster, tmp_path, monkeypatch
):
    import symgrasp

    monkeypatch.setattr(symgrasp, "__version__", "9.9.9")  # this driver only, not the workers
    with pytest.raises(SystemExit) as exit_:
        main(["data", "generate", *TINY, "--scenes", "2", *_ray(ray_cluster), "--out",
              str(tmp_path / "data")])  # fmt: skip
    message = str(exit_.value.code)
    assert message.startswith(f"error: ray_address {ray_cluster.address}: node ")
    assert "symgrasp 0.1.0 there, 9.9.9 here" in message and len(message.splitlines()) == 1
    assert not (tmp_path / "data").exists()


def test_rays_own_version_check_is_one_line(tmp_path, monkeypatch):
    import ray

    def mismatch(**options):
        raise RuntimeError(
            "Version mismatch: The cluster was started with:\n    Ray: 2.9.0\n    Python: "
            "3.10.1\nThis process on node 1.2.3.4 was started with:\n    Ray: 2.60.0\n"
        )

    monkeypatch.setattr(ray, "init", mismatch)
    monkeypatch.setattr("symgrasp.parallel.cluster._check_reachable", lambda address: None)
    with pytest.raises(SystemExit) as exit_:
        main(["data", "generate", "--backend", "ray", "--ray-address", "1.2.3.4:6379", "--out",
              str(tmp_path / "data")])  # fmt: skip
    message = str(exit_.value.code)
    assert message.startswith("error: ray_address 1.2.3.4:6379: Version mismatch: The cluster")
    assert len(message.splitlines()) == 1 and not (tmp_path / "data").exists()
