"""`symgrasp sim show` writes two non-empty PNGs."""

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
