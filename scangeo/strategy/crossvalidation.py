"""The recommendation: k-fold cross-validation over the control points, AIC, and the check points.

The cross-validation and the information criterion use what the adjustment itself uses:

* **Cross-validation.** The full control points of ``ground.csv`` (role ``control``; height-only
  and planimetric points stay as they are) are dealt into ``k`` folds (sorted by id, every k-th point
  to the same fold, so every fold has points in every control band). Each variant is adjusted ``k``
  times, each time with one fold turned into check points, and the held-out points are projected
  into the images with that orientation: the cross-validated figure is the rms of their residuals,
  along and across together (pixels), over all folds. Points a variant adds as control (``B*`` in
  the 4-band variants) are never held out: they are part of that variant.
* **Information criterion.** ``AIC = v^T P v + 2 u`` of each variant's own adjustment (``u``
  unknowns; ``v^T P v`` the weighted squared residuals, -2 ln L up to a constant with the a priori
  weights). It compares variants only over identical observations (same count and DTM heights): there
  it says whether the richer model's fit pays for its unknowns *in prediction*, which is what the
  recommendation is for: AIC estimates the expected deviance of new observations, and is
  asymptotically the leave-one-out cross-validation (Stone, 1977), the same question the held-out
  control asks, answered from every observation. BIC (``u ln n``) asks which model is true; with ``n``
  every tie point of the block its penalty is ``ln 27,000 = 10.2`` per unknown, and it chose a
  polynomial whose ``v^T P v`` was 89 higher over a split model with 12 more unknowns (vienna2000,
  20 blunders, 4 control points per band, seed 105: P4 at 137 % of S4's true error, where both
  evidences preferred S4 within their noise).

The recommendation weighs the cross-validation together with the check points, each with its noise
(:mod:`~.evidence`): no candidate significantly worse at the check points than another adjusted
variant, then the ones within the noise of the lowest rms over held-out control and check points
together, then among those the lowest AIC within its group of identical observations, then the one
that uses the most control points (the evidence cannot separate them, and an orientation resting on
more ground truth is the safer choice; measured: S4's true error is at or below S2's on 4 of 6
simulated vienna2000 blocks and at most 11 % above it on the other two), then the lowest rms.
DG (GPS/IMU as measured) is cross-validated too: with nothing fitted, its held-out residuals are what the
GPS/IMU and the fixed calibration give, the baseline an adjusted variant must beat (an imported line's
PARGE variant).
"""
from __future__ import annotations

import glob
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from scangeo.adjustment.plausibility import sigma0_warning
from scangeo.adjustment.results import VariantResult, run_variant
from scangeo.adjustment.variants import Variant
from scangeo.errors import ScangeoError
from scangeo.io.points import GroundPoints
from scangeo.progress import ProgressCallback, no_progress
from scangeo.strategy.evidence import Evidence, Residuals, TieBreak, weigh

log = logging.getLogger(__name__)

#: What adjusts one variant: ``runner(project, variant, variants_file, callback) -> VariantResult``
#: (:func:`scangeo.adjustment.results.run_variant`, or a platform's joint adjustment with its laser)
VariantRunner = Callable[..., VariantResult]


@dataclass
class CrossValidation:
    """Cross-validated rms per variant, AIC, and the recommendation."""

    folds: int
    points: int
    rms_px: dict[str, float] = field(default_factory=dict)
    n: dict[str, int] = field(default_factory=dict)
    aic: dict[str, float] = field(default_factory=dict)
    group: dict[str, str] = field(default_factory=dict)
    control: dict[str, int] = field(default_factory=dict)
    recommended: str | None = None
    reason: str = ""
    errors: dict[str, str] = field(default_factory=dict)
    #: sigma0 far above 1 in the recommended variant (:func:`scangeo.adjustment.plausibility.sigma0_warning`)
    warnings: list[str] = field(default_factory=list)
    #: the weighing of the evidence (:class:`scangeo.strategy.evidence.Decision`): margin, each evidence's
    #: choice, their disagreement, the check points' independent measure
    evidence: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"folds": self.folds, "points": self.points, "rms_px": self.rms_px, "n": self.n, "aic": self.aic,
                "group": self.group, "control": self.control, "recommended": self.recommended, "reason": self.reason,
                "errors": self.errors, "warnings": self.warnings, "evidence": self.evidence}

    @classmethod
    def from_dict(cls, d: dict) -> CrossValidation:
        return cls(**{k: d[k] for k in ("folds", "points", "rms_px", "n", "aic", "group", "control", "recommended",
                                        "reason", "errors", "warnings", "evidence") if k in d})


def folds_of(control_ids, k: int) -> list[list[str]]:
    """``k`` folds of the control points: sorted by id, every k-th point into the same fold."""
    ids = sorted(str(p) for p in control_ids)
    return [ids[i::k] for i in range(k) if ids[i::k]]


#: the name of a variant with a fold held out is the variant's with this suffix
HELD_OUT = "-cv"


def held_out(variant: Variant, fold: list[str]) -> Variant:
    """The variant with the fold's points turned into check points (exact ids, glob characters escaped)."""
    extra = tuple((glob.escape(p), "check") for p in fold)
    return replace(variant, name=f"{variant.name}{HELD_OUT}", roles=variant.roles + extra)


def aic_of(summary) -> float | None:
    """``v^T P v + 2 u`` from a variant's summary (sigma0, accounting): ``v^T P v = sigma0^2 r``."""
    a = summary.accounting
    if summary.sigma0 is None or not a:
        return None
    n = a["observations"] + a["pseudo_observations"]
    r = n - a["unknowns"]
    return float(summary.sigma0 ** 2 * r + 2 * a["unknowns"])


def recommend(cv: CrossValidation, summaries, evidence: dict[str, Evidence]) -> None:
    """Fill in ``cv.recommended``, ``cv.reason`` and ``cv.evidence`` (module docstring; :func:`.evidence.weigh`)."""
    ok = [s.name for s in summaries if s.error is None and s.name in cv.rms_px and math.isfinite(cv.rms_px[s.name])]
    if not ok:
        cv.reason = "no variant could be cross-validated"
        return
    decision = weigh(ok, evidence, TieBreak(cv.aic, cv.group, cv.control), cv.folds)
    cv.recommended = decision.recommended
    cv.reason = decision.reason
    cv.evidence = decision.as_dict()


def held_out_residuals(result, fold: list[str]) -> Residuals:
    """The residuals of the fold's points, projected with an orientation adjusted without them."""
    c = result.checks
    sel = np.isin(c.point.astype(str), fold) & (c.status == 0)
    return Residuals(c.point[sel].astype(str), c.strip[sel].astype(str), np.asarray(c.at_line)[sel], c.line[sel],
                     c.pixel[sel])


def cross_validate(project_root, variants: dict[str, Variant], summaries, folds: int = 4, variants_file=None,
                   callback: ProgressCallback = no_progress,
                   checks: dict[str, Residuals] | None = None,
                   runner: VariantRunner = run_variant) -> CrossValidation:
    """Cross-validate every variant of ``summaries`` and recommend one (module docstring); ``folds`` >= 2.
    ``checks``: per adjusted variant, its check-point residuals (the other evidence); ``runner``: what
    adjusts a variant (:data:`VariantRunner`; a platform's joint adjustment with its laser)."""
    root = Path(project_root)
    ground = GroundPoints.read(root / "ground.csv") if (root / "ground.csv").exists() else None
    control = [str(p) for p, r in zip(ground.point, ground.role) if str(r) == "control"] if ground is not None else []
    parts = folds_of(control, max(2, folds))
    cv = CrossValidation(len(parts), len(control))
    names = [s.name for s in summaries if s.error is None]
    evidence = {n: Evidence(check=(checks or {}).get(n, Residuals.empty())) for n in names}
    total = max(1, len(names) * len(parts))
    for i, name in enumerate(names):
        v = variants[name]
        held: list[Residuals] = []
        try:
            for j, fold in enumerate(parts):
                callback(i * len(parts) + j, total, f"cross-validation: {name}, fold {j + 1}/{len(parts)}")
                held.append(held_out_residuals(runner(root, held_out(v, fold), variants_file), fold))
        except ScangeoError as exc:
            log.warning("cross-validation of %s failed: %s", name, exc)
            cv.errors[name] = str(exc)
            continue
        rows = Residuals.concat(held)
        evidence[name].cv = rows
        rms = rows.rms()
        cv.rms_px[name] = rms if rms is not None else math.nan
        cv.n[name] = rows.n
    for s in summaries:
        if s.error is None:
            b = aic_of(s)
            if b is not None:
                cv.aic[s.name] = b
            cv.group[s.name] = f"{s.accounting.get('observations')} observations, {s.dtm_heights} DTM heights"
            cv.control[s.name] = sum(s.control.values())
    callback(total, total, "cross-validation: done")
    recommend(cv, summaries, evidence)
    # the recommended variant decides: its sigma0 far above 1 is never silent (a stiffer variant that lost
    # may well have it: a strip model too stiff for its drift is what the comparison is there to show)
    chosen = next((s for s in summaries if s.name == cv.recommended), None)
    warning = sigma0_warning(chosen.sigma0, f"the recommended variant {chosen.name}", root) if chosen else None
    if warning:
        log.warning("%s", warning)
        cv.warnings.append(warning)
        cv.reason += "; warning: its sigma0 is far above 1, the recommendation is suspect (crossvalidation.warnings)"
    return cv


__all__ = ["HELD_OUT", "CrossValidation", "VariantRunner", "aic_of", "cross_validate", "folds_of", "held_out",
           "held_out_residuals", "recommend"]
