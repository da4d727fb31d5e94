"""One configuration schema for every TOML file scangeo reads.

project.toml, the simulation presets, variants.toml and the ``[rectify]`` options are frozen
dataclasses whose fields are :func:`setting` s: the field's annotation is the key's type; the
setting adds its unit, range, allowed values and meaning. :func:`read` turns a parsed TOML table
into the dataclass, checking every key, and every error names the file and the dotted key::

    project.toml [sensor.pixels]: expected an integer >= 1 (px), found 716.0
    rectify.toml [rectify.igm]: expected true or false, found 'false'
    small.toml [flight.sidelap]: expected a number in [0, 0.9), found 1.2

The tables of docs/formats.md are generated from the same settings
(``python -m scangeo.io.schema_docs docs/formats.md``), so the docs and the checks cannot drift.

Types understood: ``bool`` (only ``true``/``false``, never a string), ``int`` (not a float, not a
bool), ``float`` (an integer is accepted and converted), ``str``, ``X | None`` (the key may be
absent), unions such as ``bool | str``, ``tuple[T, ...]`` and ``tuple[T, T, T]`` (TOML arrays),
``dict[str, T]`` (a TOML table of values), a nested settings dataclass (a sub-table) and
``tuple[Dataclass, ...]`` (an array of tables).

Adding a key: add a field ``name: type = setting(default, unit=..., doc=...)`` to the dataclass of
its table, then regenerate the docs. A key that needs custom parsing gives ``parse=`` (a function
``(value, where) -> value`` that raises :class:`~scangeo.errors.ProjectFileError` via
:func:`fail`); a condition that a range cannot say gives ``multiple_of=`` or ``rule=`` (a
:class:`Rule`: a test and its words).

The same checks hold for a settings dataclass built in Python: its ``__post_init__`` calls
:func:`check`, which converts and checks every field as :func:`read` checks a key, so
``RectifyOptions(max_error_px=0)`` fails with the words a file gets, only the place differs::

    RectifyOptions.max_error_px: expected a number > 0 (px), found 0
    run.toml [rectify.max_error_px]: expected a number > 0 (px), found 0
"""
from __future__ import annotations

import dataclasses
import functools
import math
import os
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from scangeo.errors import ProjectFileError

#: The default of a required key.
REQUIRED: Any = dataclasses.MISSING

#: Units inferred from a key's name when ``unit`` is not given.
_SUFFIX_UNITS = {"_m": "m", "_deg": "deg", "_s": "s", "_hz": "Hz", "_px": "px", "_mm": "mm", "_um": "um",
                 "_nm": "nm", "_mb": "MiB", "_mps": "m/s", "_dn": "DN"}


@dataclass(frozen=True)
class Rule:
    """A condition a range cannot state: ``test(value)`` is true for a good value; ``text`` says it in
    words for errors and the docs (``"odd"``, ``"ALL_CPUS or a number >= 1"``)."""

    test: Callable[[Any], bool]
    text: str


@dataclass(frozen=True)
class Setting:
    """What a key accepts besides its type: unit, range, allowed values, meaning."""

    unit: str = ""
    doc: str = ""
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    choices: tuple[Any, ...] = ()
    length: int | None = None
    key: str | None = None
    when: tuple[str, Any] | None = None
    internal: bool = False
    parse: Callable[[Any, str], Any] | None = None
    default_doc: str = ""
    file_type: Any = None
    multiple_of: int | None = None
    rule: Rule | None = None
    allow_nan: bool = False

    def range_text(self) -> str:
        """The range as ``[0, 0.9]``, ``> 0``, ``>= 16, multiple of 16`` ('' without one)."""
        text = self._bounds_text()
        extra = [t for t in (f"multiple of {self.multiple_of}" if self.multiple_of else "",
                             self.rule.text if self.rule else "") if t]
        return ", ".join([text, *extra] if text else extra)

    def _bounds_text(self) -> str:
        lo = f"[{_num(self.ge)}" if self.ge is not None else f"({_num(self.gt)}" if self.gt is not None else None
        hi = f"{_num(self.le)}]" if self.le is not None else f"{_num(self.lt)})" if self.lt is not None else None
        if lo and hi:
            return f"{lo}, {hi}"
        if lo:
            return (">= " if self.ge is not None else "> ") + lo[1:]
        if hi:
            return ("<= " if self.le is not None else "< ") + hi[:-1]
        return ""


def _num(x: float | None) -> str:
    return f"{x:g}"


def setting(default: Any = REQUIRED, *, unit: str = "", doc: str = "", ge: float | None = None,
            gt: float | None = None, le: float | None = None, lt: float | None = None,
            choices: tuple[Any, ...] = (), length: int | None = None, key: str | None = None,
            when: tuple[str, Any] | None = None, internal: bool = False,
            parse: Callable[[Any, str], Any] | None = None, default_doc: str = "", file_type: Any = None,
            multiple_of: int | None = None, rule: Rule | None = None, allow_nan: bool = False) -> Any:
    """A dataclass field that is a configuration key.

    Parameters
    ----------
    default : the value when the key is absent (mutable defaults: give a tuple); :data:`REQUIRED`
        (the default) makes the key required.
    unit : the unit of numbers (inferred from the name's suffix ``_m``, ``_deg``, ``_s``, ... when not
        given; ``"1"`` for a dimensionless number).
    doc : the meaning, one sentence (the docs tables show it).
    ge, gt, le, lt : the range of numbers (of every element of a list).
    choices : the allowed values of a string (of every element of a list).
    length : the number of elements of a list.
    key : the key's name in the file when it differs from the field's.
    when : ``(other_key, value)``: the key exists only when another key of the table has that value, or
        one of a tuple of values (e.g. ``("kind", "whiskbroom")``); given otherwise, it is an unknown key.
    internal : not a key of the file (filled in by the program).
    parse : custom conversion ``(value, where) -> value`` after the type check.
    default_doc : how the docs show the default, when its value does not say it.
    file_type : the type in the file when it differs from the field's (``parse`` converts it).
    multiple_of : integers must be a multiple of this.
    rule : any other condition on a value (:class:`Rule`), stated in errors and docs.
    allow_nan : a number may be NaN (``nan`` in TOML; a nodata value).

    Returns
    -------
    dataclasses.Field
        The field, with the :class:`Setting` in its metadata.
    """
    meta = {"setting": Setting(unit, doc, ge, gt, le, lt, tuple(choices), length, key, when, internal, parse,
                               default_doc, file_type, multiple_of, rule, allow_nan)}
    if default is REQUIRED:
        return dataclasses.field(metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def fail(where: str, expected: str, found: Any) -> typing.NoReturn:
    """Raise the schema's error: ``WHERE: expected EXPECTED, found FOUND``."""
    raise ProjectFileError(f"{where}: expected {expected}, found {found!r}")


@dataclass(frozen=True)
class Key:
    """One key of a settings dataclass: its name in the file, field name, type and setting."""

    name: str
    field: str
    hint: Any
    setting: Setting
    default: Any

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    @property
    def unit(self) -> str:
        if self.setting.unit:
            return "" if self.setting.unit == "1" else self.setting.unit
        return next((u for s, u in _SUFFIX_UNITS.items() if self.name.endswith(s)), "")


def keys(cls: type) -> list[Key]:
    """The keys of a settings dataclass, in field order (internal fields left out).

    Parameters
    ----------
    cls : a dataclass whose fields are :func:`setting` s.

    Returns
    -------
    list of Key
        One per key of the file, in field order.
    """
    return list(_keys(cls))


@functools.cache
def _keys(cls: type) -> tuple[Key, ...]:
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        s = f.metadata.get("setting", Setting())
        if s.internal or not f.init:
            continue
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            default = REQUIRED
        out.append(Key(s.key or f.name, f.name, s.file_type or hints[f.name], s, default))
    return tuple(out)


def check(obj: Any, where: str | None = None) -> None:
    """Check a settings dataclass built in Python as :func:`read` checks the keys of a file.

    Called by a settings dataclass's ``__post_init__``: every field is converted and checked as its
    key would be (type, range, allowed values, length, rule), and the converted value is stored (a
    list or array becomes a tuple, an integer given for a number a float). A field ``None`` is
    accepted where the type allows None; a nested settings dataclass must be an instance (it checked
    itself); a field read with ``parse=`` holds the parsed value and is left to ``__post_init__``.

    Parameters
    ----------
    obj : the settings dataclass instance (frozen or not).
    where : the name errors give before the field (default: the class's name).

    Raises
    ------
    ProjectFileError, or the class's ``schema_error``
        ``CLASS.FIELD: expected ..., found ...``: the words :func:`read` uses for a file's key, and
        the class of error a file's key raises (:func:`error_class`); its ``field`` attribute names
        the field.
    """
    cls = type(obj)
    error = error_class(cls)
    name = where or cls.__name__
    known = keys(cls)
    by_name = {k.name: k for k in known}
    for k in known:
        if k.setting.parse is not None:
            continue
        when = k.setting.when
        if when is not None and when[0] in by_name and not _applies(when, getattr(obj, by_name[when[0]].field)):
            continue
        try:
            value = _from_python(getattr(obj, k.field), k.hint, dataclasses.replace(k.setting, unit=k.unit),
                                 f"{name}.{k.field}")
        except ProjectFileError as exc:
            raised = exc if isinstance(exc, error) else error(str(exc))
            raised.field = k.field  # type: ignore[attr-defined]  # the command line names its flag
            raise raised from None
        object.__setattr__(obj, k.field, value)


def _from_python(value: Any, hint: Any, s: Setting, where: str) -> Any:
    """One field's value built in Python, checked and converted as the same value read from a file."""
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        members = [a for a in args if a is not type(None)]
        if len(members) == 1:
            return _from_python(value, members[0], s, where)
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        if not isinstance(value, hint):
            fail(where, f"a {hint.__name__}", value)
        return value
    if origin is tuple and args and isinstance(args[0], type) and dataclasses.is_dataclass(args[0]):
        item = args[0]
        if not isinstance(value, (tuple, list)) or not all(isinstance(v, item) for v in value):
            fail(where, f"a tuple of {item.__name__}", value)
        return tuple(value)
    return convert(_plain(value), hint, s, where)


def _plain(value: Any) -> Any:
    """A value built in Python as TOML would give it: tuples and arrays as lists, numpy scalars as
    Python numbers, a path as a string."""
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if hasattr(value, "tolist") and hasattr(value, "dtype"):  # a numpy array or scalar
        return _plain(value.tolist())
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


def _applies(when: tuple[str, Any], value: Any) -> bool:
    """Whether a key conditioned on ``when = (other_key, value or tuple of values)`` exists."""
    return value in when[1] if isinstance(when[1], tuple) else value == when[1]


def error_class(cls: type) -> type[Exception]:
    """The exception a settings dataclass's bad keys and fields raise: its ``schema_error`` class
    attribute (e.g. :class:`~scangeo.errors.RectifyOptionsError`), else
    :class:`~scangeo.errors.ProjectFileError`."""
    return getattr(cls, "schema_error", ProjectFileError)


def read(cls: type, table: Any, file: str, path: str = "", **internal: Any) -> Any:
    """A settings dataclass from a parsed TOML table; every key checked.

    Parameters
    ----------
    cls : the settings dataclass of the table.
    table : the parsed TOML table (a mapping).
    file : the file's name, for errors.
    path : the table's dotted key (``""`` for the top level), for errors.
    **internal : values of internal fields (not keys of the file).

    Returns
    -------
    cls
        The settings, every key converted and checked.

    Raises
    ------
    ProjectFileError, or the class's ``schema_error``
        ``FILE [TABLE.KEY]: expected ..., found ...``; an unknown key or table, a missing required key.
    """
    error = error_class(cls)
    try:
        return _read(cls, table, file, path, **internal)
    except ProjectFileError as exc:
        if isinstance(exc, error):
            raise
        raise error(str(exc)) from exc


def _read(cls: type, table: Any, file: str, path: str = "", **internal: Any) -> Any:
    where_table = f"{file} [{path}]" if path else str(file)
    if not isinstance(table, Mapping):
        fail(where_table, "a table", table)
    known = keys(cls)
    by_name = {k.name: k for k in known}
    for k in known:  # the keys others depend on (a sensor's kind) first: their errors come first
        if k.setting.when is not None and k.setting.when[0] in table and k.setting.when[0] in by_name:
            dep = by_name[k.setting.when[0]]
            convert(table[dep.name], dep.hint, dep.setting, _where(file, path, dep.name), file, _join(path, dep.name))
    applicable = {k.name for k in known if k.setting.when is None
                  or _applies(k.setting.when, table.get(k.setting.when[0], _default_of(by_name, k.setting.when[0])))}
    unknown = [name for name in table if name not in applicable]
    if unknown:
        name = unknown[0]
        if name in by_name:
            other, value = by_name[name].setting.when  # type: ignore[misc]
            expected = (f"one of {', '.join(map(repr, value))}" if isinstance(value, tuple) else repr(value))
            raise ProjectFileError(f"{_where(file, path, name)}: not a key when {other} is not {expected}")
        what = f"table [{_join(path, name)}]" if isinstance(table[name], Mapping) else f"key {name!r}"
        raise ProjectFileError(f"{where_table}: unknown {what} (expected one of {', '.join(sorted(applicable))})")
    values = dict(internal)
    for k in known:
        where = _where(file, path, k.name)
        if k.name not in table:
            if k.required and k.name in applicable:
                raise ProjectFileError(f"{where}: missing (required)")
            continue
        s = dataclasses.replace(k.setting, unit=k.unit)  # errors state the unit (inferred from the name)
        value = convert(table[k.name], k.hint, s, where, file, _join(path, k.name))
        if k.setting.parse is not None:
            value = k.setting.parse(value, where)
        values[k.field] = value
    try:
        return cls(**values)
    except (ProjectFileError, error_class(cls)) as exc:
        if str(file) in str(exc):
            raise
        raise type(exc)(f"{where_table}: {exc}") from exc


def _default_of(by_name: dict[str, Key], name: str) -> Any:
    k = by_name.get(name)
    return None if k is None or k.required else k.default


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _where(file: str, path: str, key: str) -> str:
    return f"{file} [{_join(path, key)}]"


def convert(value: Any, hint: Any, s: Setting, where: str, file: str = "", path: str = "") -> Any:
    """Check and convert one value against its type and setting (errors name ``where``)."""
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        members = [a for a in args if a is not type(None)]
        if len(members) == 1:
            return convert(value, members[0], s, where, file, path)
        errors = []
        for member in members:
            try:
                return convert(value, member, s, where, file, path)
            except ProjectFileError as exc:
                errors.append(str(exc).split(": expected ", 1)[-1].split(", found ")[0])
        fail(where, s.rule.text if s.rule is not None else " or ".join(dict.fromkeys(errors)), value)
    if dataclasses.is_dataclass(hint):
        return read(hint, value, file, path)  # type: ignore[arg-type]
    if origin is tuple:
        return _tuple(value, args, s, where, file, path)
    if origin is dict:
        if not isinstance(value, Mapping):
            fail(where, "a table", value)
        return {str(k): convert(v, args[1], s, f"{where[:-1]}.{k}]", file, f"{path}.{k}") for k, v in value.items()}
    return _scalar(value, hint, s, where)


def _tuple(value: Any, args: tuple, s: Setting, where: str, file: str, path: str) -> tuple:
    item = args[0]
    if dataclasses.is_dataclass(item) and isinstance(value, Mapping):
        value = [value]  # one [[table]] given as a [table]
    if not isinstance(value, list):
        fail(where, "a list" if not dataclasses.is_dataclass(item) else "an array of tables", value)
    length = s.length if s.length is not None else (len(args) if Ellipsis not in args else None)
    if length is not None and len(value) != length:
        fail(where, f"{length} {_type_name(item, plural=True)}{_unit(s) if item in (int, float) else ''}", value)
    if dataclasses.is_dataclass(item):
        return tuple(read(item, v, file, f"{path}[{i}]") for i, v in enumerate(value))  # type: ignore[arg-type]
    types_ = [a for a in args if a is not Ellipsis]
    out = []
    for i, v in enumerate(value):
        try:
            out.append(convert(v, types_[min(i, len(types_) - 1)], s, where))
        except ProjectFileError:
            fail(where, _list_text(length, item, s), value)
    return tuple(out)


def _list_text(length: int | None, item: Any, s: Setting) -> str:
    count = f"{length} " if length is not None else "a list of "
    text = count + _type_name(item, plural=True)
    extra = _constraint_text(s)
    text += f" {extra}" if extra else ""
    return text + (_unit(s) if item in (int, float) else "")


def _type_name(hint: Any, plural: bool = False) -> str:
    names = {bool: ("true or false", "booleans"), int: ("an integer", "integers"), float: ("a number", "numbers"),
             str: ("a string", "strings")}
    return names.get(hint, (getattr(hint, "__name__", str(hint)),) * 2)[1 if plural else 0]


def _constraint_text(s: Setting) -> str:
    if s.choices:
        return "(one of " + ", ".join(str(c) for c in s.choices) + ")"
    r = s.range_text()
    return f"in {r}" if r.startswith(("[", "(")) else r


def _scalar(value: Any, hint: Any, s: Setting, where: str) -> Any:
    if hint is bool:
        if not isinstance(value, bool):
            fail(where, "true or false", value)
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            fail(where, "an integer" + _with(s) + _unit(s), value)
        if s.choices and value not in s.choices:
            fail(where, "one of " + ", ".join(str(c) for c in s.choices), value)
        _check_range(value, s, where, "an integer")
        return value
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            fail(where, "a number" + _with(s) + _unit(s), value)
        if math.isnan(value):
            if s.allow_nan:
                return float(value)
            fail(where, "a number", value)
        _check_range(value, s, where, "a number")
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            fail(where, "a string" + _with(s), value)
        if s.choices and value not in s.choices:
            fail(where, "one of " + ", ".join(str(c) for c in s.choices), value)
        _check_rule(value, s, where, "a string")
        return value
    if hint is Any:
        return value
    raise TypeError(f"{where}: unsupported setting type {hint!r}")  # a programming error


def _unit(s: Setting) -> str:
    return f" ({s.unit})" if s.unit and s.unit != "1" else ""


def _with(s: Setting) -> str:
    text = _constraint_text(s)
    return f" {text}" if text else ""


def _check_range(value: float, s: Setting, where: str, kind: str) -> None:
    ok = ((s.ge is None or value >= s.ge) and (s.gt is None or value > s.gt)
          and (s.le is None or value <= s.le) and (s.lt is None or value < s.lt)
          and (not s.multiple_of or value % s.multiple_of == 0))
    if not ok:
        fail(where, f"{kind} {_constraint_text(s)}{_unit(s)}", value)
    _check_rule(value, s, where, kind)


def _check_rule(value: Any, s: Setting, where: str, kind: str) -> None:
    if s.rule is not None and not s.rule.test(value):
        fail(where, f"{kind} {_constraint_text(s)}{_unit(s)}" if s.range_text() != s.rule.text else s.rule.text,
             value)


def type_text(hint: Any, s: Setting | None = None) -> str:
    """A key's type in words, for the docs (``3 numbers``, ``integer``, ``true/false``...)."""
    s = s or Setting()
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(type_text(a, s) for a in args if a is not type(None))
    if dataclasses.is_dataclass(hint):
        return "table"
    if origin is tuple:
        if dataclasses.is_dataclass(args[0]):
            return "array of tables"
        length = s.length if s.length is not None else (len(args) if Ellipsis not in args else None)
        return f"{length} {_type_name(args[0], True)}" if length else f"list of {_type_name(args[0], True)}"
    if origin is dict:
        return f"table of {_type_name(args[1], True)}"
    return {bool: "true/false", int: "integer", float: "number", str: "string"}.get(hint, str(hint))


__all__ = ["REQUIRED", "Key", "Rule", "Setting", "check", "convert", "error_class", "fail", "keys", "read", "setting",
           "type_text"]
