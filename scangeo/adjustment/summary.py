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
    """All variants of a project, their figures and the reference they are measured against.

    Parameters
    ----------
    project : str
        The project folder.
    variants_file : str
        The variants file compared.
    reference : str
        The reference variant (100 %).
    strips : list of str
        The project's strips.
    variants : list of VariantSummary
        Per variant: sigma0, accounting, per strip the control and check-point rms along track (lines)
        and across track (pixels), rejections, or the error that stopped it.
    truth : bool
        The true errors of a simulation are in the summaries.
    crossvalidation : dict or None
        The cross-validation over the control points (folds, rms per variant, the recommendation).
    """

    project: str
    variants_file: str
    reference: str
    strips: list[str]
    variants: list[VariantSummary]
    truth: bool = False
    crossvalidation: dict | None = None

    def variant(self, name: str) -> VariantSummary:
        """One variant's summary.

        Parameters
        ----------
        name : str
            The variant's name.

        Returns
        -------
        VariantSummary
            Its figures.

        Raises
        ------
        KeyError
            No such variant in the comparison.
        """
        for v in self.variants:
            if v.name == name:
                return v
        raise KeyError(name)

    @property
    def best(self) -> str | None:
        """The variant other than the reference with the lowest pooled check-point rms.

        Returns
        -------
        str or None
            Its name; None without check points.
        """
        cands = [(v.check_pooled_rms(), v.name) for v in self.variants
                 if v.name != self.reference and v.error is None and v.check_pooled_rms() is not None]
        return min(cands)[1] if cands else None

    def reference_summary(self) -> VariantSummary | None:
        """The reference variant's summary.

        Returns
        -------
        VariantSummary or None
            None when it is missing or failed.
        """
        for v in self.variants:
            if v.name == self.reference and v.error is None:
                return v
        return None

    def sigma0_percent(self, v: VariantSummary) -> float | None:
        """A variant's sigma0 in % of the reference's (the paper's ratio: P/S carry DTM heights the
        reference does not).

        Parameters
        ----------
        v : VariantSummary
            The variant.

        Returns
        -------
        float or None
            Percent; None without a reference.
        """
        ref = self.reference_summary()
        return percent(v.sigma0, ref.sigma0 if ref else None)

    def dtm_reference(self) -> VariantSummary | None:
        """The reference with the DTM heights (``SE_DTM`` for reference ``SE``).

        Returns
        -------
        VariantSummary or None
            None when it did not run or failed.
        """
        for v in self.variants:
            if v.name == f"{self.reference}_DTM" and v.error is None:
                return v
        return None

    def sigma0_identical_percent(self, v: VariantSummary) -> float | None:
        """A variant's sigma0 in % of the reference run on the same observations (``SE_DTM``).

        Parameters
        ----------
        v : VariantSummary
            A variant with DTM heights.

        Returns
        -------
        float or None
            Percent; None when the variant has no DTM heights or other ones than ``SE_DTM``.
        """
        ref = self.dtm_reference()
        if ref is None or not v.dtm_heights or v.dtm_heights != ref.dtm_heights:
            return None
        return percent(v.sigma0, ref.sigma0)

    @property
    def recommended(self) -> str | None:
        """The variant the cross-validation, the check points and the information criterion recommend
        (crossvalidation.py, evidence.py).

        Returns
        -------
        str or None
            Its name; None without a cross-validation.
        """
        return (self.crossvalidation or {}).get("recommended")

    def check_percent(self, v: VariantSummary, strip: str, key: str) -> float | None:
        """A strip's check-point rms in % of the reference's.

        Parameters
        ----------
        v : VariantSummary
            The variant.
        strip : str
            The strip's id.
        key : str
            ``along`` (track, lines) or ``across`` (track, pixels).

        Returns
        -------
        float or None
            Percent; None without check points there or without a reference.
        """
        ref = self.reference_summary()
        mine = v.strips.get(strip, {}).get("check", {}).get(f"rms_{key}_px")
        theirs = ref.strips.get(strip, {}).get("check", {}).get(f"rms_{key}_px") if ref else None
        return percent(mine, theirs)

    def as_dict(self) -> dict:
        """What ``comparison.json`` holds.

        Returns
        -------
        dict
            JSON-able: every figure, with the percentages of the reference filled in.
        """
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
        """A comparison read back from what :meth:`as_dict` gave (``comparison.json``).

        Parameters
        ----------
        d : dict
            The parsed JSON.

        Returns
        -------
        Comparison
            The comparison.
        """
        return cls(d["project"], d["variants_file"], d["reference"], list(d["strips"]),
                   [VariantSummary.from_dict(v) for v in d["variants"]], bool(d.get("truth")), d.get("crossvalidation"))
