"""A made-up gripper from its spec file alone, end to end on a tiny run: `symgrasp gripper
show`, a grasp database on one object, a few labelled scenes, one training epoch and one
benchmark round; the dataset and the model carry the spec, so once they exist the file is not
needed."""

import json
import shutil

from symgrasp.cli import main
from symgrasp.detect import GraspDetector
from symgrasp.sim import load_gripper


def test_a_made_up_gripper_end_to_end(wide_jaw, tmp_path, capsys):
    spec_file = tmp_path / "my-jaw.toml"
    shutil.copy(wide_jaw, spec_file)
    spec = load_gripper(spec_file)
    main(["gripper", "show", str(spec_file), "--out", str(tmp_path / "jaw.png")])
    assert "opening 110 mm" in capsys.readouterr().out
    assert (tmp_path / "jaw.png").stat().st_size > 10_000

    data, run, bench = tmp_path / "data", tmp_path / "run", tmp_path / "bench"
    main(["data", "generate", "--objects", "blocks", "--gripper", str(spec_file),
          "--pool-size", "1", "--grasps", "10", "--directions", "4", "--scenes", "10",
          "--out", str(data)])  # fmt: skip
    databases = list((data / "db").glob("*.npz"))
    assert len(databases) == 1 and "_wide-jaw_" in databases[0].name
    main(["train", "--data", str(data), "--gripper", str(spec_file), "--out", str(run),
          "--epochs", "1", "--batch-size", "3", "--widths", "2", "2", "4", "4",
          "--features", "4"])  # fmt: skip

    spec_file.unlink()  # from here on the dataset and the model are all there is
    main(["data", "inspect", str(data), "--validate", "2"])
    assert json.loads((data / "card.json").read_text())["label_validation"]["trials"] <= 2
    assert GraspDetector.from_pretrained(run / "best.pt", device="cpu").gripper == spec
    main(["bench", "declutter", "--model", str(run / "best.pt"), "--objects", "blocks",
          "--num-objects", "2", "--rounds", "1", "--no-diagnose", "--gripper", str(wide_jaw),
          "--validity", "0", "--no-confidence", "--out", str(bench)])  # fmt: skip
    summary = json.loads((bench / "results.json").read_text())["summary"]
    assert summary["rounds"] == 1 and not summary["errors"]
    assert summary["executed"] >= 1  # no thresholds: the one-epoch model's best free grasps run
