"""The default variants of a comparison: ``scangeo/data/variants.toml`` filled in for one project.

The data file holds the strategies of the paper's set-up (DG, BE, SE, SE_DTM, P2, P4, S2, S4;
docs/reports.md) with two placeholders for facts of the project: ``"@PROBLEM_STRIP@"`` (a strip whose
GPS/IMU needs more than a constant correction) and ``"@BREAKS_LINES@"`` (the image lines of that strip
where its error changes course). A ``[[variants.NAME.strip]]`` table with the placeholder is repeated
for every problem strip; without a problem strip the P and S variants are left out. The problem strips
come from the diagnosis (:func:`scangeo.adjustment.diagnosis.diagnose.diagnose`) or from the user; never from a
simulation's truth. The filled-in text is written to ``PROJECT/variants.toml``, where ``scangeo adjust``
and ``scangeo compare`` find it.

When the diagnosis calls its attribution ambiguous (:mod:`scangeo.adjustment.diagnosis.attribution`),
every plausible other attribution gets its own P and S variants beside the chosen one's, named with its
strips as a suffix (``S4-03``: the drift on strip 03; ``S4-02-03``: split between 02 and 03), so that
the comparison's evidence decides between them.
"""
from __future__ import annotations

import json
import logging
import re
from collections.abc import Sequence
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from pathlib import Path

from scangeo.adjustment.diagnosis.diagnose import Diagnosis, diagnose
from scangeo.adjustment.diagnosis.output import write_diagnosis
from scangeo.atomic import write_text
from scangeo.errors import ArgumentError, ProjectFileError
from scangeo.io.project import Project
from scangeo.progress import ProgressCallback, no_progress
from scangeo.resources import DEFAULT_VARIANTS

log = logging.getLogger(__name__)

PROBLEM_STRIP = '"@PROBLEM_STRIP@"'
BREAKS_LINES = '"@BREAKS_LINES@"'


@dataclass(frozen=True)
class ProblemStrip:
    """A strip that needs a polynomial or split correction, and its break lines (0-based image lines)."""

    strip: str
    breaks_lines: tuple[float, ...]
    source: str = ""


def _sections(text: str) -> list[str]:
    """The text cut before every line that opens a table (``[...]`` at the start of a line)."""
    cuts = [m.start() for m in re.finditer(r"^\[", text, flags=re.M)]
    bounds = [0] + cuts + [len(text)]
    return [text[i:j] for i, j in zip(bounds[:-1], bounds[1:]) if j > i]


def _facts(problems: Sequence[ProblemStrip]) -> str:
    return "; ".join(f"strip {p.strip} breaks at lines {', '.join(f'{b:g}' for b in p.breaks_lines) or 'none'}"
                     + (f" (from {p.source})" if p.source else "") for p in problems)


def _blocks(text: str) -> list[tuple[str | None, list[str]]]:
    """The template's sections grouped by variant: (name, [its table, its strip tables]); None for others."""
    blocks: list[tuple[str | None, list[str]]] = []
    for sec in _sections(text):
        head = sec.split("\n", 1)[0].strip()
        m = re.fullmatch(r"\[variants\.([A-Za-z0-9_-]+)\]", head)
        s = re.fullmatch(r"\[\[variants\.([A-Za-z0-9_-]+)\.strip\]\]", head)
        if m:
            blocks.append((m.group(1), [sec]))
        elif s and blocks and blocks[-1][0] == s.group(1):
            blocks[-1][1].append(sec)
        else:
            blocks.append((None, [sec]))
    return blocks


def _variant_text(name: str, sections: list[str], problems: Sequence[ProblemStrip], suffix: str = "",
                  note: str = "") -> str:
    """One variant's tables with the problem strips filled in (renamed ``NAME-suffix`` with a suffix)."""
    out = []
    for sec in sections:
        if suffix:
            sec = sec.replace(f"variants.{name}]", f"variants.{name}-{suffix}]", 1)
            sec = sec.replace(f"variants.{name}.strip]]", f"variants.{name}-{suffix}.strip]]", 1)
            if note:
                sec = re.sub(r'^(description\s*=\s*")(.*)"', lambda m: f'{m.group(1)}{m.group(2)} ({note})"', sec,
                             count=1, flags=re.M)
        if PROBLEM_STRIP in sec:
            for p in problems:
                breaks = "[" + ", ".join(repr(float(b)) for b in p.breaks_lines) + "]"
                out.append(sec.replace(PROBLEM_STRIP, json.dumps(p.strip)).replace(BREAKS_LINES, breaks))
            continue
        out.append(sec)
    return "".join(out)


def render_default_variants(problems: Sequence[ProblemStrip] | ProblemStrip,
                            template: Path | Traversable = DEFAULT_VARIANTS, header: str = "",
                            alternatives: Sequence[tuple[str, Sequence[ProblemStrip]]] = ()) -> str:
    """The text of the default variants file for these problem strips (module docstring); ``alternatives``:
    other attributions (suffix, their problem strips), each with its own P and S variants."""
    if isinstance(problems, ProblemStrip):
        problems = [problems]
    out = []
    for name, sections in _blocks(template.read_text(encoding="utf-8")):
        corrected = name is not None and bool(re.search(r'^strategy\s*=\s*"[PS]"', sections[0], flags=re.M))
        if not corrected:
            out.append("".join(sections))
            continue
        if problems:
            out.append(_variant_text(name, sections, problems))  # type: ignore[arg-type]
        for suffix, alt in alternatives:
            out.append(_variant_text(name, sections, alt, suffix,  # type: ignore[arg-type]
                                     f"another attribution: {_facts(alt)}"))
    if problems:
        header += f"# Filled in for this project: problem strips: {_facts(problems)}\n"
    else:
        header += "# Filled in for this project: no problem strip, so no P or S variant\n"
    for suffix, alt in alternatives:
        header += f"# Variants NAME-{suffix}: the plausible other attribution {_facts(alt)}\n"
    return header + "".join(out)


def _check_strip(root: Path, problem: ProblemStrip) -> None:
    project = Project.load(root)
    ids = [s.id for s in project.strips]
    if problem.strip not in ids:
        raise ProjectFileError(f"{problem.source or 'problem strip'}: strip {problem.strip!r} is not in "
                               f"{root / 'project.toml'} (strips: {', '.join(ids)})")
    n = project.n_lines(problem.strip)
    bad = [b for b in problem.breaks_lines if not 0 < b < n - 1]
    if bad:
        raise ProjectFileError(f"{problem.source or 'breaks'}: break line {bad[0]:g} is not inside strip "
                               f"{problem.strip} (lines 0..{n - 1})")


def write_variants_file(project_root, problems: Sequence[ProblemStrip], header: str = "",
                        alternatives: Sequence[tuple[str, Sequence[ProblemStrip]]] = ()) -> Path:
    """Fill in the default variants for ``problems`` (and ``alternatives``, :func:`render_default_variants`) and
    write ``PROJECT/variants.toml`` (checked first)."""
    root = Path(project_root)
    for p in [*problems, *(q for _, alt in alternatives for q in alt)]:
        _check_strip(root, p)
    path = root / "variants.toml"
    write_text(path, render_default_variants(problems, header=header, alternatives=alternatives))
    log.info("wrote the default variants to %s (problem strips: %s%s)", path,
             ", ".join(p.strip for p in problems) or "none",
             "".join(f"; other attribution {s}" for s, _ in alternatives))
    return path


def attributions(diagnosis: Diagnosis, source: str
                 ) -> tuple[list[ProblemStrip], list[tuple[str, list[ProblemStrip]]]]:
    """The diagnosis's problem strips, and every plausible other attribution (suffix, its problem strips)."""
    problems = [ProblemStrip(s, diagnosis.breaks_of(s), source) for s in diagnosis.problem_strips]
    alternatives: list[tuple[str, list[ProblemStrip]]] = []
    for a in diagnosis.plausible():
        alt = [ProblemStrip(s, tuple(b)) for s, b in a.breaks.items() if b]
        if alt and a.label not in {x for x, _ in alternatives}:
            alternatives.append((a.label, alt))
    return problems, alternatives


def write_diagnosed_variants(project_root, diagnosis: Diagnosis, source: str, header: str = "") -> Path:
    """``PROJECT/variants.toml`` for a diagnosis: its problem strips and its plausible other attributions."""
    problems, alternatives = attributions(diagnosis, source)
    return write_variants_file(project_root, problems, header, alternatives)


def ensure_variants_file(project_root, problem_strip: str | None = None,
                         breaks_lines: tuple[float, ...] | None = None,
                         callback: ProgressCallback = no_progress) -> Path:
    """``PROJECT/variants.toml``: kept when it exists, else the defaults filled in and written.

    The problem strip and its breaks come from the arguments; without them the project is diagnosed
    (:func:`scangeo.adjustment.diagnosis.diagnose.diagnose`; its results go to ``PROJECT/results/diagnosis.*``)
    and every problem strip it finds gets its breaks.
    """
    root = Path(project_root)
    path = root / "variants.toml"
    given = problem_strip is not None or breaks_lines is not None
    if given and problem_strip is None:
        raise ArgumentError("{breaks_lines}: needs the problem strip they belong to",
                            breaks_lines=list(breaks_lines or ()))
    if path.exists():
        if given and not _holds(path, ProblemStrip(str(problem_strip), tuple(breaks_lines or ()))):
            where = str(path).replace("{", "{{").replace("}", "}}")
            raise ArgumentError(where + " exists and holds other variants: {problem_strip} and {breaks_lines} "
                                "fill in the default variants only (remove the file to have them written)",
                                problem_strip=problem_strip, breaks_lines=list(breaks_lines or ()))
        return path
    if problem_strip is None:
        diagnosis = diagnose(root, callback=callback)
        write_diagnosis(diagnosis)
        return write_diagnosed_variants(root, diagnosis, "scangeo diagnose")
    problem = ProblemStrip(str(problem_strip), tuple(breaks_lines or ()), "problem_strip, breaks_lines")
    return write_variants_file(root, [problem])


def _holds(path: Path, problem: ProblemStrip) -> bool:
    """Whether the variants file is the default variants filled in for ``problem`` (comments aside)."""
    def body(text: str) -> list[str]:
        return [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]

    return body(path.read_text(encoding="utf-8")) == body(render_default_variants([problem]))


__all__ = ["DEFAULT_VARIANTS", "ProblemStrip", "attributions", "ensure_variants_file", "render_default_variants",
           "write_diagnosed_variants", "write_variants_file"]
