"""The key tables of the docs, generated from the settings dataclasses (:mod:`scangeo.io.schema`).

``python -m scangeo.io.schema_docs docs/formats.md`` rewrites every block between
``<!-- schema: module.Class -->`` and ``<!-- /schema -->`` with the table of that class's keys (key,
type, default, unit, range or allowed values, meaning); ``--check`` only reports stale blocks (exit
status 1), which is what the test suite runs.
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib
import re
import sys
from pathlib import Path

from scangeo.atomic import write_text
from scangeo.io.schema import Key, keys, type_text

BLOCK = re.compile(r"(<!-- schema: (?P<name>[\w.]+) -->\n)(?P<body>.*?)(<!-- /schema -->)", re.S)


def _default_text(k: Key) -> str:
    if k.required:
        return "required"
    if k.setting.default_doc:
        return k.setting.default_doc
    d = k.default
    if d is None:
        return "none"
    if dataclasses.is_dataclass(d):
        return "(table)"
    if isinstance(d, bool):
        return "true" if d else "false"
    if isinstance(d, tuple):
        return "[" + ", ".join(f'"{v}"' if isinstance(v, str) else f"{v:g}" for v in d) + "]"
    if isinstance(d, str):
        return f'"{d}"'
    return f"{d:g}" if isinstance(d, float) else str(d)


def _values_text(k: Key) -> str:
    s = k.setting
    if s.choices:
        return ", ".join(f"`{c}`" for c in s.choices)
    return s.range_text()


def table(cls: type) -> str:
    """The markdown table of a settings dataclass's keys."""
    rows = ["| key | type | default | unit | range / values | meaning |", "|---|---|---|---|---|---|"]
    for k in keys(cls):
        cells = [f"`{k.name}`", type_text(k.hint, k.setting), _default_text(k), k.unit, _values_text(k),
                 k.setting.doc]
        rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(rows) + "\n"


def _class(name: str) -> type:
    module, _, attr = name.rpartition(".")
    return getattr(importlib.import_module(module), attr)


def render(text: str) -> str:
    """The text with every schema block regenerated."""
    return BLOCK.sub(lambda m: m.group(1) + table(_class(m.group("name"))) + m.group(4), text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scangeo.io.schema_docs", description=__doc__)
    parser.add_argument("files", nargs="+", type=Path, help="markdown files with schema blocks")
    parser.add_argument("--check", action="store_true", help="report stale blocks instead of rewriting")
    args = parser.parse_args(argv)
    stale = []
    for path in args.files:
        text = path.read_text(encoding="utf-8")
        new = render(text)
        if new != text:
            stale.append(path)
            if not args.check:
                write_text(path, new)
    for path in stale:
        print(f"{path}: schema tables {'are stale' if args.check else 'regenerated'}")
    return 1 if (stale and args.check) else 0


if __name__ == "__main__":
    sys.exit(main())
