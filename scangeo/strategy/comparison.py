"""Compare adjustment strategies on one project: every variant adjusted, summarised against a reference.

:func:`compare_project` runs every variant of a variants file (``scangeo.adjustment.results.
run_variant``), writes each one's results to ``PROJECT/results/NAME/`` and gathers, per variant,
its type, control configuration, maximum correction degree, sigma0 and accounting, and per strip
the check-point rms along track (lines = pixels along track) and across track (pixels), each also
in % of the reference variant (SE, 100 %). On a simulated project it adds the true error of each
variant's orientation (:mod:`scangeo.truth.true_error`). :mod:`scangeo.reports.tables` writes the
result as Markdown, CSV and JSON.
"""
from __future__ import annotations

import logging
import math
from pathlib import Path

from scangeo.adjustment.block import CONTROL_COMPONENTS, strips_read_once
from scangeo.adjustment.ground import DtmHeights
from scangeo.adjustment.outputs import write_results
from scangeo.adjustment.results import VariantResult, run_variant
from scangeo.adjustment.summary import Comparison, VariantSummary
from scangeo.adjustment.variants import read_variants
from scangeo.errors import DTMError, InputFileError, ProjectFileError, ScangeoError
from scangeo.io.project import Project
from scangeo.progress import ProgressCallback, no_progress, scaled
from scangeo.reports.correlations import correlated_pairs
from scangeo.strategy.crossvalidation import VariantRunner, cross_validate, held_out_residuals
from scangeo.strategy.default_variants import ensure_variants_file
from scangeo.strategy.evidence import Residuals
from scangeo.truth.true_error import Truth

log = logging.getLogger(__name__)

#: Role -> the coordinates a control point gives (labels of the control configuration).
CONTROL_KIND = {"control": "XYZ", "planimetric": "XY", "height": "Z"}


def _num(x) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def summarise(result: VariantResult, truth: Truth | None = None) -> VariantSummary:
    """The figures of one adjusted variant (and its true error when ``truth`` is given)."""
    block, adj = result.block, result.adjustment
    measured = {str(p) for p in block.points.point}
    control: dict[str, int] = {}
    for p in measured:
        role = block.role(p)
        if role in CONTROL_COMPONENTS:
            control[CONTROL_KIND[role]] = control.get(CONTROL_KIND[role], 0) + 1
    dtm = sum(g.n_rows for g in adj.solution.groups if isinstance(g, DtmHeights))
    degrees = [max(m.position_degree, m.attitude_degree) for m in block.models]
    strips = {}
    for sid, e in result.rms_per_strip().items():
        entry = {}
        for kind in ("control", "check"):
            r = e[kind]
            entry[kind] = {"n": r["n"], "rms_along_px": _num(r["rms_along_lines"]),
                           "rms_across_px": _num(r["rms_across_px"])}
        if truth is not None:
            error = truth.error(sid, result.geometry(sid)).as_dict()
            entry["true"] = {k: _num(v) if k != "n" else v for k, v in error.items()}
        strips[sid] = entry
    v = result.variant
    return VariantSummary(
        v.name, v.strategy, v.description, control, int(dtm), max(degrees) if degrees else None,
        _num(adj.statistics.sigma0), adj.statistics.accounting.as_dict(), len(adj.rejections),
        len(adj.solution.regularisation), bool(adj.solution.converged), round(result.seconds, 2), strips,
        correlations=correlated_pairs(result))


@strips_read_once()  # its variants and folds read each trajectory once
def compare_project(project_root, variants_file=None, *, reference: str = "SE", names: list[str] | None = None,
                    problem_strip: str | None = None, breaks_lines: tuple[float, ...] | None = None,
                    folds: int = 4, callback: ProgressCallback = no_progress,
                    runner: VariantRunner = run_variant) -> Comparison:
    """Adjust every variant of the project, write each one's results, and compare them.

    Parameters
    ----------
    project_root : the project folder.
    variants_file : the variants (default ``PROJECT/variants.toml``; when it does not exist, the default
        variants ``scangeo/data/variants.toml`` filled in with ``problem_strip`` and ``breaks_lines`` or, without
        them, with the problem strips and breaks the diagnosis finds (``scangeo diagnose``; a simulation's
        truth is never used to build variants, only for the true-error table)).
    reference : the variant that is 100 % (when the file has no such variant: its first, e.g. an imported
        project's PARGE).
    names : the variants to run (default all, in the file's order).
    folds : folds of the cross-validation over the control points, which with the check points recommends
        a variant (:mod:`scangeo.strategy.crossvalidation`, :mod:`scangeo.strategy.evidence`; 0: none).
    callback : progress ``callback(done, total, message)``.
    runner : adjusts one variant, as :func:`~scangeo.adjustment.results.run_variant` (the default) does;
        a platform with a laser scanner hands in its joint adjustment
        (:class:`scangeo.strategy.platform.JointRunner`). A variant it raises a
        :class:`~scangeo.errors.ScangeoError` for (not an input file's) is a failed variant with that error.
    """
    project = Project.from_user_input(project_root)
    root = project.root
    if variants_file is None:
        path = ensure_variants_file(root, problem_strip, breaks_lines, callback=callback)
    else:
        path = Path(variants_file)
        if not path.exists():
            raise ProjectFileError(f"{path}: no such variants file")
    variants = read_variants(path)
    chosen = list(variants) if names is None else list(names)
    for n in chosen:
        if n not in variants:
            raise ProjectFileError(f"{path}: no variant {n!r} (variants: {', '.join(variants)})")
    callback(0, len(chosen), "reading the truth" if (root / "truth").exists() else "comparing")
    truth = Truth.load(project)
    summaries = []
    checks: dict[str, Residuals] = {}  # the check points' residuals per variant: evidence for the recommendation
    for i, name in enumerate(chosen):
        sub = scaled(callback, i, i + 1, len(chosen))
        try:
            result = runner(project, variants[name], path,
                                 lambda d, t, m="", sub=sub, name=name: sub(d, t, f"{name}: {m}"))
            write_results(result)
            summaries.append(summarise(result, truth))
            checks[name] = held_out_residuals(result, sorted({str(p) for p in result.checks.point}))
        except (InputFileError, DTMError):
            raise  # a defect of the project's files fails every variant alike: stop with its message
        except ScangeoError as exc:
            log.warning("variant %s failed: %s", name, exc)
            summaries.append(VariantSummary(name, variants[name].strategy, variants[name].description, error=str(exc)))
        callback(i + 1, len(chosen), f"{name}: done")
    if reference not in chosen:
        reference = chosen[0]
    comparison = Comparison(str(root), str(path), reference, [s.id for s in project.image_strips], summaries,
                            truth is not None)
    if folds >= 2:
        cv = cross_validate(root, variants, summaries, folds, path, callback, checks, runner)
        comparison.crossvalidation = cv.as_dict()
        log.info("recommended: %s (%s)", cv.recommended, cv.reason)
    return comparison


__all__ = ["CONTROL_KIND", "compare_project", "summarise"]
