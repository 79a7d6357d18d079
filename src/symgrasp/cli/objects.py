"""``symgrasp objects fetch`` and ``objects inspect``: object sets on disk
(`symgrasp.objects`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from symgrasp.arguments import integer
from symgrasp.cli.options import (
    add_mesh_options,
    output_folder_path,
    output_path,
    parse_object_set,
)
from symgrasp.names import PROCEDURAL_OBJECT_SETS
from symgrasp.parallel.options import add_parallel_options, parallel_from_args


def add(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "objects",
        help="object sets: download VGN's, look inside one",
        description="Object sets on disk: VGN's household meshes in the data folder "
        "($SYMGRASP_DATA, default ~/.cache/symgrasp), a folder of URDF files or a folder of "
        "bare OBJ/STL/PLY meshes (cut into convex parts once, cached in <data>/cache).",
    )
    actions = parser.add_subparsers(
        dest="action", required=True, metavar="ACTION", help="what to do (fetch, inspect)"
    )
    fetch = actions.add_parser(
        "fetch",
        help="download VGN's household object sets into the data folder",
        description="Download VGN's object sets (pile/packed, train/test; Breyer et al. 2020, "
        "as redistributed by the MIT-licensed HaojHuang/Edge-Grasp-Network at a pinned "
        "commit) into <data>/objects/vgn. Every file is checked against the manifest shipped "
        "with symgrasp; a killed download continues where it stopped; nothing is put in "
        "place until all of it is there and checked. Does nothing when the sets are there.",
    )
    fetch.add_argument("what", choices=("vgn",), help="what to download (vgn: VGN's four sets)")
    fetch.add_argument(
        "--data", type=output_folder_path, default=None,
        help="data folder to download into (default: $SYMGRASP_DATA, else ~/.cache/symgrasp)",
    )  # fmt: skip
    fetch.add_argument(
        "--url", default=None,
        help="archive to download instead of the pinned GitHub one: a mirror, or a file:// "
        "URL of a copy; its files must still match the shipped manifest",
    )  # fmt: skip
    fetch.set_defaults(run=_run_objects_fetch)
    inspect = actions.add_parser(
        "inspect",
        help="print what a set holds and draw it",
        description="Print, per object: its units (a bare mesh's as read, guessed or given "
        "by --mesh-unit; a URDF's as its size suggests), its size, mass, convex parts (MuJoCo "
        "collides each as one convex geom) and whether its mesh (a URDF's visual mesh) is "
        "watertight, and every file refused and why; then draw the first objects' collision "
        "parts into one picture.",
    )
    inspect.add_argument("objects", type=parse_object_set, metavar="SET|FOLDER",
                         help="a mesh set's name (vgn-pile-test, …), a folder of URDF files or "
                         "bare OBJ/STL/PLY meshes, or several joined by commas")  # fmt: skip
    inspect.add_argument(
        "--out", type=output_path, help="picture to write (default: out/objects/<set>.png)"
    )
    inspect.add_argument(
        "--limit", type=integer(1, 500), default=48, help="objects drawn (default: 48)"
    )
    add_mesh_options(inspect)
    add_parallel_options(inspect, "per-object reads and convex decompositions")
    inspect.set_defaults(run=_run_objects_inspect)


def _run_objects_fetch(args: argparse.Namespace) -> None:
    from symgrasp.objects.fetch import VGN_ARCHIVE_URL, fetch_vgn

    print(f"VGN's object sets are in {fetch_vgn(args.data, args.url or VGN_ARCHIVE_URL)}")


def _run_objects_inspect(args: argparse.Namespace) -> None:
    if args.objects in PROCEDURAL_OBJECT_SETS:
        raise SystemExit(f"error: {args.objects} is built in code, not read from meshes")

    from symgrasp.objects.inspect import HEADER, contact_sheet, inspect_objects
    from symgrasp.objects.sets import resolve

    source = resolve(args.objects, args.mesh_unit, args.decomposition)
    reports, refused = inspect_objects(source, parallel_from_args(args))
    where = ", ".join(map(str, source.folders))
    print(f"{len(reports)} objects in {where}, {len(refused)} refused")
    print(HEADER)
    for report in reports:
        print(report.row())
    for reason in refused:
        print(f"refused: {reason}")
    out = args.out or f"out/objects/{Path(args.objects).name}.png"
    print(f"picture: {contact_sheet([r.obj for r in reports[: args.limit]], out)}")
