"""The default variants of a comparison: ``scangeo/data/variants.toml`` filled in for one project.

The data file holds the strategies of the paper's set-up (DG, BE, SE, SE_DTM, P2, P4, S2, S4;
docs/reports.md) with two placeholders for facts of the project: ``"@PROBLEM_STRIP@"`` (a strip whose
GPS/IMU needs more than a constant correction) and ``"@BREAKS_LINES@"`` (the image lines of that strip
where its error changes course). A ``[[variants.NAME.strip]]`` table with the placeholder is repeated
for every problem strip; without a problem strip the P and S variants are left out. The problem strips
come from the diagnosis (:func:`scangeo.adjustment.diagnosis.diagnose.diagnose`) or from the user; never from a
simulation's truth. The filled-in text is written to ``PROJECT/variants.toml``, where ``scangeo adjust``
and ``scangeo compare`` find it.
"""
from __future__ import annotations

import json
import logging
import re
from collections.abc import Sequence
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from pathlib import Path

from scangeo.adjustment.diagnosis.diagnose import diagnose
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


def render_default_variants(problems: Sequence[ProblemStrip] | ProblemStrip,
                            template: Path | Traversable = DEFAULT_VARIANTS, header: str = "") -> str:
    """The text of the default variants file for these problem strips (module docstring)."""
    if isinstance(problems, ProblemStrip):
        problems = [problems]
    out = []
    dropped: set[str] = set()
    for sec in _sections(template.read_text(encoding="utf-8")):
        head = sec.split("\n", 1)[0].strip()
        m = re.fullmatch(r"\[variants\.([A-Za-z0-9_-]+)\]", head)
        if m and not problems and re.search(r'^strategy\s*=\s*"[PS]"', sec, flags=re.M):
            dropped.add(m.group(1))
            continue
        m = re.fullmatch(r"\[\[variants\.([A-Za-z0-9_-]+)\.strip\]\]", head)
        if m and PROBLEM_STRIP in sec:
            if m.group(1) in dropped:
                continue
            for p in problems:
                breaks = "[" + ", ".join(repr(float(b)) for b in p.breaks_lines) + "]"
                out.append(sec.replace(PROBLEM_STRIP, json.dumps(p.strip)).replace(BREAKS_LINES, breaks))
            continue
        out.append(sec)
    if problems:
        facts = "; ".join(f"strip {p.strip} breaks at lines {', '.join(f'{b:g}' for b in p.breaks_lines) or 'none'}"
                          + (f" (from {p.source})" if p.source else "") for p in problems)
        header += f"# Filled in for this project: problem strips: {facts}\n"
    else:
        header += "# Filled in for this project: no problem strip, so no P or S variant\n"
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


def write_variants_file(project_root, problems: Sequence[ProblemStrip], header: str = "") -> Path:
    """Fill in the default variants for ``problems`` and write ``PROJECT/variants.toml`` (checked first)."""
    root = Path(project_root)
    for p in problems:
        _check_strip(root, p)
    path = root / "variants.toml"
    write_text(path, render_default_variants(problems, header=header))
    log.info("wrote the default variants to %s (problem strips: %s)", path,
             ", ".join(p.strip for p in problems) or "none")
    return path


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
        problems = [ProblemStrip(s, diagnosis.breaks_of(s), "scangeo diagnose") for s in diagnosis.problem_strips]
        return write_variants_file(root, problems)
    problem = ProblemStrip(str(problem_strip), tuple(breaks_lines or ()), "problem_strip, breaks_lines")
    return write_variants_file(root, [problem])


def _holds(path: Path, problem: ProblemStrip) -> bool:
    """Whether the variants file is the default variants filled in for ``problem`` (comments aside)."""
    def body(text: str) -> list[str]:
        return [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]

    return body(path.read_text(encoding="utf-8")) == body(render_default_variants([problem]))


__all__ = ["DEFAULT_VARIANTS", "ProblemStrip", "ensure_variants_file", "render_default_variants",
           "write_variants_file"]
