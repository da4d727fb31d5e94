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
from typing import Any

from scangeo.atomic import OutputLock
from scangeo.errors import ArgumentError, ScangeoError
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


class HelpFormatter(argparse.HelpFormatter):
    """``--help`` that states each option's default and choices as the library defines them.

    A flag added by :func:`option_argument` names the field of a settings dataclass or the parameter
    of a library call it sets (``scangeo.rectify.options:RectifyOptions.max_error_px``); its help gets
    ``(default: 0.05 px)`` and the allowed values from there, read only when the help is shown, so
    no command's start imports the library for it.
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help
        target = getattr(action, "option", None)
        if target is None or text == argparse.SUPPRESS:
            return text
        extra = option_text(target, choices=not isinstance(action, argparse.BooleanOptionalAction),
                            scale=getattr(action, "scale", 1.0)).replace("%", "%%")
        return f"{text} ({extra})" if text else extra


class Parser(argparse.ArgumentParser):
    """scangeo's argument parser: its help is formatted by :class:`HelpFormatter`."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)


def _owner(target: str):
    module, _, rest = target.partition(":")
    owner, _, name = rest.rpartition(".")
    return getattr(importlib.import_module(module), owner), name


def option_default(target: str):
    """The default of a settings field or a call's parameter (``module:Owner.name``).

    ``Owner`` is a dataclass (its field's default), a dataclass instance (the field's value there: an
    example the command starts from) or a function (its parameter's default; the allowed values of a
    ``Literal[...]`` annotation).

    Returns
    -------
    tuple
        (value, words for a missing value or None, unit, allowed values).
    """
    import dataclasses
    import inspect
    import typing

    owner, name = _owner(target)
    if dataclasses.is_dataclass(owner):
        from scangeo.io.schema import keys

        cls = owner if isinstance(owner, type) else type(owner)
        key = next(k for k in keys(cls) if k.field == name)
        value = key.default if isinstance(owner, type) else getattr(owner, name)
        return value, key.setting.default_doc or None, key.unit, tuple(key.setting.choices)
    hint = typing.get_type_hints(owner).get(name)
    allowed = typing.get_args(hint) if typing.get_origin(hint) is typing.Literal else ()
    return inspect.signature(owner).parameters[name].default, None, "", allowed


def _words(value) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, (tuple, list)):
        return " ".join(_words(v) for v in value) if value else "none"
    if isinstance(value, float):
        return f"{value:g}"
    return "none" if value is None else str(value)


def option_text(target: str, choices: bool = True, scale: float = 1.0) -> str:
    """``default: 0.05 px`` (and ``one of: ...``) of a flag bound to ``target`` (:class:`HelpFormatter`);
    ``scale``: the library's value is the flag's times ``scale`` (an angle in degrees on the command line,
    radians in the library: ``pi / 180``)."""
    value, words, unit, allowed = option_default(target)
    if scale != 1.0:
        value = _scaled(value, 1.0 / scale)
    unit = {"line": "lines", "cell": "cells"}.get(unit, unit)
    text = "default: " + (words or _words(value)) + (f" {unit}" if unit and not words and value is not None else "")
    if allowed and choices:
        text += "; one of: " + ", ".join(_words(c) for c in allowed)
    return text


def _scaled(value, factor: float):
    """A number, or every number of a tuple, times ``factor`` (None stays None)."""
    if isinstance(value, (tuple, list)):
        return tuple(_scaled(v, factor) for v in value)
    return None if value is None else value * factor


def option_argument(parser: argparse.ArgumentParser, *flags: str, option: str, scale: float = 1.0,
                    **kwargs) -> argparse.Action:
    """A flag that sets a settings field or a call's parameter ``option`` (``module:Owner.name``).

    Its default is None (not given: the settings file's value or the library's default applies), and
    ``--help`` shows the library's default and choices (:class:`HelpFormatter`). ``scale``: the
    library's value is the flag's times ``scale`` (degrees on the command line, radians in the library:
    ``pi / 180``); :func:`given` converts. Returns the action.
    """
    action = parser.add_argument(*flags, default=None, **kwargs)
    action.option = option  # type: ignore[attr-defined]
    action.scale = scale  # type: ignore[attr-defined]
    bound = dict(parser.get_default("option_flags") or {})
    bound[action.dest] = (option, max(action.option_strings, key=len), scale)
    parser.set_defaults(option_flags=bound)
    return action


def given(args: argparse.Namespace, owner: str) -> dict[str, tuple[str, object]]:
    """The flags given on the command line that set a field of the class (or instance) named ``owner``:
    field -> (flag, value in the library's unit)."""
    out = {}
    for dest, (target, flag, scale) in (getattr(args, "option_flags", None) or {}).items():
        cls, _, name = target.rpartition(".")
        value = getattr(args, dest, None)
        if cls.rpartition(":")[2] == owner and value is not None:
            out[name] = (flag, value if scale == 1.0 else _scaled(value, scale))
    return out


def passed(args: argparse.Namespace, *names: str) -> dict[str, Any]:
    """The flags among ``names`` given on the command line (name -> value), for a library call whose
    own defaults apply to the rest."""
    return {name: getattr(args, name) for name in names if getattr(args, name, None) is not None}


def with_flags(options, args: argparse.Namespace, owner: str | None = None):
    """``options`` (a settings dataclass) with the fields the command-line flags give; an error names
    the flag (``--max-error 0: expected a number > 0 (px), found 0``). ``owner``: the name the flags are
    bound to (:func:`option_argument`), when not the class's (an example instance's)."""
    import dataclasses

    flags = given(args, owner or type(options).__name__)
    try:
        return dataclasses.replace(options, **{name: value for name, (flag, value) in flags.items()})
    except ScangeoError as exc:
        name = getattr(exc, "field", None)
        if name not in flags:
            raise
        flag = flags[name][0]
        value = next(getattr(args, dest) for dest, bound in args.option_flags.items() if bound[1] == flag)
        raise type(exc)(f"{flag} {_words(value)}: {str(exc).split(': ', 1)[1]}") from None


def settings_argument(parser: argparse.ArgumentParser) -> None:
    """``--config FILE``: the settings file (default ``PROJECT/run.toml`` when it exists)."""
    parser.add_argument("--config", default=None, metavar="FILE",
                        help="settings file with [match], [clean], [compare], [rectify] tables (default: "
                             "PROJECT/run.toml when it exists; docs/run.md)")


def project_settings(args: argparse.Namespace):
    """The settings of ``args.project``: ``--config`` or ``PROJECT/run.toml`` (:mod:`scangeo.pipeline.settings`)."""
    from scangeo.pipeline.settings import read_settings

    return read_settings(args.project, args.config)


def progress_of(args: argparse.Namespace):
    """The progress callback for a command's arguments."""
    enabled = args.progress if args.progress is not None else sys.stderr.isatty()
    return TextProgress(enabled=True) if enabled else no_progress


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="scangeo", description="Georeferencing of airborne line-scanner imagery.")
    parser.add_argument("--version", action="version", version=f"scangeo {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
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
        print(f"scangeo {args.command}: error: {_in_flags(exc, parser, args)}", file=sys.stderr)
        return 1
    except OSError as exc:  # a full disk, a folder without write permission: the system's words suffice
        print(f"scangeo {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"scangeo {args.command}: interrupted", file=sys.stderr)
        return 130


def _actions(parser: argparse.ArgumentParser, args: argparse.Namespace) -> list[argparse.Action]:
    """The actions of the command given (and of its sub-commands)."""
    out: list[argparse.Action] = []
    todo = [parser]
    while todo:
        p = todo.pop()
        for a in p._actions:
            if isinstance(a, argparse._SubParsersAction):
                chosen = [sub for name, sub in a.choices.items() if name in (args.command, getattr(args, a.dest, None))]
                todo.extend(chosen)
            else:
                out.append(a)
    return out


def _flag(actions: list[argparse.Action], name: str, value: object) -> str:
    """How the command line says ``name=value``: ``--workers 0``, ``--overwrite``, ``--no-write-variants``."""
    for a in actions:
        if a.dest != name or not a.option_strings:
            continue
        longest = max(a.option_strings, key=len)
        if isinstance(a, argparse.BooleanOptionalAction):
            return a.option_strings[0] if value else a.option_strings[-1]
        if isinstance(a.const, bool) and a.nargs == 0:  # store_true / store_false
            if a.const == value:
                return longest
            continue
        return longest if value is None or value in ([], ()) else f"{longest} {_words(value)}"
    return f"{name}={value!r}"


def _in_flags(exc: ScangeoError, parser: argparse.ArgumentParser, args: argparse.Namespace) -> str:
    """An error's message, with the arguments it names as the command line names them."""
    if isinstance(exc, ArgumentError):
        actions = _actions(parser, args)
        return exc.render(lambda name, value: _flag(actions, name, value))
    return str(exc)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
