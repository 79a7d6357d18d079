"""The cells of a comparison over training seeds: which training run plays which test rounds,
and the one folder its benchmark lives in, so that every script that needs a cell (the seed
spread, the Table 1 collation) reads the same rounds instead of playing them again.

A cell is a gripper, a representation (with or without its confidence threshold), a training
seed, an object set laid out as a pile or packed, and the seed of its first round. Its run is
``RUNS/PREFIX-REP-sSEED`` (``symgrasp train --out``; the prefix names the campaign and gripper,
e.g. ``final`` for the Robotiq 2F-85 and ``final-franka``), its model that run's ``best.pt`` as
chosen by the declutter validation (`symgrasp.benchmark.selection.selected_checkpoint`), and
its rounds the benchmark of `symgrasp.benchmark.runner` from round seed ``first_seed`` with
failure diagnosis, in ``OUT/GRIPPER/REP[-noconf]/sSEED/OBJECTS[-packed]``, followed by
``-first-seed-F`` for a first seed F other than 0: Table 1's rounds (round seeds 0–99) and
those of another first seed (100–199: test rounds that informed no choice, issue 36) never
share a folder.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from symgrasp.config import (
    SCENES,
    SURFACE_CLEARANCE,
    TABLE_CLEARANCE,
    BenchmarkConfig,
    PlannerOptions,
)

NO_THRESHOLD = PlannerOptions(confidence_threshold=0.0)
"""The detector options of the paper's "2D Bingham" row: its confidence threshold off."""


def objects_folder(objects: str, scene: str) -> str:
    """The last level of a cell's folder: ``OBJECTS`` for a pile, ``OBJECTS-SCENE`` else."""
    return objects + ("" if scene == "pile" else f"-{scene}")


@dataclass(frozen=True)
class Cell:
    """One training run of one representation on one object set (module docstring)."""

    gripper: str
    rep: str
    seed: int
    """The training seed."""
    objects: str
    scene: str = "pile"
    threshold: bool = True
    """Whether the detector keeps its confidence threshold (off: the paper's ablation)."""
    first_seed: int = 0
    """The round seed of the cell's first round: round r plays seed ``first_seed + r``."""

    def __post_init__(self) -> None:
        if self.scene not in SCENES:
            raise ValueError(f"scene must be one of {SCENES}, got {self.scene!r}")
        if self.seed < 0:
            raise ValueError(f"seed must be a training seed ≥ 0, got {self.seed}")
        if self.first_seed < 0:
            raise ValueError(f"first_seed must be a round seed ≥ 0, got {self.first_seed}")

    def run(self, runs: str | Path, prefix: str) -> Path:
        """The training run's folder: ``runs/PREFIX-REP-sSEED``."""
        return Path(runs) / f"{prefix}-{self.rep}-s{self.seed}"

    def folder(self, out: str | Path) -> Path:
        """Where the cell's benchmark lives under ``out``."""
        rep = self.rep + ("" if self.threshold else "-noconf")
        objects = objects_folder(self.objects, self.scene)
        if self.first_seed:
            objects += f"-first-seed-{self.first_seed}"
        return Path(out) / self.gripper / rep / f"s{self.seed}" / objects

    def config(
        self,
        model: str | Path,
        rounds: int = 100,
        num_objects: int = 5,
        table_clearance: float = TABLE_CLEARANCE,
        surface_clearance: float = SURFACE_CLEARANCE,
    ) -> BenchmarkConfig:
        """The benchmark the cell plays with the checkpoint ``model``: ``rounds`` rounds of
        ``num_objects`` objects from round seed ``first_seed``, failure diagnosis on, the
        approach check's ``table_clearance`` and ``surface_clearance``."""
        return BenchmarkConfig(
            model=str(Path(model).resolve()), objects=self.objects, scene=self.scene,
            num_objects=num_objects, rounds=rounds, seed=self.first_seed,
            options=PlannerOptions() if self.threshold else NO_THRESHOLD,
            table_clearance=table_clearance, surface_clearance=surface_clearance,
        )  # fmt: skip
