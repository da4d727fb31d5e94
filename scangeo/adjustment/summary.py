"""What a comparison of variants shows: per variant its figures (:class:`VariantSummary`), and all
variants against a reference (:class:`Comparison`), with the JSON round trip.

:func:`scangeo.strategy.comparison.compare_project` fills them; :mod:`scangeo.reports` renders them
(tables, the HTML report) and reads them back from ``results/comparison.json``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any


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
