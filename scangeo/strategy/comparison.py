"""Compare adjustment strategies on one project: every variant adjusted, summarised against a reference.

:func:`compare_project` runs every variant of a variants file (``scangeo.adjustment.results.
run_variant``), writes each one's results to ``PROJECT/results/NAME/`` and gathers, per variant,
its type, control configuration, maximum correction degree, sigma0 and accounting, and per strip
the check-point rms along track (lines = pixels along track) and across track (pixels), each also
in % of the reference variant (SE, 100 %). On a simulated project it adds the true error of each
variant's orientation (:mod:`scangeo.reports.true_error`). :mod:`scangeo.reports.tables` writes the
result as Markdown, CSV and JSON.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scangeo.adjustment.block import CONTROL_COMPONENTS
from scangeo.adjustment.ground import DtmHeights
from scangeo.adjustment.results import VariantResult
from scangeo.errors import DTMError, InputFileError, ProjectFileError, ScangeoError
from scangeo.progress import ProgressCallback, no_progress, scaled
from scangeo.reports.true_error import Truth

log = logging.getLogger(__name__)

#: Role -> the coordinates a control point gives (labels of the control configuration).
CONTROL_KIND = {"control": "XYZ", "planimetric": "XY", "height": "Z"}


def _num(x) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def percent(value: float | None, reference: float | None) -> float | None:
    """``100 value / reference`` (None when either is missing or the reference is 0)."""
    if value is None or reference is None or reference == 0:
        return None
    return 100.0 * value / reference


@dataclass
class VariantSummary:
    """What the comparison table shows of one variant (``error`` set when its adjustment failed)."""

    name: str
    strategy: str
    description: str = ""
    control: dict[str, int] = field(default_factory=dict)
    dtm_heights: int = 0
    max_degree: int | None = None
    sigma0: float | None = None
    accounting: dict = field(default_factory=dict)
    rejected: int = 0
    regularised: int = 0
    converged: bool = True
    seconds: float = 0.0
    strips: dict[str, dict] = field(default_factory=dict)
    error: str | None = None
    correlations: list[dict] = field(default_factory=list)

    @property
    def control_label(self) -> str:
        """E.g. ``30 XYZ + 18 Z`` (the control points the adjustment used, by what they give)."""
        parts = [f"{self.control[k]} {k}" for k in ("XYZ", "XY", "Z") if self.control.get(k)]
        return " + ".join(parts) if parts else "none"

    def check_pooled_rms(self) -> float | None:
        """rms over all check-point measurements of all strips, along and across together (pixels)."""
        total, n = 0.0, 0
        for e in self.strips.values():
            c = e.get("check", {})
            if c.get("n"):
                total += c["n"] * (c["rms_along_px"] ** 2 + c["rms_across_px"] ** 2)
                n += 2 * c["n"]
        return math.sqrt(total / n) if n else None

    def as_dict(self) -> dict:
        return {"name": self.name, "strategy": self.strategy, "description": self.description,
                "control": dict(self.control), "control_label": self.control_label, "dtm_heights": self.dtm_heights,
                "max_degree": self.max_degree, "sigma0": self.sigma0, "accounting": self.accounting,
                "rejected": self.rejected, "regularised": self.regularised, "converged": self.converged,
                "seconds": self.seconds, "strips": self.strips, "error": self.error, "correlations": self.correlations}

    @classmethod
    def from_dict(cls, d: dict) -> VariantSummary:
        keys = ("name", "strategy", "description", "control", "dtm_heights", "max_degree", "sigma0", "accounting",
                "rejected", "regularised", "converged", "seconds", "strips", "error", "correlations")
        return cls(**{k: d[k] for k in keys if k in d})


@dataclass
class Comparison:
    """All variants of a project, their figures and the reference they are measured against."""

    project: str
    variants_file: str
    reference: str
    strips: list[str]
    variants: list[VariantSummary]
    truth: bool = False
    crossvalidation: dict | None = None

    def variant(self, name: str) -> VariantSummary:
        for v in self.variants:
            if v.name == name:
                return v
        raise KeyError(name)

    @property
    def best(self) -> str | None:
        """The variant other than the reference with the lowest pooled check-point rms."""
        cands = [(v.check_pooled_rms(), v.name) for v in self.variants
                 if v.name != self.reference and v.error is None and v.check_pooled_rms() is not None]
        return min(cands)[1] if cands else None

    def reference_summary(self) -> VariantSummary | None:
        """The reference variant's summary (None when it is missing or failed)."""
        for v in self.variants:
            if v.name == self.reference and v.error is None:
                return v
        return None

    def sigma0_percent(self, v: VariantSummary) -> float | None:
        """sigma0 in % of the reference's (the paper's ratio: P/S carry DTM heights the reference does not)."""
        ref = self.reference_summary()
        return percent(v.sigma0, ref.sigma0 if ref else None)

    def dtm_reference(self) -> VariantSummary | None:
        """The reference with the DTM heights (``SE_DTM`` for reference ``SE``), when it ran."""
        for v in self.variants:
            if v.name == f"{self.reference}_DTM" and v.error is None:
                return v
        return None

    def sigma0_identical_percent(self, v: VariantSummary) -> float | None:
        """sigma0 in % of the reference run with the same DTM heights (``SE_DTM``), for variants with DTM heights."""
        ref = self.dtm_reference()
        if ref is None or not v.dtm_heights or v.dtm_heights != ref.dtm_heights:
            return None
        return percent(v.sigma0, ref.sigma0)

    @property
    def recommended(self) -> str | None:
        """The variant the cross-validation and the information criterion recommend (crossvalidation.py)."""
        return (self.crossvalidation or {}).get("recommended")

    def check_percent(self, v: VariantSummary, strip: str, key: str) -> float | None:
        """Check-point rms ``key`` (``along`` or ``across``) of a strip in % of the reference's."""
        ref = self.reference_summary()
        mine = v.strips.get(strip, {}).get("check", {}).get(f"rms_{key}_px")
        theirs = ref.strips.get(strip, {}).get("check", {}).get(f"rms_{key}_px") if ref else None
        return percent(mine, theirs)

    def as_dict(self) -> dict:
        """Everything, with the percentages of the reference filled in (the JSON of the comparison)."""
        out: dict[str, Any] = {
            "project": self.project, "variants_file": self.variants_file, "reference": self.reference,
            "best": self.best, "recommended": self.recommended, "strips": self.strips, "truth": self.truth,
            "crossvalidation": self.crossvalidation, "variants": []}
        for v in self.variants:
            d = v.as_dict()
            d["sigma0_percent"] = self.sigma0_percent(v)
            d["sigma0_identical_percent"] = self.sigma0_identical_percent(v)
            d["strips"] = {sid: {k: dict(x) for k, x in e.items()} for sid, e in v.strips.items()}
            for sid, e in d["strips"].items():
                for key in ("along", "across"):
                    e.setdefault("check", {})[f"{key}_percent"] = self.check_percent(v, sid, key)
            out["variants"].append(d)
        return out

    @classmethod
    def from_dict(cls, d: dict) -> Comparison:
        return cls(d["project"], d["variants_file"], d["reference"], list(d["strips"]),
                   [VariantSummary.from_dict(v) for v in d["variants"]], bool(d.get("truth")), d.get("crossvalidation"))


def summarise(result: VariantResult, truth: Truth | None = None) -> VariantSummary:
    """The figures of one adjusted variant (and its true error when ``truth`` is given)."""
    from scangeo.reports.correlations import correlated_pairs

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


def compare_project(project_root, variants_file=None, *, reference: str = "SE", names: list[str] | None = None,
                    problem_strip: str | None = None, breaks_lines: tuple[float, ...] | None = None,
                    folds: int = 4, callback: ProgressCallback = no_progress) -> Comparison:
    """Adjust every variant of the project, write each one's results, and compare them.

    Parameters
    ----------
    project_root : the project folder.
    variants_file : the variants (default ``PROJECT/variants.toml``; when it does not exist, the default
        variants ``scangeo/data/variants.toml`` filled in with ``problem_strip`` and ``breaks_lines`` or, without
        them, with the problem strips and breaks the diagnosis finds (``scangeo diagnose``; a simulation's
        truth is never used to build variants, only for the true-error table)).
    reference : the variant that is 100 %.
    names : the variants to run (default all, in the file's order).
    folds : folds of the cross-validation over the control points that recommends a variant without
        check points (:mod:`scangeo.strategy.crossvalidation`; 0: none).
    callback : progress ``callback(done, total, message)``.
    """
    from scangeo.adjustment.outputs import write_results
    from scangeo.adjustment.results import run_variant
    from scangeo.adjustment.variants import read_variants
    from scangeo.io.project import Project
    from scangeo.strategy.default_variants import ensure_variants_file

    root = Path(project_root)
    project = Project.load(root)
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
    for i, name in enumerate(chosen):
        sub = scaled(callback, i, i + 1, len(chosen))
        try:
            result = run_variant(root, variants[name], path,
                                 lambda d, t, m="", sub=sub, name=name: sub(d, t, f"{name}: {m}"))
            write_results(result)
            summaries.append(summarise(result, truth))
        except (InputFileError, DTMError):
            raise  # a defect of the project's files fails every variant alike: stop with its message
        except ScangeoError as exc:
            log.warning("variant %s failed: %s", name, exc)
            summaries.append(VariantSummary(name, variants[name].strategy, variants[name].description, error=str(exc)))
        callback(i + 1, len(chosen), f"{name}: done")
    comparison = Comparison(str(root), str(path), reference, [s.id for s in project.strips], summaries,
                            truth is not None)
    if folds >= 2:
        from scangeo.strategy.crossvalidation import cross_validate

        cv = cross_validate(root, variants, summaries, folds, path, callback)
        comparison.crossvalidation = cv.as_dict()
        log.info("recommended: %s (%s)", cv.recommended, cv.reason)
    return comparison


__all__ = ["CONTROL_KIND", "Comparison", "VariantSummary", "compare_project", "percent", "summarise"]
