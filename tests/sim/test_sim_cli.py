"""`symgrasp sim show` writes two non-empty PNGs; `symgrasp gripper show` draws a hand."""

import matplotlib.image as mpimg

from symgrasp.cli import main


def test_sim_show_writes_colour_and_depth_pictures(tmp_path, capsys):
    main(
        [
            "sim",
            "show",
            "--scene",
            "packed",
            "--objects",
            "blocks",
            "--n",
            "3",
            "--out",
            str(tmp_path),
        ]
    )
    printed = capsys.readouterr().out
    for kind in ("color", "depth"):
        path = tmp_path / f"packed_blocks_seed0_{kind}.png"
        assert str(path) in printed
        image = mpimg.imread(path)
        assert image.shape[0] > 100 and image.std() > 0.01  # not a blank picture


def test_gripper_show_draws_a_built_in_hand(tmp_path, capsys):
    """The underactuated kind (the made-up jaw's end-to-end test draws a rigid one)."""
    main(["gripper", "show", "robotiq-2f85", "--out", str(tmp_path / "hand.png")])
    printed = capsys.readouterr().out
    assert "robotiq-2f85 (underactuated): opening 85 mm" in printed
    assert str(tmp_path / "hand.png") in printed
    image = mpimg.imread(tmp_path / "hand.png")
    assert image.shape[0] > 500 and image.std() > 0.05
