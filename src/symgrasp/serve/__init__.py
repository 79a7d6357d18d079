"""A way in for a robot: ``symgrasp serve`` holds a detector in its own process and answers
requests over HTTP + JSON, a protocol any language speaks (docs/serve.md).

`protocol` is the wire format (arrays, fields, paths), `server` the HTTP server around
`symgrasp.detect.GraspDetector`, `client` a small Python client that needs only the standard
library and numpy. This package imports none of them, so that importing the client loads
neither torch nor MuJoCo; it holds only the protocol's names, which the command line offers
without importing numpy.
"""

PROTOCOL = 1
"""The protocol's version: the health answer says it; a change that breaks a client bumps it."""

HEALTH_PATH = "/v1/health"
"""GET: the protocol, the model, its gripper and workspace."""

DETECT_PATH = "/v1/detect"
"""POST: a detect request (docs/serve.md)."""

DEFAULT_PORT = 8642
"""The port ``symgrasp serve`` listens on unless told."""

MAX_CONNECTIONS = 16
"""Connections ``symgrasp serve`` serves at once unless told (``--max-connections``); one more is
answered 503 at once. Each may hold a request of up to 256 MiB, and about 2.8 times that while
it is decoded (docs/serve.md)."""
