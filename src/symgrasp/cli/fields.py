"""A configuration's fields as options (`add_config_options`) and back (`config_from_args`):
every field of a job's dataclass (`symgrasp.config`) is an option whose help is the field's
documentation, so a new field is on the command line without an edit to the command. A field
named in `SHARED` takes that option's flag and choices."""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

from symgrasp.arguments import sentence
from symgrasp.cli.options import SHARED
from symgrasp.fields import field_docs

_SCALARS: dict[str, Callable[[str], Any]] = {"int": int, "float": float, "str": str}


def _value_options(annotation: str) -> dict[str, Any]:
    """argparse keywords for a field annotated ``annotation`` (as written in the source)."""
    base = annotation.removesuffix(" | None")
    if base == "bool":
        return {"action": argparse.BooleanOptionalAction}
    if base in _SCALARS:
        return {"type": _SCALARS[base]}
    if base.startswith("tuple[") and base.endswith("]"):
        items = [item.strip() for item in base[len("tuple[") : -1].split(",")]
        nargs: int | str = "+" if items[-1] == "..." else len(items)
        return {"type": _SCALARS[items[0]], "nargs": nargs}
    raise TypeError(f"no command-line form for a field of type {annotation}")


def _shown(default: Any) -> str:
    if isinstance(default, tuple):
        return " ".join(_shown(v) for v in default)
    return f"{default:g}" if isinstance(default, float) else str(default)


def add_config_options(
    parser: argparse.ArgumentParser,
    cls: type,
    skip: Sequence[str] = (),
    prefixes: dict[str, str] | None = None,
    path: str = "",
) -> None:
    """One option per field of the dataclass ``cls`` (nested dataclasses: one per field of
    theirs, flags prefixed by ``prefixes[field]``); dests are the fields' dotted paths."""
    prefixes = prefixes or {}
    docs = field_docs(cls)
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        dest = path + f.name
        if f.default_factory is not dataclasses.MISSING:
            nested = f.default_factory()
            prefix = prefixes.get(f.name, "")
            add_config_options(parser, type(nested), (), {}, f"{dest}.{prefix}")
            continue
        flag, options = SHARED.get(dest, SHARED.get(f.name, (None, {})))
        name = dest.split(".")[-1]
        flag = flag or "--" + name.replace("_", "-")
        options = {**_value_options(str(f.type)), **options}
        if "choices" not in options and "action" not in options:
            options.setdefault("metavar", name.upper())
        help = sentence(docs[f.name])
        if f.default is dataclasses.MISSING:
            parser.add_argument(flag, dest=dest, required=True, help=help, **options)
            continue
        if isinstance(f.default, bool):
            help += f" (default: {'on' if f.default else 'off'})"
        elif f.default is not None:
            help += f" (default: {_shown(f.default)})"
        parser.add_argument(flag, dest=dest, default=f.default, help=help, **options)


def config_from_args(
    cls: type, args: argparse.Namespace, path: str = "", prefixes: dict[str, str] | None = None
) -> Any:
    """The ``cls`` whose fields `add_config_options` put on the command line, from ``args``;
    fields it skipped keep their defaults."""
    prefixes = prefixes or {}
    values = {}
    for f in dataclasses.fields(cls):
        dest = path + f.name
        if f.default_factory is not dataclasses.MISSING:
            nested = type(f.default_factory())
            values[f.name] = config_from_args(
                nested, args, f"{dest}.{prefixes.get(f.name, '')}", {}
            )
        elif hasattr(args, dest):
            value = getattr(args, dest)
            values[f.name] = tuple(value) if isinstance(value, list) else value
    return cls(**values)
