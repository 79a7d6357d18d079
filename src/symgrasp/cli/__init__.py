"""The ``symgrasp`` command: one sub-command per job, each a thin wrapper over the package.

One module per command group adds its sub-commands (``add``) and runs them (`demo`,
`objects`, `sim`, `data`, `figures`, `model`, `detect`, `serve`, `bench`). A job's options are built
from its configuration (`symgrasp.config`) by `fields`: every field is an option and its
documentation is the option's help, so a new field is on the command line without an edit
here. The options several commands share (``--objects``, ``--gripper``, ``--rep``, the
confidence pair) are defined once in `options`, with their choices from `symgrasp.names`;
``--backend``/``--workers``/``--ray-address`` in `symgrasp.parallel.options`. Building the
parser imports no heavy package (``symgrasp --help`` answers without torch or MuJoCo); each
command's run function imports what it needs.
"""

from __future__ import annotations

import argparse
import signal
import sys
from collections.abc import Sequence
from concurrent.futures.process import BrokenProcessPool
from typing import NoReturn

from symgrasp.cli import bench, data, demo, detect, figures, model, objects, serve, sim
from symgrasp.objects.folder import EX_NOINPUT, MissingData
from symgrasp.parallel import TasksFailed

COMMANDS = (demo, objects, sim, data, figures, model, detect, serve, bench)
"""The command groups, in the order ``symgrasp --help`` lists their sub-commands."""


class _Parser(argparse.ArgumentParser):
    """Argument errors in one line: the command, the option, what was expected."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="symgrasp",
        description="Learning 6-DoF grasp detection for parallel grippers with a "
        "planar-symmetric 2D-Bingham SO(3) representation.",
    )
    subparsers = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", help="the job to run"
    )
    for group in COMMANDS:
        group.add(subparsers)
    return parser


class Terminated(BaseException):
    """SIGTERM, raised where this process is, so it unwinds as from Ctrl-C: workers stopped,
    files closed, the output folder released."""


def _terminate(signum: int, frame: object) -> NoReturn:
    raise Terminated


def _continue(args: argparse.Namespace) -> str:
    """How to continue the stopped command, if it can be (it has ``--resume``)."""
    return "; run it again with --resume to continue" if hasattr(args, "resume") else ""


def _stop(what: str, args: argparse.Namespace, status: int) -> NoReturn:
    """Exit with ``status`` after one line: ``what`` stopped the command, how to continue."""
    print(f"{what}{_continue(args)}", file=sys.stderr)
    raise SystemExit(status)


def main(argv: Sequence[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        args.run(args)
    except KeyboardInterrupt:  # Ctrl-C: 128 + SIGINT, as a shell reports it
        _stop("interrupted", args, 128 + signal.SIGINT)
    except Terminated:
        _stop("terminated", args, 128 + signal.SIGTERM)
    except BrokenProcessPool as error:  # the pool says only "abruptly": say what that means
        raise SystemExit(
            "error: a worker process died (killed, or out of memory?); what finished is "
            f"kept{_continue(args)}"
        ) from error
    except MissingData as error:  # downloaded data not there: what, where, how to get it
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(EX_NOINPUT) from error
    except ValueError as error:  # bad input: the message names the argument, no traceback needed
        raise SystemExit(f"error: {error}") from error
    except TasksFailed as error:  # the message says which tasks failed and where the tracebacks are
        raise SystemExit(f"error: {error}") from error
    except ModuleNotFoundError as error:  # an optional extra not installed: its message says which
        raise SystemExit(f"error: {error}") from error
    except OSError as error:  # a path that cannot be read or written: name it
        where = f"{error.filename}: " if error.filename else ""
        raise SystemExit(f"error: {where}{error.strerror or error}") from error
    finally:
        signal.signal(signal.SIGTERM, previous)
