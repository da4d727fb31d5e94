"""The ``scangeo`` command: one module per subcommand, each a thin shell over a library call.

A command module defines ``add_parser(subparsers, common)`` which adds its sub-parser (with
``parents=[common]`` for the shared options) and sets ``func`` to a handler ``run(args) -> int``.
To add a command, add its module name to ``COMMANDS``.

A command module imports the library it calls inside its handler, not at the top: ``scangeo --help``
and every command build all sub-parsers, and importing every command's library first would make
each start 2.8-3x slower (building the parser of all commands: 9.6-16 s with the imports inside
the handlers against 27-48 s with them all imported, on the shared 2-core machine at load 18-20;
both import scangeo's own modules only). Those are the only imports inside functions of scangeo's
own modules outside lidar/ (``lint-imports`` checks them with the rest: pyproject.toml).
"""
from __future__ import annotations

import argparse
import importlib
import logging
import sys
from pathlib import Path

from scangeo.atomic import OutputLock
from scangeo.errors import ProjectFileError, ScangeoError
from scangeo.io.toml_config import load_toml
from scangeo.progress import TextProgress, no_progress
from scangeo.version import __version__

#: Sub-command modules of scangeo.cli, in the order ``--help`` lists them.
COMMANDS = [
    "info",
    "locate",
    "lidar",
    "simulate",
    "imports",
    "match",
    "adjust",
    "plan",
    "rectify",
    "clean",
    "diagnose",
    "compare",
    "report",
    "run",
    "demo",
]


def common_options() -> argparse.ArgumentParser:
    """The options every command shares (``--verbose``, ``--progress/--no-progress``)."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv: debug)")
    common.add_argument(
        "--progress", dest="progress", action=argparse.BooleanOptionalAction, default=None,
        help="show a progress bar (default: when stderr is a terminal)",
    )
    return common


def settings_table(path: str | None, name: str) -> dict:
    """The ``[name]`` table of a command's ``--config`` TOML file (empty without one); any other
    table, or a file that cannot be read, is a ProjectFileError naming the file."""
    if not path:
        return {}
    data = load_toml(Path(path))
    unknown = [k for k in data if k != name]
    if unknown:
        raise ProjectFileError(f"{path}: unknown table [{unknown[0]}] (expected [{name}])")
    return dict(data.get(name, {}))


def progress_of(args: argparse.Namespace):
    """The progress callback for a command's arguments."""
    enabled = args.progress if args.progress is not None else sys.stderr.isatty()
    return TextProgress(enabled=True) if enabled else no_progress


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="scangeo", description="Georeferencing of airborne line-scanner imagery."
    )
    parser.add_argument("--version", action="version", version=f"scangeo {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    common = common_options()
    for name in COMMANDS:
        module = importlib.import_module(f"scangeo.cli.{name}")
        module.add_parser(subparsers, common)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    level = logging.WARNING - 10 * min(getattr(args, "verbose", 0), 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        if getattr(args, "writes_project", False):  # set by commands that write into PROJECT
            with OutputLock(args.project, f"scangeo {args.command}"):
                return int(args.func(args) or 0)
        return int(args.func(args) or 0)
    except ScangeoError as exc:
        print(f"scangeo {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # a full disk, a folder without write permission: the system's words suffice
        print(f"scangeo {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"scangeo {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
