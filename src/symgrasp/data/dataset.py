"""The torch ``Dataset`` of labelled scenes, its augmentation and its collate function.

Item ``i`` is a dict of tensors (the contract with the model):

- ``tsdf`` float32 [1, 40, 40, 40]; ``valid``, ``score`` float32 [40, 40, 40];
- ``voxel_index`` int64 [M, 3] of the M valid voxels; ``rotations`` float32
  [M, K_max, 3, 3] (R = [e_x e_y e_z], world frame), ``rotation_mask`` bool [M, K_max],
  ``width`` float32 [M] [m].

Augmentation keeps labels consistent: a rotation by a multiple of 90° about the vertical
axis through the workspace centre maps voxel (i, j, k) to (39 − j, i, k) per quarter turn
and every rotation target R to R_z(90°) · R; a vertical shift by whole voxels moves the
TSDF (the exposed layers repeat the edge layer) and the labels, dropping those that leave
the grid. Gravity stays along −z, so scores are unchanged.
"""

from __future__ import annotations

import hashlib
import json
import warnings
import zipfile
from collections import Counter
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import Dataset

from symgrasp.atomic import read_json
from symgrasp.sim.grippers import GripperSpec, get_gripper
from symgrasp.workspace import RESOLUTION

SPLITS = ("train", "val", "all")
MANIFEST_KEYS = ("scene_ids", "gripper", "object_set", "k_max")
"""The keys of ``manifest.json`` a dataset is read by."""
VAL_EVERY = 10
"""Scene ``id`` is in the validation split when ``id % VAL_EVERY == VAL_EVERY − 1``."""

MAX_SHIFT = 2
"""Largest vertical shift of the augmentation [voxels] (15 mm)."""

REQUIRED = ("tsdf", "voxel_index", "voxel_score", "voxel_width", "voxel_rotations")


def in_split(scene_id: int, split: str) -> bool:
    """Whether scene ``scene_id`` belongs to ``split`` (deterministic, by scene id)."""
    val = scene_id % VAL_EVERY == VAL_EVERY - 1
    return split == "all" or (split == "val") == val


def scene_path(root: str | Path, scene_id: int) -> Path:
    """Where scene ``scene_id`` of a dataset lives."""
    return Path(root) / "scenes" / f"scene_{scene_id:06d}.npz"


ITEM_KEYS = (*REQUIRED, "voxel_rotation_mask")
"""The arrays of a scene file that a training item is made of."""


def dataset_hash(root: str | Path, scene_ids: Iterable[int]) -> str:
    """SHA-256 over the ordered scene ids and the bytes of their files (first 16 hex): the
    manifest's ``dataset_hash``. Hashing costs ≈ 40 µs per 32 kB scene file once it is in the
    page cache (0.3–0.4 s for 8 000 scenes), against ≈ 1.3 ms for the CRC test of its
    members that opening a dataset makes anyway."""
    h = hashlib.sha256()
    for i in sorted(scene_ids):
        h.update(str(i).encode())
        h.update(hashlib.sha256(scene_path(root, i).read_bytes()).digest())
    return h.hexdigest()[:16]


def read_manifest(path: str | Path) -> dict:
    """The dataset manifest ``path`` (`read_json`, with `MANIFEST_KEYS`) when its
    ``scene_ids`` are distinct integers ≥ 0 and its ``k_max`` an integer ≥ 1; ValueError
    naming the file and the field otherwise: a hand-edited list would read as an unfinished
    dataset (a string's characters) or one whose files changed (an id twice)."""
    manifest = read_json(path, "dataset manifest", dict, MANIFEST_KEYS)
    ids, k_max = manifest["scene_ids"], manifest["k_max"]
    if not (isinstance(ids, list) and all(_is_count(i, 0) for i in ids)):
        raise ValueError(
            f"{path} is not a valid dataset manifest: scene_ids must be a list of integers "
            f"≥ 0, got {json.dumps(ids)[:40]}"
        )
    repeated = sorted(i for i, n in Counter(ids).items() if n > 1)
    if repeated:
        raise ValueError(
            f"{path} is not a valid dataset manifest: scene_ids must name each scene once, got "
            f"{', '.join(map(str, repeated[:5]))}{', …' * (len(repeated) > 5)} more than once"
        )
    if not _is_count(k_max, 1):
        raise ValueError(
            f"{path} is not a valid dataset manifest: k_max must be an integer ≥ 1, got "
            f"{json.dumps(k_max)[:40]}"
        )
    return manifest


def _is_count(value: object, lo: int) -> bool:
    """Whether ``value`` is a JSON integer (not a bool) ≥ ``lo``."""
    return isinstance(value, int) and not isinstance(value, bool) and value >= lo


class ManifestMismatch(ValueError):
    """A dataset folder's files are not what its manifest promises (`check_scene_file`)."""


def _shape(z: zipfile.ZipFile, key: str) -> tuple[int, ...] | None:
    """The shape of array ``key`` of an open scene file, from its header alone (None: absent)."""
    if f"{key}.npy" not in z.namelist():
        return None
    with z.open(f"{key}.npy") as member:
        major, _ = np.lib.format.read_magic(member)
        header = (
            np.lib.format.read_array_header_1_0
            if major == 1
            else np.lib.format.read_array_header_2_0
        )
        return tuple(header(member)[0])


def check_scene_file(z: zipfile.ZipFile, path: Path, scene_id: int, k_max: int) -> None:
    """ValueError naming ``path`` unless the open scene file ``z`` is scene ``scene_id`` (its
    recorded ``scene_id``: a file swapped or copied under another id is not) and its arrays
    have the contract's shapes: ``tsdf`` (40, 40, 40), and for M valid voxels ``voxel_index``
    (M, 3), ``voxel_score`` and ``voxel_width`` (M,), ``voxel_rotations`` (M, k_max, 3, 3),
    ``voxel_rotation_mask`` (M, k_max). Reads the small ``scene_id`` member and the arrays'
    headers, not the arrays: cheap enough for every scene at every open."""
    if "scene_id.npy" in z.namelist():
        with z.open("scene_id.npy") as member:
            recorded = int(np.lib.format.read_array(member))
        if recorded != scene_id:
            raise ValueError(
                f"scene file {path} holds scene {recorded}, not {scene_id}: a file swapped or "
                "copied under another name"
            )
    m = _shape(z, "voxel_index")
    m = m[0] if m else 0
    expected = {
        "tsdf": (RESOLUTION,) * 3,
        "voxel_index": (m, 3),
        "voxel_score": (m,),
        "voxel_width": (m,),
        "voxel_rotations": (m, k_max, 3, 3),
        "voxel_rotation_mask": (m, k_max),
    }
    for key, shape in expected.items():
        found = _shape(z, key)
        if found is not None and found != shape:
            raise ValueError(
                f"scene file {path}: {key} has shape {found}, the dataset contract says {shape}"
            )


def load_scene(path: str | Path, keys: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """The arrays ``keys`` (None: all) of a scene file; raises ValueError naming the path if it
    is unreadable or lacks one. Each array is its own compressed member, so leaving out the
    depth image and the grasp lists saves most of the decompression."""
    try:
        with np.load(path) as z:
            wanted = z.files if keys is None else [k for k in keys if k in z.files]
            record = {k: z[k] for k in wanted}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
        raise ValueError(f"scene file {path} is missing or corrupted: {err}") from err
    missing = [k for k in (REQUIRED if keys is None else keys) if k not in record]
    if missing:
        raise ValueError(f"scene file {path} is corrupted: no {missing}")
    return record


def rotate_quarter_turns(item: dict[str, torch.Tensor], k: int) -> dict[str, torch.Tensor]:
    """``item`` turned by ``k`` · 90° about the vertical axis through the workspace centre."""
    k = k % 4
    if k == 0:
        return item
    out = dict(item)
    # torch.rot90 over dims (0, 1) maps new[a, b] = old[b, n−1−a] per turn, i.e. old (i, j)
    # goes to (n−1−j, i): a counter-clockwise quarter turn of the (x, y) plane.
    out["tsdf"] = torch.rot90(item["tsdf"], k, dims=(1, 2))
    out["valid"] = torch.rot90(item["valid"], k, dims=(0, 1))
    out["score"] = torch.rot90(item["score"], k, dims=(0, 1))
    idx = item["voxel_index"].clone()
    c, s = round(np.cos(k * np.pi / 2)), round(np.sin(k * np.pi / 2))
    n = RESOLUTION - 1
    # about the grid centre n/2: (i, j) → (c·(i − n/2) − s·(j − n/2) + n/2, s·(…) + c·(…) + n/2)
    i, j = idx[:, 0] * 2 - n, idx[:, 1] * 2 - n
    idx[:, 0] = (c * i - s * j + n) // 2
    idx[:, 1] = (s * i + c * j + n) // 2
    out["voxel_index"] = idx
    Rz = torch.tensor([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=item["rotations"].dtype)
    real = item["rotation_mask"][..., None, None]
    out["rotations"] = torch.where(real, Rz @ item["rotations"], item["rotations"])  # pads stay I
    return out


def shift_vertical(item: dict[str, torch.Tensor], dz: int) -> dict[str, torch.Tensor]:
    """``item`` moved by ``dz`` voxels along +z; labels leaving the grid are dropped."""
    if dz == 0:
        return item
    out = dict(item)
    n = RESOLUTION
    src = torch.clamp(torch.arange(n) - dz, 0, n - 1)  # repeats the edge layer
    out["tsdf"] = item["tsdf"][..., src]
    keep_layer = ((torch.arange(n) - dz) >= 0) & ((torch.arange(n) - dz) < n)
    for key in ("valid", "score"):
        out[key] = item[key][..., src] * keep_layer
    idx = item["voxel_index"].clone()
    idx[:, 2] += dz
    keep = (idx[:, 2] >= 0) & (idx[:, 2] < n)
    out["voxel_index"] = idx[keep]
    for key in ("rotations", "rotation_mask", "width"):
        out[key] = item[key][keep]
    return out


def make_item(
    tsdf: np.ndarray,
    voxel_index: np.ndarray,
    score: np.ndarray,
    rotations: np.ndarray,
    mask: np.ndarray,
    width: np.ndarray,
) -> dict[str, torch.Tensor]:
    """An item of the contract from a TSDF (40, 40, 40) and the sparse labels of its M valid
    voxels (see :class:`symgrasp.data.labels.VoxelLabels`)."""
    idx = torch.from_numpy(np.asarray(voxel_index, dtype=np.int64)).reshape(-1, 3)
    valid = torch.zeros((RESOLUTION,) * 3)
    dense_score = torch.zeros((RESOLUTION,) * 3)
    valid[idx[:, 0], idx[:, 1], idx[:, 2]] = 1.0
    dense_score[idx[:, 0], idx[:, 1], idx[:, 2]] = torch.from_numpy(
        np.asarray(score, dtype=np.float32)
    )
    return {
        "tsdf": torch.from_numpy(np.asarray(tsdf, dtype=np.float32))[None],
        "valid": valid,
        "score": dense_score,
        "voxel_index": idx,
        "rotations": torch.from_numpy(np.asarray(rotations, dtype=np.float32)),
        "rotation_mask": torch.from_numpy(np.asarray(mask, dtype=bool)),
        "width": torch.from_numpy(np.asarray(width, dtype=np.float32)),
    }


class GraspDataset(Dataset):
    """Labelled scenes of a dataset folder written by ``symgrasp data generate``.

    Args:
        root: dataset folder (with ``manifest.json`` and ``scenes/``).
        split: "train", "val" or "all" (every 10th scene id is validation).
        augment: random quarter turns about z and vertical shifts of ±``MAX_SHIFT`` voxels.
        seed: seed of the augmentation: item ``i`` in epoch ``e`` (:meth:`set_epoch`) is
            augmented the same way every time, in any worker.

    A scene file that is missing or unreadable is reported (a warning naming its path) and
    skipped. One that is not the scene its name says (swapped, or copied under another name)
    or whose arrays break the contract (a TSDF not 40³, …) is refused: `ManifestMismatch`
    naming the first such file (`check_scene_file`, which reads headers only). So are files
    whose bytes are not those the manifest's ``dataset_hash`` was made of. When they are, the
    members' CRC test is skipped: the hash has read every byte already, and it is the costly
    part of opening (the training split of the final Robotiq set, 7 200 of 8 000 scenes: 47.8 s
    with it, 16.4 s without, one after the other on the 2-core CPU beside two training jobs,
    load 3.0). A dataset whose hash does not match, or that has no
    hash, has every member's CRC tested, to name and skip the files that fail.
    """

    def __init__(
        self, root: str | Path, split: str = "train", augment: bool = False, seed: int = 0
    ) -> None:
        if split not in SPLITS:
            raise ValueError(f"split must be one of {SPLITS}, got {split!r}")
        self.root = Path(root)
        manifest = self.root / "manifest.json"
        if not manifest.exists():
            raise ValueError(f"root must be a dataset folder with manifest.json, got {root}")
        self.manifest: dict = read_manifest(manifest)
        on_disk = len(list((self.root / "scenes").glob("scene_*.npz")))
        if on_disk > len(self.manifest["scene_ids"]):
            raise ValueError(
                f"{root} is an unfinished dataset: {on_disk} scene files on disk, "
                f"{len(self.manifest['scene_ids'])} in its manifest; finish it with "
                "`symgrasp data generate ... --resume` (same options)"
            )
        self.gripper: GripperSpec = get_gripper(self.manifest["gripper"])  # old: a name
        self.object_set: str = self.manifest["object_set"]
        self.k_max: int = self.manifest["k_max"]
        self.augment, self.seed = augment, seed
        self.paths: list[Path] = []
        self.scene_ids: list[int] = []  # of the items, in the order of paths
        self.skipped: list[Path] = []
        recorded, actual = self._hashes()
        for scene_id in self.manifest["scene_ids"]:
            if not in_split(scene_id, split):
                continue
            path = scene_path(self.root, scene_id)
            try:
                with zipfile.ZipFile(path) as z:
                    bad = None if actual is not None and actual == recorded else z.testzip()
                    if bad is None:
                        check_scene_file(z, path, scene_id, self.k_max)
                if bad is not None:
                    raise zipfile.BadZipFile(f"bad CRC in {bad}")
            except (OSError, zipfile.BadZipFile) as err:
                warnings.warn(
                    f"skipping scene file {path}: missing or corrupted ({err})", stacklevel=2
                )
                self.skipped.append(path)
                continue
            except ValueError as err:
                raise ManifestMismatch(
                    f"{root} does not match its manifest: {err}; `symgrasp data inspect "
                    f"{root}` lists every mismatch"
                ) from None
            self.paths.append(path)
            self.scene_ids.append(scene_id)
        if actual is not None and actual != recorded and not self.skipped:
            raise ManifestMismatch(
                f"{self.root} does not match its manifest: dataset hash {recorded} recorded, "
                f"{actual} on disk (a scene file changed since it was generated; "
                f"`symgrasp data inspect {self.root}` lists what it can name)"
            )
        self.epoch = 0

    def _hashes(self) -> tuple[str | None, str | None]:
        """The manifest's ``dataset_hash`` and that of the scene files on disk; the latter None
        for a manifest without one (made by hand) or a dataset with a missing or unreadable
        file (reported and skipped as the files are read), where there is nothing to compare."""
        recorded = self.manifest.get("dataset_hash")
        ids = self.manifest["scene_ids"]
        if not recorded or not all(scene_path(self.root, i).is_file() for i in ids):
            return recorded, None
        try:
            return recorded, dataset_hash(self.root, ids)
        except OSError:  # an unreadable file: reported and skipped as the files are read
            return recorded, None

    def set_epoch(self, epoch: int) -> None:
        """Select the augmentation draws of ``epoch`` (call before each epoch)."""
        self.epoch = int(epoch)

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        r = load_scene(self.paths[i], ITEM_KEYS)
        item = make_item(
            r["tsdf"],
            r["voxel_index"],
            r["voxel_score"],
            r["voxel_rotations"],
            r["voxel_rotation_mask"],
            r["voxel_width"],
        )
        if self.augment:
            rng = np.random.default_rng([self.seed, self.epoch, i])
            item = rotate_quarter_turns(item, int(rng.integers(4)))
            item = shift_vertical(item, int(rng.integers(-MAX_SHIFT, MAX_SHIFT + 1)))
        return item


def collate_scenes(items: list[dict[str, torch.Tensor]]) -> dict[str, torch.Tensor]:
    """Batch items: ``tsdf``, ``valid``, ``score`` stacked; per-voxel tensors concatenated,
    with ``voxel_index`` int64 [ΣM, 4] = (batch b, i, j, k)."""
    batch = {key: torch.stack([it[key] for it in items]) for key in ("tsdf", "valid", "score")}
    batch["voxel_index"] = torch.cat(
        [
            torch.cat([torch.full((len(it["voxel_index"]), 1), b), it["voxel_index"]], dim=1)
            for b, it in enumerate(items)
        ]
    ).long()
    for key in ("rotations", "rotation_mask", "width"):
        batch[key] = torch.cat([it[key] for it in items])
    return batch
