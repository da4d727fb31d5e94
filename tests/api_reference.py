"""docs/api.md's reference, generated from the docstrings of ``scangeo.__all__``.

``python -m tests.api_reference docs/api.md`` rewrites the block between ``<!-- api-reference -->``
and ``<!-- /api-reference -->`` of the page; ``--check`` only reports whether it is stale (exit status 1).
``tests/test_docs_api.py`` checks that the page is up to date and that every name has a numpydoc
docstring with Parameters and Returns (:func:`missing_sections`).

Each name gets a heading ``#### scangeo.NAME``, its signature and its docstring in Markdown: the numpydoc
sections (Parameters, Returns, Raises, ...) become bold titles and lists. A class also lists its public
methods and properties (those it defines, not inherited ones) with their own docstrings.
"""
from __future__ import annotations

import argparse
import dataclasses
import inspect
import re
import sys
from pathlib import Path

import scangeo

BLOCK = re.compile(r"(<!-- api-reference -->\n)(?P<body>.*?)(<!-- /api-reference -->)", re.S)
PAGE = Path(__file__).resolve().parents[1] / "docs" / "api.md"

#: The groups of the reference, in order: a title and the names of ``scangeo.__all__`` it holds.
GROUPS = (
    ("Calls", ("simulate_project", "match_points", "clean", "diagnose", "adjust", "compare", "report",
               "rectify_strips", "rectify_in_memory", "read_orientation", "read_settings", "lidar_adjust", "run")),
    ("What the calls take", ("Project", "Settings", "MatchOptions", "CleaningOptions", "CompareSettings",
                             "RectifyOptions", "GeoTiffProfile")),
    ("What the calls return", ("SimulatedBlock", "LaserSimulation", "MatchResult", "Cleaning", "DiagnosisRun",
                               "Diagnosis", "AdjustmentRun", "VariantResult", "ComparisonRun", "Comparison",
                               "ReportFiles", "BatchResult", "StripArray", "Orientation", "LaserResult",
                               "RunResult")),
    ("Errors and version", ("ScangeoError", "__version__")),
)
SECTION = re.compile(r"^(?P<title>[A-Z][A-Za-z ]+)\n-{3,}\n", re.M)
ITEM = re.compile(r"^(?P<name>[\w*][\w*, ]*?)(?: : (?P<type>.+))?$")


def members(cls: type) -> list[tuple[str, object]]:
    """The public methods and properties a class defines itself (not inherited), in source order."""
    out = []
    for name, value in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(value, (staticmethod, classmethod)):
            value = value.__func__
        if inspect.isfunction(value) or isinstance(value, property) or type(value).__name__ == "cached_property":
            out.append((name, value))
    return out


def sections(doc: str) -> dict[str, str]:
    """The numpydoc sections of a docstring: title -> body ('' -> the text before the first)."""
    parts = SECTION.split(doc)
    out = {"": parts[0].strip()}
    for i in range(1, len(parts) - 1, 2):
        out[parts[i]] = parts[i + 1].rstrip()
    return out


def missing_sections(name: str) -> list[str]:
    """What the docstring of ``scangeo.NAME`` lacks: a function needs Parameters and Returns; a class
    needs Parameters (its fields or its constructor's arguments), and every method or property it
    defines needs Returns (and Parameters when it takes arguments)."""
    obj = getattr(scangeo, name)
    if not (inspect.isclass(obj) or callable(obj)):
        return []  # a value (__version__): no docstring of its own
    doc = inspect.getdoc(obj) or ""
    missing = []
    if inspect.isclass(obj):
        if "Parameters" not in sections(doc):
            missing.append(f"{name}: Parameters")
        for member, value in members(obj):
            mdoc = sections(inspect.getdoc(value) or "")
            if "Returns" not in mdoc:
                missing.append(f"{name}.{member}: Returns")
            function = getattr(value, "fget", None) or getattr(value, "func", None) or value
            args = [p for p in inspect.signature(function).parameters if p not in ("self", "cls")]
            if args and "Parameters" not in mdoc:
                missing.append(f"{name}.{member}: Parameters")
        return missing
    found = sections(doc)
    return [f"{name}: {s}" for s in ("Parameters", "Returns") if s not in found]


ROLE = re.compile(r":(?P<role>class|func|meth|mod|data|attr|exc):`~?(?P<target>[\w.]+)`")


def _rst(text: str) -> str:
    """reStructuredText's inline markup as Markdown: ``x`` as `x`, :func:`a.b.x` as `x`, a module in full."""
    def name(m: re.Match) -> str:
        target = m.group("target")
        return f"`{target if m.group('role') == 'mod' else target.rpartition('.')[2]}`"

    return ROLE.sub(name, text).replace("``", "`")


def _markdown(doc: str) -> str:
    """A numpydoc docstring in Markdown: the summary as text, each section a bold title and a list."""
    out = []
    for title, body in sections(doc).items():
        if not title:
            out.append(_rst(body))
            continue
        if title in ("Parameters", "Returns", "Raises", "Attributes", "Yields"):
            out.append(f"**{title}**\n\n" + _rst(_items(body)))
        else:
            out.append(f"**{title}**\n\n" + _rst(body))
    return "\n\n".join(p for p in out if p) + "\n"


def _items(body: str) -> str:
    """``name : type`` lines with indented descriptions -> a Markdown list."""
    rows: list[list[str]] = []
    for line in body.splitlines():
        if line and not line.startswith(" "):
            m = ITEM.match(line.strip())
            head = line.strip()
            if m and m.group("type"):
                head = f"`{m.group('name')}` : *{m.group('type')}*"
            elif m:
                head = f"*{m.group('name')}*" if m.group("name")[0].isupper() else f"`{m.group('name')}`"
            rows.append([head])
        elif rows:
            rows[-1].append(line.strip())
    return "\n".join("- " + rows_text(r) for r in rows)


def rows_text(row: list[str]) -> str:
    head, *rest = row
    text = " ".join(r for r in rest if r)
    return f"{head}: {text}" if text else head


def _default(value: object) -> str:
    """A default as the page shows it: the same on every run (a function by its name, not its address)."""
    if callable(value):
        return getattr(value, "__name__", type(value).__name__)
    if dataclasses.is_dataclass(value):
        return f"{type(value).__name__}()"
    return repr(value)


def _signature(name: str, obj: object) -> str:
    """``scangeo.NAME(arguments) -> returned``; a dataclass by its fields."""
    if inspect.isclass(obj) and dataclasses.is_dataclass(obj):
        fields = [f.name for f in dataclasses.fields(obj) if f.init]
        return f"```python\nscangeo.{name}({', '.join(fields)})\n```\n"
    try:
        sig = inspect.signature(obj)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return ""
    parts, star = [], False
    for p in sig.parameters.values():
        if p.kind is p.KEYWORD_ONLY and not star:
            parts.append("*")
            star = True
        text = {p.VAR_POSITIONAL: "*", p.VAR_KEYWORD: "**"}.get(p.kind, "") + p.name  # type: ignore[call-overload]
        if p.annotation is not p.empty:
            annotation = p.annotation if isinstance(p.annotation, str) else inspect.formatannotation(p.annotation)
            text += f": {annotation}"
        if p.default is not p.empty:
            text += f" = {_default(p.default)}"
        if p.kind is p.VAR_POSITIONAL:
            star = True
        parts.append(text)
    returned = sig.return_annotation
    tail = "" if returned is sig.empty else f" -> {returned}" if isinstance(returned, str) else ""
    body = "".join(f"\n    {p}," for p in parts) + ("\n" if parts else "")
    return f"```python\nscangeo.{name}({body}){tail}\n```\n"


def entry(name: str) -> str:
    """The reference entry of ``scangeo.NAME``."""
    obj = getattr(scangeo, name)
    if not (inspect.isclass(obj) or callable(obj)):
        return f"#### scangeo.{name}\n\nThe version of scangeo, a string (`{type(obj).__name__}`).\n"
    kind = "class" if inspect.isclass(obj) else "function"
    where = getattr(obj, "__module__", "")
    text = f"#### scangeo.{name}\n\n*{kind}, defined in `{where}`*\n\n{_signature(name, obj)}\n"
    text += _markdown(inspect.getdoc(obj) or "")
    if inspect.isclass(obj):
        for member, value in members(obj):
            kind = "property" if not inspect.isfunction(value) else "method"
            text += f"\n##### {name}.{member} ({kind})\n\n" + _markdown(inspect.getdoc(value) or "")
    return text


def reference() -> str:
    """The generated reference: every name of ``scangeo.__all__``, by group."""
    listed = [n for _, names in GROUPS for n in names]
    unknown = set(scangeo.__all__) - set(listed)
    if unknown:  # a new name must be placed in a group
        raise SystemExit(f"scangeo.__all__ names not in a group of tests/api_reference.py: {sorted(unknown)}")
    out = []
    for title, names in GROUPS:
        out.append(f"### {title}\n")
        out += [entry(n) for n in names]
    return "\n".join(out)


def render(text: str) -> str:
    """The page with its reference block regenerated."""
    if not BLOCK.search(text):
        raise SystemExit("no <!-- api-reference --> block in the page")
    return BLOCK.sub(lambda m: m.group(1) + "\n" + reference() + "\n" + m.group(3), text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.api_reference", description=__doc__)
    parser.add_argument("page", nargs="?", type=Path, default=PAGE, help="the page (default docs/api.md)")
    parser.add_argument("--check", action="store_true", help="report a stale page instead of rewriting it")
    args = parser.parse_args(argv)
    text = args.page.read_text(encoding="utf-8")
    new = render(text)
    if new == text:
        return 0
    if args.check:
        print(f"{args.page}: the reference is stale (python -m tests.api_reference)")
        return 1
    args.page.write_text(new, encoding="utf-8")
    print(f"{args.page}: reference regenerated")
    return 0


if __name__ == "__main__":
    sys.exit(main())
