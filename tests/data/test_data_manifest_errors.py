"""A hand-edited dataset manifest is refused naming the file and the field (`read_manifest`,
`config_from_dict`), not read as an unfinished dataset (a string's characters counted as ids)
or one whose files changed (an id listed twice hashed twice)."""

import dataclasses
import json
import re

import pytest

from symgrasp.config import SceneConfig
from symgrasp.data.card import manifest_mismatches
from symgrasp.data.dataset import GraspDataset, read_manifest
from symgrasp.data.generate import config_from_dict

MANIFEST = {"gripper": "franka", "object_set": "blocks", "k_max": 8, "scene_ids": [3, 0, 7]}

READERS = (read_manifest, lambda p: GraspDataset(p.parent), lambda p: manifest_mismatches(p.parent))
"""Where a manifest ``p`` is read: alone, by training and by `data inspect`."""


def _write(root, **changes):
    """A dataset folder ``root`` of no scene file, whose manifest is `MANIFEST` with
    ``changes``; its manifest's path."""
    (root / "scenes").mkdir(parents=True, exist_ok=True)
    path = root / "manifest.json"
    path.write_text(json.dumps({**MANIFEST, **changes}))
    return path


def test_a_valid_manifest_is_read_as_written(tmp_path):
    path = _write(tmp_path, scene_ids=[3, 0, 7], k_max=1, dataset_hash="x")
    assert read_manifest(path) == json.loads(path.read_text())


@pytest.mark.parametrize(
    "changes, said",
    [
        ({"scene_ids": "0-1"}, 'scene_ids must be a list of integers ≥ 0, got "0-1"'),
        ({"scene_ids": ["0", "1"]}, 'scene_ids must be a list of integers ≥ 0, got ["0", "1"]'),
        ({"scene_ids": [0, True]}, "scene_ids must be a list of integers ≥ 0, got [0, true]"),
        ({"scene_ids": [0, -1]}, "scene_ids must be a list of integers ≥ 0, got [0, -1]"),
        ({"scene_ids": [0, 2.0]}, "scene_ids must be a list of integers ≥ 0, got [0, 2.0]"),
        ({"scene_ids": [4, 0, 4]}, "scene_ids must name each scene once, got 4 more than once"),
        ({"k_max": "eight"}, 'k_max must be an integer ≥ 1, got "eight"'),
        ({"k_max": 0}, "k_max must be an integer ≥ 1, got 0"),
        ({"k_max": True}, "k_max must be an integer ≥ 1, got true"),
        ({"k_max": 8.5}, "k_max must be an integer ≥ 1, got 8.5"),
    ],
)
def test_a_bad_field_is_named_with_the_file_wherever_the_manifest_is_read(tmp_path, changes, said):
    path = _write(tmp_path, **changes)
    whole = re.escape(f"{path} is not a valid dataset manifest: {said}") + "$"
    for read in READERS:
        with pytest.raises(ValueError, match=whole):
            read(path)


def test_ids_listed_twice_are_named_in_order_the_first_five(tmp_path):
    path = _write(tmp_path, scene_ids=[9, 8, 7, 6, 5, 4, 3] * 2 + [0])
    with pytest.raises(ValueError, match=r"got 3, 4, 5, 6, 7, … more than once$"):
        read_manifest(path)


def test_a_recorded_configuration_names_its_file_and_field(tmp_path):
    path = tmp_path / "manifest.json"
    config = dataclasses.asdict(SceneConfig(k_max=5))
    assert config_from_dict(config, path) == SceneConfig(k_max=5)
    with pytest.raises(ValueError, match=rf"^{re.escape(str(path))} .*: its config: k_max must"):
        config_from_dict({**config, "k_max": "eight"}, path)
    del config["database"]
    with pytest.raises(ValueError, match=r"its config: it lacks 'database'$"):
        config_from_dict(config, path)
