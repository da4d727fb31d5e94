"""The default variants of a comparison: ``scangeo/data/variants.toml`` filled in for one project.

The data file holds the strategies of DESIGN section 7 (DG, BE, SE, P2, P4, S2, S4) with two
placeholders for facts of the project: ``"@PROBLEM_STRIP@"`` (the strip whose GPS/IMU needs more
than a constant correction) and ``"@BREAKS_LINES@"`` (the image lines of that strip where its error
changes course). For a simulated project both come from ``truth/errors.json``; otherwise the user
names them. The filled-in text is written to ``PROJECT/variants.toml``, where ``scangeo adjust``
and ``scangeo compare`` find it.
"""
from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from pathlib import Path

from scangeo.errors import ProjectFileError
from scangeo.resources import DEFAULT_VARIANTS

log = logging.getLogger(__name__)

PROBLEM_STRIP = '"@PROBLEM_STRIP@"'
BREAKS_LINES = '"@BREAKS_LINES@"'


@dataclass(frozen=True)
class ProblemStrip:
    """The strip that needs a polynomial or split correction, and its break lines (0-based image lines)."""

    strip: str
    breaks_lines: tuple[float, ...]
    source: str = ""


def problem_strip_from_truth(project_root) -> ProblemStrip | None:
    """The problem strip and break lines a simulation recorded in ``truth/errors.json`` (None without)."""
    path = Path(project_root) / "truth" / "errors.json"
    if not path.exists():
        return None
    try:
        info = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ProjectFileError(f"{path}: cannot read ({exc})") from exc
    strip, breaks = info.get("problem_strip"), info.get("breaks_lines") or []
    if not strip:
        return None
    if not isinstance(breaks, list) or not all(isinstance(b, (int, float)) for b in breaks):
        raise ProjectFileError(f"{path}: breaks_lines: expected a list of line numbers, found {breaks!r}")
    return ProblemStrip(str(strip), tuple(float(b) for b in breaks), str(path))


def render_default_variants(problem: ProblemStrip, template: Path | Traversable = DEFAULT_VARIANTS) -> str:
    """The text of the default variants file with the placeholders filled in."""
    if not problem.breaks_lines:
        raise ProjectFileError(f"{template}: the split variants need break lines of strip {problem.strip} "
                               "(none given)")
    text = template.read_text(encoding="utf-8")
    breaks = "[" + ", ".join(repr(float(b)) for b in problem.breaks_lines) + "]"
    header = (f"# Filled in for this project: problem strip {problem.strip}, breaks at lines "
              f"{', '.join(f'{b:g}' for b in problem.breaks_lines)}"
              + (f" (from {problem.source})" if problem.source else "") + "\n")
    return header + text.replace(PROBLEM_STRIP, json.dumps(problem.strip)).replace(BREAKS_LINES, breaks)


def _check_strip(root: Path, problem: ProblemStrip) -> None:
    from scangeo.io.project import Project

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


def ensure_variants_file(project_root, problem_strip: str | None = None,
                         breaks_lines: tuple[float, ...] | None = None) -> Path:
    """``PROJECT/variants.toml``: kept when it exists, else the defaults filled in and written.

    The problem strip and its breaks come from the arguments, else from ``truth/errors.json``;
    without either, a clear error says what to give.
    """
    root = Path(project_root)
    path = root / "variants.toml"
    if path.exists():
        if problem_strip is not None or breaks_lines is not None:
            log.warning("%s exists: --problem-strip/--breaks-lines are not used", path)
        return path
    if problem_strip is None:
        problem = problem_strip_from_truth(root)
        if problem is None:
            raise ProjectFileError(
                f"{path}: no variants file; the default variants ({DEFAULT_VARIANTS}) need the problem strip and "
                "its break lines: give --problem-strip ID --breaks-lines L1 L2, or copy the file, edit it and "
                "pass it with --variants")
        if breaks_lines is not None:
            problem = ProblemStrip(problem.strip, tuple(breaks_lines), "the command line")
    else:
        problem = ProblemStrip(str(problem_strip), tuple(breaks_lines or ()), "the command line")
    _check_strip(root, problem)
    text = render_default_variants(problem)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
    log.info("wrote the default variants to %s (problem strip %s)", path, problem.strip)
    return path


__all__ = ["DEFAULT_VARIANTS", "ProblemStrip", "ensure_variants_file", "problem_strip_from_truth",
           "render_default_variants"]
