"""Bad input, table-driven (the tables: tests/bad_input_cases.py): every case ends with a non-zero
exit and one line that names the argument or file (command line), or a ValueError/TypeError
with a message (API); never a traceback, a hang or a silently wrong run. Arguments are checked
before any work starts, so each case takes well under a second. Inputs that give no grasp for
a cause they show end with no grasp and one warning naming it."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pytest
from bad_input_cases import (
    API,
    ARGUMENTS,
    CLI,
    MODEL,
    WARNED_API,
    WARNED_CLI,
    detect_argv,
    make_files,
)

from symgrasp.cli import main
from symgrasp.detect import NoGraspWarning


@pytest.fixture
def files(tmp_path, wide_jaw, monkeypatch):
    """The `make_files` folder, the current folder (the `PLANNERS` cases import from it)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    return make_files(tmp_path, wide_jaw)


RAY_CLI = {
    "--ray-address unreachable": (lambda d: ["data", "generate", "--out", str(d / "g"), "--backend", "ray", "--ray-address", "127.0.0.1:1"], "ray_address 127.0.0.1:1: no Ray cluster answers there"),
    "--ray-address not host:port": (lambda d: ["bench", "declutter", "--out", str(d / "g"), "--backend", "ray", "--ray-address", "headnode"], "ray_address must be host:port"),
    "RAY_ADDRESS unreachable": (lambda d: ["bench", "declutter", "--out", str(d / "g"), "--backend", "ray"], "ray_address 127.0.0.1:1"),
}  # fmt: skip
"""Ray's bad input, where Ray is installed (the extra 'cluster'): one line, nothing written."""


@pytest.mark.parametrize("case", CLI)
def test_command_line(case, files, capsys):
    _refused(CLI[case], files, capsys)


@pytest.mark.parametrize("case", RAY_CLI)
def test_command_line_with_ray(case, files, capsys, monkeypatch):
    pytest.importorskip("ray")
    monkeypatch.setenv("RAY_ADDRESS", "127.0.0.1:1")  # read when --ray-address is not given
    _refused(RAY_CLI[case], files, capsys)
    assert not (files / "g").exists()


HEAVY = ("torch", "mujoco", "trimesh", "matplotlib")
"""What a bad argument must be refused without: each takes from a fifth of a second (MuJoCo) to
two seconds (torch) to import."""

_PLAY_BLOCKED = """
import contextlib, io, json, sys
for name in json.loads(sys.argv[1]):
    sys.modules[name] = None  # importing it raises ImportError
from symgrasp.cli import main
results = []
for argv in json.loads(sys.argv[2]):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            main(argv)
            code = 0
        except SystemExit as exit_:
            code = exit_.code
        except BaseException as error:
            code = f"{type(error).__name__}: {error}"
    results.append([code if isinstance(code, str) else err.getvalue().strip(), code])
print(json.dumps(results))
"""


def test_bad_arguments_are_refused_before_the_heavy_imports(files):
    """Every `ARGUMENTS` case, played in one process where importing torch, MuJoCo, trimesh or
    matplotlib fails, still ends in its own one-line refusal: it is found before them."""
    argvs = [argv(files) for argv, _ in ARGUMENTS.values()]
    played = subprocess.run(
        [sys.executable, "-c", _PLAY_BLOCKED, json.dumps(HEAVY), json.dumps(argvs)],
        capture_output=True, text=True, check=True, timeout=120, cwd=files,
    )  # fmt: skip
    for (case, (_, named)), (message, code) in zip(
        ARGUMENTS.items(), json.loads(played.stdout), strict=True
    ):
        assert code not in (0, None) and named in message and len(message.splitlines()) == 1, (
            f"{case}: {message}"
        )


def test_backend_ray_without_ray_installed(files, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails as if not installed
    argv = ["data", "generate", "--out", str(files / "g"), "--backend", "ray"]
    _refused((lambda d: argv, "pip install 'symgrasp[cluster]'"), files, capsys)
    assert not (files / "g").exists()


def _refused(case, files, capsys):
    """Run the command of ``case`` = (argv of the files folder, text its message names) and
    check it fails in one line naming that text, leaving no temporary file."""
    argv, named = case
    with pytest.raises(SystemExit) as exit_:
        main(argv(files))
    code = exit_.value.code
    captured = capsys.readouterr()
    message = code if isinstance(code, str) else captured.err.strip()
    assert code not in (0, None), message
    assert "Traceback" not in captured.err + captured.out
    assert len(message.splitlines()) == 1, message
    assert named in message
    assert "error" in message
    assert not list(files.rglob("*.tmp")), "a temporary file was left behind"
    assert not (files / "b").exists(), "a refused benchmark left its folder behind"


def test_detect_with_no_grasp_is_an_answer(files, capsys):
    """An empty table is a valid scene: exit 0, zero grasps, pictures, no warning."""
    main(detect_argv(files))
    captured = capsys.readouterr()
    assert "no grasp found" in captured.out and captured.err == ""
    assert json.loads((files / "out" / "grasps.json").read_text())["grasps"] == []
    assert (files / "out" / "grasps.png").stat().st_size > 0


@pytest.mark.parametrize("case", WARNED_CLI)
def test_command_line_without_grasp_says_why(case, files, capsys):
    argv, named = WARNED_CLI[case]
    main(argv(files))  # exit 0: no grasp is an answer
    captured = capsys.readouterr()
    assert "no grasp found" in captured.out
    assert len(captured.err.splitlines()) == 1, captured.err
    assert captured.err.startswith("warning: no grasp found: ") and named in captured.err
    assert json.loads((files / "out" / "grasps.json").read_text())["grasps"] == []


def test_data_show_writes_the_path_it_prints(tmp_path, capsys):
    from symgrasp.model.synthetic import SyntheticGraspDataset  # noqa: F401  (torch present)

    dataset = tmp_path / "d"
    main(["data", "generate", "--objects", "blocks", "--gripper", "franka", "--pool-size", "1",
          "--grasps", "5", "--directions", "4", "--scenes", "1", "--out", str(dataset)])  # fmt: skip
    capsys.readouterr()
    main(["data", "show", str(dataset), "--out", str(tmp_path / "picture")])
    printed = capsys.readouterr().out.strip()
    assert printed == str(tmp_path / "picture") and (tmp_path / "picture").stat().st_size > 0


# -- the Python API ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def detector():
    from symgrasp.detect import GraspDetector

    return GraspDetector.from_pretrained(MODEL, device="cpu")


@pytest.mark.parametrize("case", API)
def test_api(case, detector):
    call, named = API[case]
    with pytest.raises((ValueError, TypeError), match=re.escape(named)):
        call(detector)


@pytest.mark.parametrize("case", WARNED_API)
def test_api_without_grasp_says_why(case, detector):
    call, named = WARNED_API[case]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert call(detector) == []
    assert [w.category for w in caught] == [NoGraspWarning]
    assert named in str(caught[0].message)


def test_a_depth_image_with_a_channel_axis_is_one_image(detector):
    K, T = np.diag([50.0, 50, 1]), np.eye(4)
    depth = np.full((48, 64), 0.6, dtype=np.float32)
    flat = detector.fuse(depth, K, T).grid()
    channel = detector.fuse(depth[..., None], K, T).grid()
    assert np.array_equal(flat.cpu().numpy(), channel.cpu().numpy())


def test_a_corrupted_grasp_database_cache_is_recomputed(tmp_path):
    from symgrasp.config import DatabaseConfig
    from symgrasp.data.grasp_db import cached_database, database_key
    from symgrasp.sim import FRANKA, object_set

    obj = object_set("blocks", 1)[0]
    cfg = DatabaseConfig(grasps=3, max_candidates=10, directions=4)
    good = cached_database(obj, FRANKA, tmp_path, cfg)
    path = tmp_path / f"{obj.name}_{FRANKA.name}_{database_key(obj, FRANKA, cfg, 0)}.npz"
    path.write_bytes(b"PK\x03\x04 truncated")
    with pytest.warns(UserWarning, match="recomputing the corrupted grasp database"):
        again = cached_database(obj, FRANKA, tmp_path, cfg)
    np.testing.assert_array_equal(again.T_object_tcp, good.T_object_tcp)
    shutil.rmtree(tmp_path)


def test_training_needs_a_validation_split(tmp_path, capsys):
    dataset = tmp_path / "d"
    main(["data", "generate", "--objects", "blocks", "--gripper", "franka", "--pool-size", "1",
          "--grasps", "5", "--directions", "4", "--scenes", "2", "--out", str(dataset)])  # fmt: skip
    with pytest.raises(SystemExit, match="0 validation scenes"):
        main(["train", "--data", str(dataset), "--gripper", "franka", "--out", str(tmp_path / "r")])
