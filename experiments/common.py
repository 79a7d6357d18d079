"""What the experiments share beyond `scripts`: where their results go, the shipped
model that stands in for every training run in ``--quick`` mode, the order their tables list
the hands in, which validation scenes a checkpoint is looked at on, the Wilson interval of a rate,
a grasp database's prefix, the Table 1 rounds a shipped model replays, an archive of rounds,
a page's text between two markers, issue 39's robustness gap with its verdict, and a planner
that keeps each state it plans in, to replay executed grasps instrumented."""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Callable
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Any

import numpy as np

from symgrasp import rates
from symgrasp.names import GRIPPERS as BUILT_IN

if TYPE_CHECKING:
    from symgrasp.data.grasp_db import GraspDatabase
    from symgrasp.sim.grippers import GripperSpec
    from symgrasp.sim.world import World

RESULTS = Path("experiments/results")
"""Where an experiment's result is published (`add_result_option`)."""

PAPER_HAND = "robotiq-2f85"
"""The hand of the paper's Table 1 (Ko et al. 2024): first in every table."""

GRIPPERS = (PAPER_HAND, *(g for g in BUILT_IN if g != PAPER_HAND))
"""The built-in hands (`symgrasp.names.GRIPPERS`) in the order the tables list them."""

SHIPPED = f"bingham2d-{PAPER_HAND}"
"""The paper's detector for that hand, shipped with the package: the checkpoint looked at by
default, and what ``--quick`` plays in place of every training run."""

GAP_TARGET = 0.03
"""Issue 39: under noise and the side view, SR and CR within 3 points of the clean numbers."""


def wilson(k: int, n: int, z: float = 1.96) -> list[float]:
    """Wilson score 95 % interval of the rate k / n, in percent (NaN for n = 0):
    `symgrasp.rates.wilson`, as the result tables print it."""
    return [round(100 * bound, 2) for bound in rates.wilson(k, n, z)]


def prefix(db: GraspDatabase, n: int) -> GraspDatabase:
    """The database the same seed gives with ``grasps=n``: rows up to the n-th held grasp (a
    database of n grasps is the first n held grasps of a larger one with the same seed)."""
    from symgrasp.data.grasp_db import GraspDatabase

    held = np.flatnonzero(db.held)
    end = held[n - 1] + 1 if len(held) >= n else len(db)
    rows = {
        f.name: getattr(db, f.name)[:end]
        for f in dataclasses.fields(db)
        if f.name not in ("directions", "candidates")
    }
    return GraspDatabase(**rows, directions=db.directions, candidates=int(end))


def add_result_option(parser: argparse.ArgumentParser, name: str) -> None:
    """``--result STEM``, where `scripts.write_result` writes: by default
    ``experiments/results/NAME`` with ``--publish``, else under out/ (`scripts.output_path`)."""
    default = str(RESULTS / name)
    parser.add_argument(
        "--result",
        default=default,
        metavar="STEM",
        help="where the result goes: STEM.json (the numbers, the command, the machine and its "
        f"load) and STEM.md (its tables, if it has any) (default: {default})",
    )


def add_checkpoint_options(parser: argparse.ArgumentParser, scenes: int, threshold: str) -> None:
    """``--checkpoints``, ``--data``, ``--scenes`` and ``--threshold``: the checkpoints a script
    looks at, the validation scenes it looks at them on (`validation_items`) and the validity
    probability it cuts at (``threshold`` says what for)."""
    from symgrasp.config import DEFAULT_VALIDITY

    parser.add_argument("--checkpoints", nargs="+", default=[SHIPPED],
                        help="checkpoint files or shipped model names (default: %(default)s)")  # fmt: skip
    parser.add_argument("--data", default=None,
                        help="dataset folder whose validation split is read (default: each "
                        "checkpoint's own training data)")  # fmt: skip
    parser.add_argument("--scenes", type=int, default=scenes,
                        help=f"validation scenes, spread evenly over the split (default: {scenes})")  # fmt: skip
    parser.add_argument("--threshold", type=float, default=DEFAULT_VALIDITY,
                        help=f"{threshold} (default: %(default)s)")  # fmt: skip


def per_checkpoint(
    args: argparse.Namespace, measure: Callable[[Path, list[dict[str, Any]], float], dict]
) -> list[dict[str, Any]]:
    """``measure(checkpoint, items, threshold)`` of each of ``args.checkpoints`` on its
    validation items (`validation_items`), with its name as ``model``."""
    cells = []
    for name in args.checkpoints:
        checkpoint, items = validation_items(name, args.data, args.scenes, args.quick)
        cells.append({**measure(checkpoint, items, args.threshold), "model": name})
    return cells


def validation_items(
    name: str, data: str | None, scenes: int, quick: bool
) -> tuple[Path, list[dict[str, Any]]]:
    """The checkpoint file of ``name`` (a path or a shipped model's name) and ``scenes`` items
    spread evenly over the validation split of ``data`` (None: the checkpoint's own training
    data), not augmented; in quick mode, synthetic scenes."""
    from symgrasp.detect.pretrained import resolve_model
    from symgrasp.model.checkpoint import load_checkpoint

    checkpoint = resolve_model(name)
    if quick:
        from symgrasp.model.synthetic import SyntheticGraspDataset

        split = SyntheticGraspDataset(scenes, seed=0)
    else:
        from symgrasp.data.dataset import GraspDataset

        data = data or load_checkpoint(checkpoint)["config"]["data"]
        split = GraspDataset(data, split="val", augment=False)
    step = max(1, len(split) // scenes)
    return checkpoint, [split[i] for i in range(0, len(split), step)][:scenes]


def add_table1_options(parser: argparse.ArgumentParser, baselines: str = "") -> None:
    """``--baselines``, ``--rounds`` and ``--num-objects`` of a study paired with Table 1's
    rounds (`table1_rounds`): where they are unpacked (``baselines`` says what the study takes
    from them), and the rounds a cell plays, Table 1's by default."""
    parser.add_argument("--baselines", type=Path, default=Path("out/bench/table"),
                        help="Table 1's rounds, unpacked from experiments/results/"
                        f"declutter_rounds.tar.gz{baselines} (default: %(default)s)")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=100, help="rounds per cell (default: 100)")
    parser.add_argument("--num-objects", type=int, default=5,
                        help="objects per round (default: 5)")  # fmt: skip


def add_decoding_options(parser: argparse.ArgumentParser, result: str, what: str) -> None:
    """The options `decoding.py` and `operating_points.py` share: ``--rounds`` per ``what``,
    ``--seed``, ``--num-objects``, the executor (2 workers by default), ``--out`` (the per-cell
    folders both read, ``out/decoding``) and ``--result`` (``result``)."""
    from symgrasp.parallel.options import add_parallel_options

    parser.add_argument("--rounds", type=int, default=200,
                        help=f"rounds per {what} (default: %(default)s)")  # fmt: skip
    parser.add_argument("--seed", type=int, default=3_000_000,
                        help="seed of round 0 (default: %(default)s)")  # fmt: skip
    parser.add_argument("--num-objects", type=int, default=5,
                        help="objects per round (default: %(default)s)")  # fmt: skip
    add_parallel_options(parser, "rounds")
    parser.set_defaults(workers=2)
    parser.add_argument("--out", default="out/decoding",
                        help="per-cell benchmark folders (default: %(default)s)")  # fmt: skip
    add_result_option(parser, result)


def add_round_options(parser: argparse.ArgumentParser, seed: int, rounds: int, what: str) -> None:
    """``--objects``, ``--seed``, ``--rounds`` and ``--num-objects`` of the training-object
    rounds a campaign's collation reads (``what`` names them in the help): the declutter
    validation's objects, ``seed`` and ``rounds`` by default."""
    from symgrasp.config import VALIDATION_OBJECTS

    parser.add_argument("--objects", default=VALIDATION_OBJECTS,
                        help=f"object set of {what} (default: %(default)s)")  # fmt: skip
    parser.add_argument("--seed", type=int, default=seed,
                        help=f"round seed of the first of {what} (default: %(default)s)")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=rounds,
                        help=f"{what}: rounds of each run (default: %(default)s)")  # fmt: skip
    parser.add_argument("--num-objects", type=int, default=5,
                        help="objects per round (default: %(default)s)")  # fmt: skip
    add_approach_check(parser)


def add_approach_check(parser: argparse.ArgumentParser) -> None:
    """``--table-clearance`` and ``--surface-clearance``
    (`symgrasp.cli.options.add_approach_check`) for the rounds a script plays and reads."""
    from symgrasp.cli.options import add_approach_check as add

    add(parser, "the rounds played and read")


def campaign_root(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    plan: str,
    build: Callable[[Path, argparse.Namespace], None],
) -> None:
    """``args.root``, a collation's campaign root: the one given with ``--root`` (refused when
    missing), or in ``--quick`` mode one that ``build`` makes under DIR/``plan`` (refused when
    ``--root`` is given too)."""
    if args.quick:
        if args.root is not None:
            parser.error("--quick builds its own campaign root under DIR; drop --root")
        args.root = args.quick / plan
        build(args.root, args)
    elif args.root is None:
        parser.error("--root: give the campaign's root (campaign.py run … --root DIR)")


def add_mode_options(parser: argparse.ArgumentParser, play: str, collate: str) -> None:
    """``--play-only`` and ``--collate-only``, at most one of them (a campaign plays each cell in
    a step of its own and collates once at the end); ``play`` and ``collate`` are their help."""
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--play-only", action="store_true", help=play)
    mode.add_argument("--collate-only", action="store_true", help=collate)


def table1_rounds(
    model: str,
    objects: str,
    scene: str,
    baselines: str | Path,
    rounds: int,
    agree: dict[str, Any],
    first_seed: int = 0,
) -> tuple[list[dict[str, Any]] | None, Path]:
    """Rounds ``first_seed`` … ``first_seed + rounds − 1`` of the Table 1 cell of ``model`` (a
    shipped model, which replays its training run's cell round for round, or a training run's
    checkpoint; experiments/tests/test_shipped_replay.py) in ``baselines``: the cell of
    its hand, representation and training seed (`symgrasp.benchmark.cells`, from
    ``first_seed``), e.g. Table 1's rounds unpacked from ``results/declutter_rounds.tar.gz``, and
    the cell's folder (`cell_rounds`)."""
    from symgrasp.benchmark.cells import Cell
    from symgrasp.detect.pretrained import resolve_model
    from symgrasp.model.checkpoint import load_checkpoint, trained_gripper

    state = load_checkpoint(resolve_model(model))
    cell = Cell(trained_gripper(state).name, state["representation"], state["config"]["seed"],
                objects, scene, first_seed=first_seed)  # fmt: skip
    return cell_rounds(cell.folder(baselines), rounds, agree, first_seed)


def cell_rounds(
    cell: Path, rounds: int, agree: dict[str, Any], first_seed: int = 0
) -> tuple[list[dict[str, Any]] | None, Path]:
    """Rounds ``first_seed`` … ``first_seed + rounds − 1`` of the benchmark folder ``cell``, and
    the folder. The rounds are None unless it recorded the values of ``agree`` (configuration
    fields) and holds them all; whatever model file played them, which may live on another
    machine."""
    from symgrasp.benchmark.runner import read_rounds, recorded_config

    recorded = recorded_config(cell)
    if recorded is None or any(recorded[k] != v for k, v in agree.items()):
        return None, cell
    done = read_rounds(cell / "rounds.jsonl")
    seeds = range(first_seed, first_seed + rounds)
    return ([done[s] for s in seeds] if all(s in done for s in seeds) else None), cell


ARCHIVED = ("config.json", "model.sha256", "rounds.jsonl")
"""What a rounds archive keeps of a benchmark folder: enough to collate it again."""


def write_rounds_archive(
    path: Path, files: dict[str, Path], extra: dict[str, bytes] | None = None
) -> None:
    """A gzipped tar of the ``ARCHIVED`` files of benchmark folders, byte for byte the same for
    the same contents: ``files`` maps each folder's name in the archive to the folder, and
    ``extra`` adds files by name and contents."""
    import gzip
    import io
    import tarfile

    from symgrasp.atomic import write_atomic

    entries = dict(extra or {})
    for name, folder in files.items():
        for archived in ARCHIVED:
            if (folder / archived).exists():
                entries[f"{name}/{archived}"] = (folder / archived).read_bytes()

    def write(file: Any) -> None:
        with gzip.GzipFile(filename="", fileobj=file, mode="wb", mtime=0) as packed:
            with tarfile.open(fileobj=packed, mode="w", format=tarfile.PAX_FORMAT) as tar:
                for name, data in sorted(entries.items(), key=lambda e: PurePosixPath(e[0]).parts):
                    info = tarfile.TarInfo(name)
                    info.size, info.mode = len(data), 0o644
                    tar.addfile(info, io.BytesIO(data))

    write_atomic(path, write)


def update_page(page: Path, begin: str, end: str, text: str) -> None:
    """Replace what stands between ``page``'s markers ``begin`` and ``end`` by ``text`` (a
    script's ``--docs``; SystemExit naming the page when it lacks them)."""
    content = page.read_text()
    if begin not in content or end not in content:
        raise SystemExit(f"error: --docs {page} has no {begin} … {end} markers")
    head, rest = content.split(begin, 1)
    page.write_text(f"{head}{begin}\n{text}{end}{rest.split(end, 1)[1]}")


def verdict(
    low: float, high: float, lowest: float = -float("inf"), highest: float = float("inf")
) -> str:
    """Whether an interval [low, high] meets a target range [lowest, highest]: ``met`` when it
    lies inside, ``missed`` when it lies outside, ``undecided`` when it straddles a bound."""
    if lowest <= low and high <= highest:
        return "met"
    if high < lowest or low > highest:
        return "missed"
    return "undecided"


def sensing_gap(noisy: list[list[dict]], clean: list[list[dict]]) -> dict[str, Any]:
    """``noisy`` − ``clean`` of the same training runs (one per training seed, in the same order
    in both) played in two conditions, on the rounds every one of them finished in both:
    ``change``, the change of the means over seeds with one draw of training seeds shared by
    both conditions (`symgrasp.benchmark.seeds.seed_contrast`), so that a run's own luck
    cancels as the rounds' does; ``per_run``, each run's own paired change (`paired_change`);
    ``rounds``; and ``target``, issue 39's (`GAP_TARGET`): ``met`` when the SR and CR intervals
    both lie above −3 points, ``missed`` when either lies below, else ``undecided``."""
    from symgrasp.benchmark.compare import paired_change
    from symgrasp.benchmark.seeds import common_rounds, seed_contrast

    if len(noisy) != len(clean) or not noisy:
        raise ValueError(f"noisy, clean: expected the same runs, got {len(noisy)} and {len(clean)}")
    shared = common_rounds(*noisy, *clean)
    change = seed_contrast([shared[: len(noisy)], shared[len(noisy) :]], [1.0, -1.0],
                           trained=[0, 0])  # fmt: skip
    per_run = [paired_change(*common_rounds(a, b)) for a, b in zip(noisy, clean, strict=True)]
    targets = [verdict(*change[name][1:], lowest=-GAP_TARGET)
               for name in ("success_ratio", "clear_ratio")]  # fmt: skip
    target = "missed" if "missed" in targets else "met" if targets == ["met"] * 2 else "undecided"
    return {"rounds": len(shared[0]), "change": change, "per_run": per_run, "target": target}


def percent_mean(ratios: list[float]) -> str:
    """A mean over training seeds with its interval, ``[mean, low, high]``, in percent:
    ``64.1 [60.3, 67.8]``."""
    mean, low, high = (100 * v for v in ratios)
    return f"{mean:.1f} [{low:.1f}, {high:.1f}]"


# -- replaying rounds instrumented --------------------------------------------------------


def records_by_seed(path: Path) -> dict[int, dict[str, Any]]:
    """The JSON records of the lines file ``path`` by their ``"seed"`` (empty when there is no
    file): the rounds a resumable replay has kept."""
    import json

    if not path.exists():
        return {}
    records = (json.loads(line) for line in path.read_text().splitlines() if line.strip())
    return {record["seed"]: record for record in records}


def pad_extent(gripper: GripperSpec, axis: int = 0) -> tuple[float, float]:
    """The open pads' extent along TCP axis ``axis`` (0: ``e_x``, 1: ``e_y``) [m], from the
    hand's own boxes."""
    from symgrasp.sim.world import World

    world = World([], gripper=gripper)
    centre, rotation, half = world.hand_boxes()
    i = world.hand_box_names().index("hand_pad_left")
    reach = float(np.abs(rotation[i][axis]) @ half[i])
    return float(centre[i][axis] - reach), float(centre[i][axis] + reach)


class Watched:
    """A planner that keeps the world's state (objects, simulation state, walls) when it is
    asked for grasps, the state the executed grasp starts from, and the poses of the
    ``oracle``'s labels of that state (when given one)."""

    def __init__(self, planner: Any, oracle: Any = None) -> None:
        self.planner, self.gripper, self.oracle = planner, planner.gripper, oracle
        self.state: tuple[list, np.ndarray, bool] | None = None
        self.labels: np.ndarray | None = None

    def plan(self, observation: Any) -> list:
        world = observation.world
        self.state = (list(world.objects), world.snapshot().state.copy(), world.walls)
        if self.oracle is not None:
            grasps = self.oracle.plan(observation)
            self.labels = np.array([g.pose for g in grasps]).reshape(-1, 4, 4)
        return self.planner.plan(observation)

    def world(self) -> World:
        """A copy of the world in the kept state."""
        from symgrasp.sim.world import Snapshot, World

        objects, state, walls = self.state
        world = World(objects, gripper=self.gripper, walls=walls)
        world.restore(Snapshot(world.model, state))
        return world
