"""The models shipped in the package: each one is what its name says it is."""

import pytest

from symgrasp.detect import PRETRAINED, GraspDetector
from symgrasp.detect.pretrained import shipped_path
from symgrasp.model.checkpoint import load_checkpoint
from symgrasp.names import GRIPPERS, REPRESENTATIONS


@pytest.mark.parametrize("name", PRETRAINED)
def test_a_shipped_model_is_the_representation_and_gripper_its_name_gives(name):
    representation, gripper = name.split("-", 1)
    assert representation in REPRESENTATIONS and gripper in GRIPPERS
    state = load_checkpoint(shipped_path(name))
    assert "optimizer" not in state and "model_raw" not in state
    detector = GraspDetector.from_pretrained(name, device="cpu")
    assert detector.info["representation"] == representation
    assert detector.gripper.name == gripper
