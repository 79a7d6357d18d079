"""``symgrasp serve``: a detector held in its own process, answering grasp requests over HTTP +
JSON (`symgrasp.serve`; docs/serve.md)."""

from __future__ import annotations

import argparse
import signal
import sys
import threading

from symgrasp.arguments import integer
from symgrasp.cli.detect import add_detector_options, load_detector
from symgrasp.serve import DEFAULT_PORT, DETECT_PATH, HEALTH_PATH, MAX_CONNECTIONS


def add(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "serve",
        help="answer grasp requests over HTTP + JSON (a robot's way in)",
        description=f"Load a grasp detector once and answer requests: POST {DETECT_PATH} with "
        "depth image(s), intrinsic and camera pose(s), or a point cloud, gets the ranked "
        f"grasps; GET {HEALTH_PATH} says the model and its workspace. The protocol is in "
        "docs/serve.md; symgrasp.serve.client is a Python client. A bad request is answered "
        "400 with the field it names, and the server goes on. One line per request on stderr. "
        "Ctrl-C or SIGTERM stops it after the requests in flight. No authentication: listen "
        "on a trusted network only.",
    )
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default: 127.0.0.1, this machine only; 0.0.0.0 for every "
        "interface)",
    )
    parser.add_argument(
        "--port",
        type=integer(0, 65535),
        default=DEFAULT_PORT,
        help=f"port to listen on (default: {DEFAULT_PORT}; 0 picks a free one, printed)",
    )
    parser.add_argument(
        "--max-connections",
        type=integer(1, 10_000),
        default=MAX_CONNECTIONS,
        metavar="N",
        help=f"connections served at once; one more is answered 503 at once (default: "
        f"{MAX_CONNECTIONS}; each may hold about 1 GiB while its request is decoded)",
    )
    parser.add_argument(
        "--quiet",
        action="store_true",
        help="no line per request (the traceback of an internal error is still printed)",
    )
    add_detector_options(parser)
    parser.set_defaults(run=_run_serve)


def _run_serve(args: argparse.Namespace) -> None:
    import torch

    from symgrasp.serve import PROTOCOL
    from symgrasp.serve.server import GraspServer

    detector = load_detector(args)
    detector.predict(torch.ones((40, 40, 40)))  # warm-up: the first request is not slower
    try:
        server = GraspServer((args.host, args.port), detector, str(args.model),
                             log=None if args.quiet else sys.stderr,
                             max_connections=args.max_connections)  # fmt: skip
    except OSError as error:  # the port taken, the address not this machine's
        raise ValueError(f"cannot listen on {args.host}:{args.port}: {error.strerror}") from None
    stopped: list[str] = []

    def stop(signum: int, frame: object) -> None:
        stopped.append(signal.Signals(signum).name)
        threading.Thread(target=server.shutdown).start()  # not on the serving thread

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        print(f"listening on {server.url} (model {args.model}, protocol {PROTOCOL}, "
              f"{detector.device}); stop with Ctrl-C", flush=True)  # fmt: skip
        server.serve_forever()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        server.server_close()  # waits for the requests in flight
    what = stopped[0] if stopped else "stopped"
    print(f"{what}: stopped after {server.answered} requests", flush=True)
