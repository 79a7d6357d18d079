"""The command-line options of a job's executor (`ParallelConfig`): ``--backend``,
``--workers`` and ``--ray-address``, for the ``symgrasp`` commands that map tasks and for the
scripts in ``experiments/``. Argparse only: adding them imports neither torch nor Ray."""

from __future__ import annotations

import argparse

from symgrasp.arguments import integer, sentence
from symgrasp.config import MAX_WORKERS, ParallelConfig
from symgrasp.fields import field_docs
from symgrasp.names import BACKENDS


def add_parallel_options(parser: argparse.ArgumentParser, tasks: str) -> None:
    """``--backend``, ``--workers`` and ``--ray-address`` (`ParallelConfig`) for a command whose
    pure tasks are ``tasks`` (e.g. "rounds")."""
    docs = field_docs(ParallelConfig)
    parser.add_argument(
        "--backend", choices=BACKENDS, default="process",
        help=f"where the {tasks} run: {sentence(docs['backend'])} (default: process)",
    )  # fmt: skip
    parser.add_argument(
        "--workers", type=integer(1, MAX_WORKERS), default=None, help=sentence(docs["workers"])
    )
    parser.add_argument(
        "--ray-address", default=None, metavar="HOST:PORT", help=sentence(docs["ray_address"])
    )


def parallel_from_args(args: argparse.Namespace) -> ParallelConfig:
    """The `ParallelConfig` of `add_parallel_options`' options."""
    return ParallelConfig(args.backend, args.workers, args.ray_address)
