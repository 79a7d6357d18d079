"""What each field of a dataclass means: the string below it in the class body.

The configurations (`symgrasp.config`) and the gripper spec (`symgrasp.sim.grippers`)
document every field this way, once; the command line shows it as the field's ``--help`` and
a spec file's missing key is explained by it. A small root module that imports nothing of
symgrasp, so every layer may read it.
"""

from __future__ import annotations

import ast
import functools
import inspect
import itertools
import textwrap


@functools.cache
def field_docs(cls: type) -> dict[str, str]:
    """The documentation of each field of the dataclass ``cls``: the string below it in the
    class body, on one line."""
    body = ast.parse(textwrap.dedent(inspect.getsource(cls))).body[0].body
    return {
        node.target.id: " ".join(doc.value.value.split())
        for node, doc in itertools.pairwise(body)
        if isinstance(node, ast.AnnAssign)
        and isinstance(node.target, ast.Name)
        and isinstance(doc, ast.Expr)
        and isinstance(doc.value, ast.Constant)
        and isinstance(doc.value.value, str)
    }
