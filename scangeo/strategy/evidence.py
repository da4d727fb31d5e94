"""The recommendation weighs all independent evidence: the cross-validation and the check points, each with its noise.

Two kinds of measurement say how well a variant's orientation predicts image points it did not use:

* the **cross-validation**'s held-out control points (:mod:`~.crossvalidation`): each fold of the
  control points left out of the variant's adjustment in turn and projected with the result. They
  lie where control lies: in bands at the strips' ends (and at the breaks in the 4-band variants).
* the **check points**: in no adjustment at all, spread along the strips. They see an error in the
  middle of a strip, which control at its ends cannot (a split model placed on the wrong strip fits
  the control bands as well as the right one).

Per image measurement the squared error is ``q = (along^2 + across^2) / 2`` (pixels; lines along
track), and a variant's rms over a set of measurements is ``sqrt(mean q)``.

**Two variants compared** (:func:`paired`) on the measurements both predicted: the same points, so the
measurement noise is common and largely cancels in the difference. The paired test of predictive
accuracy (Diebold and Mariano, 1995): ``d = q_a - q_b``, ``z = mean(d) / SE``, ``SE = sd(d) /
sqrt(n_eff)``, ``n_eff = n (1 - rho) / (1 + rho)`` with ``rho`` the lag-1 autocorrelation of ``d``
along each strip's lines (neighbouring measurements share an orientation error; the diagnosis
corrects its BIC the same way). The **noise** of the rms difference is its 95 % half-width
``1.96 SE / (rms_a + rms_b)``; a difference within it does not decide. At the check points a
variant is also compared as the comparison table shows it (:func:`f_test`): the ratio of the two
variants' mean squares over their own check points, an F test with 2n degrees of freedom each. A
variant is **significantly worse at the check points** than another when either test says so at 5 %
(one-sided for the F test, two-sided for the paired one).

**The recommendation** (:func:`weigh`):

1. the candidates: the variants the cross-validation adjusted (never DG);
2. not significantly worse at the check points than any other adjusted variant (the check points are
   never contradicted while a candidate they do not reject exists);
3. of those, the ones within the noise of the lowest rms over all their out-of-sample measurements,
   held-out control and check points together (a cross-validation that also holds out the check
   points; the check points outnumber the control and spread along the strips, so they weigh most);
4. among them, the tie-break of :mod:`~.crossvalidation`: the lowest AIC within a group of identical
   observations, then the most control points, then the lowest rms.

Without check points this is the cross-validation with its noise. Each evidence's own choice (the
lowest cross-validated rms; the lowest check-point rms) is named, and where the two disagree beyond
their noise (they rank the two oppositely, on the check points both predicted, and at least one of
them beyond its noise) the recommendation says so and why. Its margin is stated against the closest other
candidate, in each evidence ("S4, 0.03 px better than S2 over held-out control and check points,
within the noise of 0.05 px").

**The check points still measure independently** (:func:`independent_check`): they are dealt into
folds (by id, as the control points are), and the recommendation is made again without each fold;
each fold's measurements are then scored in the variant chosen without them. That rms is measured by
points that took no part in the choice; where every fold's choice is the recommended variant, it is
that variant's check-point rms over all check points, which the table reports.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

#: two-sided 95 % quantile of the normal distribution: the paired test's level and the noise's width
Z95 = 1.96
#: level of the one-sided F test of two variants' check-point mean squares
F_LEVEL = 0.05
#: the fewest common measurements for a paired comparison
MIN_COMMON = 3


@dataclass
class Residuals:
    """Out-of-sample residuals of one variant, one row per image measurement: the point and strip, the
    measured line (its place along the strip), the residual along track (lines) and across (pixels)."""

    point: np.ndarray
    strip: np.ndarray
    line: np.ndarray
    along: np.ndarray
    across: np.ndarray

    @classmethod
    def empty(cls) -> Residuals:
        e = np.zeros(0)
        return cls(e.astype(object), e.astype(object), e, e, e)

    @classmethod
    def concat(cls, parts: Sequence[Residuals]) -> Residuals:
        parts = [p for p in parts if p.n]
        if not parts:
            return cls.empty()
        return cls(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("point", "strip", "line", "along",
                                                                              "across")))

    @property
    def n(self) -> int:
        return int(self.along.size)

    @property
    def q(self) -> np.ndarray:
        """Squared error per measurement, ``(along^2 + across^2) / 2`` (px^2)."""
        return 0.5 * (self.along ** 2 + self.across ** 2)

    def rms(self) -> float | None:
        return float(math.sqrt(np.mean(self.q))) if self.n else None

    def keys(self) -> list[tuple[str, str]]:
        return [(str(p), str(s)) for p, s in zip(self.point, self.strip)]

    def select(self, keep: np.ndarray) -> Residuals:
        return Residuals(self.point[keep], self.strip[keep], self.line[keep], self.along[keep], self.across[keep])

    def without(self, points: set[str]) -> Residuals:
        return self.select(np.array([str(p) not in points for p in self.point], bool))

    def only(self, points: set[str]) -> Residuals:
        return self.select(np.array([str(p) in points for p in self.point], bool))


@dataclass
class Evidence:
    """One variant's out-of-sample residuals: the cross-validation's held-out control, the check points."""

    cv: Residuals = field(default_factory=Residuals.empty)
    check: Residuals = field(default_factory=Residuals.empty)

    def all(self) -> Residuals:
        return Residuals.concat([self.cv, self.check])

    def get(self, source: str) -> Residuals:
        return {"cv": self.cv, "check": self.check, "all": self.all()}[source]

    def without_checks(self, points: set[str]) -> Evidence:
        return Evidence(self.cv, self.check.without(points))


@dataclass(frozen=True)
class Difference:
    """Variant a against b on their common measurements (module docstring): rms of each, the noise of
    the difference (95 % half-width, px) and the paired statistic ``z`` (positive: a is worse)."""

    n: int
    rms_a: float
    rms_b: float
    noise: float
    z: float
    rho: float

    @property
    def delta(self) -> float:
        """rms_a - rms_b (px; negative: a is better)."""
        return self.rms_a - self.rms_b

    @property
    def significant(self) -> bool:
        return bool(abs(self.z) > Z95)

    def as_dict(self) -> dict:
        return {"n": self.n, "rms_a_px": round(self.rms_a, 4), "rms_b_px": round(self.rms_b, 4),
                "delta_px": round(self.delta, 4), "noise_px": round(self.noise, 4), "z": round(self.z, 3),
                "rho": round(self.rho, 3), "significant": self.significant}


def _lag1(d: np.ndarray, strip: np.ndarray, line: np.ndarray) -> float:
    """Lag-1 autocorrelation of ``d`` ordered by line within each strip (clipped to [0, 0.9])."""
    num = den = 0.0
    for s in np.unique(strip.astype(str)):
        sel = strip.astype(str) == s
        r = d[sel][np.argsort(line[sel], kind="stable")]
        if r.size > 2:
            r = r - r.mean()
            num += float(np.sum(r[1:] * r[:-1]))
            den += float(np.sum(r * r))
    return float(np.clip(num / den, 0.0, 0.9)) if den > 0 else 0.0


def paired(a: Residuals, b: Residuals) -> Difference | None:
    """The paired comparison of a and b on the measurements (point, strip) both have (module docstring);
    None with fewer than :data:`MIN_COMMON` in common."""
    index_b = {k: i for i, k in enumerate(b.keys())}
    ia, ib = [], []
    for i, k in enumerate(a.keys()):
        j = index_b.get(k)
        if j is not None:
            ia.append(i)
            ib.append(j)
    n = len(ia)
    if n < MIN_COMMON:
        return None
    qa, qb = a.q[ia], b.q[ib]
    d = qa - qb
    rho = _lag1(d, a.strip[ia], a.line[ia])
    n_eff = max(n * (1.0 - rho) / (1.0 + rho), 2.0)
    se = float(np.std(d, ddof=1)) / math.sqrt(n_eff)
    rms_a, rms_b = math.sqrt(float(qa.mean())), math.sqrt(float(qb.mean()))
    mean = float(d.mean())
    z = mean / se if se > 0 else (0.0 if mean == 0 else math.copysign(math.inf, mean))
    noise = Z95 * se / max(rms_a + rms_b, 1e-12)
    return Difference(n, rms_a, rms_b, noise, z, rho)


def f_test(a: Residuals, b: Residuals) -> tuple[float, float] | None:
    """``(F, p)``: the ratio of a's mean square to b's over each one's own measurements, and the one-sided
    p-value of a being no worse (F distribution, 2n degrees of freedom each); None when either is empty."""
    if not a.n or not b.n:
        return None
    f = float(np.mean(a.q) / max(np.mean(b.q), 1e-300))
    return f, float(stats.f.sf(f, 2 * a.n, 2 * b.n))


def worse_at_checks(a: Evidence, b: Evidence) -> str | None:
    """Why a is significantly worse than b at the check points (module docstring), or None."""
    d = paired(a.check, b.check)
    if d is not None and d.z > Z95:
        return (f"{d.rms_a:.3f} against {d.rms_b:.3f} px on the {d.n} check-point measurements of both, "
                f"{d.delta:.3f} px beyond the noise of {d.noise:.3f} px")
    f = f_test(a.check, b.check)
    if f is not None and f[1] < F_LEVEL:
        return (f"{a.check.rms():.3f} against {b.check.rms():.3f} px over their check points "
                f"(F = {f[0]:.2f}, p = {f[1]:.2g})")
    return None


@dataclass
class Decision:
    """What :func:`weigh` decided and why (module docstring)."""

    recommended: str | None
    reason: str = ""
    margin: str = ""
    cv_choice: str | None = None
    check_choice: str | None = None
    disagreement: str | None = None
    #: variant -> the variants it is significantly worse than at the check points (with why)
    rejected_by_checks: dict[str, dict[str, str]] = field(default_factory=dict)
    #: the recommended variant's significant deficits at the check points (empty unless unavoidable)
    contradicts_checks: dict[str, str] = field(default_factory=dict)
    rms: dict[str, dict[str, float | None]] = field(default_factory=dict)
    #: the recommended variant against every other candidate, per evidence
    against: dict[str, dict[str, dict | None]] = field(default_factory=dict)
    independent: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"recommended": self.recommended, "reason": self.reason, "margin": self.margin,
                "cv_choice": self.cv_choice, "check_choice": self.check_choice,
                "disagreement": self.disagreement, "rejected_by_checks": self.rejected_by_checks,
                "contradicts_checks": self.contradicts_checks, "rms_px": self.rms, "against": self.against,
                "independent_check": self.independent}


@dataclass(frozen=True)
class TieBreak:
    """What the tie-break of :mod:`~.crossvalidation` knows of every variant."""

    aic: Mapping[str, float]
    group: Mapping[str, str]
    control: Mapping[str, int]


def _tie_break(near: list[str], rms: Mapping[str, float], info: TieBreak) -> str:
    winners = []
    for g in sorted({info.group.get(n, n) for n in near}):
        members = [n for n in near if info.group.get(n, n) == g]
        winners.append(min(members, key=lambda n: (info.aic.get(n, math.inf), rms[n])))
    return min(winners, key=lambda n: (-info.control.get(n, 0), rms[n]))


def _choose(candidates: list[str], evidence: Mapping[str, Evidence], info: TieBreak
            ) -> tuple[str | None, dict[str, dict[str, str]], list[str]]:
    """(recommended, rejected by the check points, the near set) over ``candidates`` (steps 2-4)."""
    if not candidates:
        return None, {}, []
    rejected: dict[str, dict[str, str]] = {}
    for a in evidence:
        for b in evidence:
            if a != b:
                why = worse_at_checks(evidence[a], evidence[b])
                if why:
                    rejected.setdefault(a, {})[b] = why
    kept = [n for n in candidates if n not in rejected] or list(candidates)
    score = {n: evidence[n].all().rms() for n in kept}
    scored = [n for n in kept if score[n] is not None]
    if not scored:
        return None, rejected, []
    best = min(scored, key=lambda n: score[n])  # type: ignore[arg-type, return-value]
    near = [best]
    for n in scored:
        if n == best:
            continue
        d = paired(evidence[n].all(), evidence[best].all())
        if d is None or not (d.z > Z95):
            near.append(n)
    return _tie_break(near, {n: score[n] for n in scored}, info), rejected, near  # type: ignore[misc]


def _phrase(name: str, other: str, d: Difference | None, what: str) -> str:
    if d is None:
        return f"{what}: no measurements in common with {other}"
    side = "better" if d.delta < 0 else "worse"
    within = "within" if not d.significant else "beyond"
    return (f"{abs(d.delta):.3f} px {side} than {other} {what} ({d.rms_a:.3f} against {d.rms_b:.3f} px, "
            f"{d.n} measurements), {within} the noise of {d.noise:.3f} px")


def weigh(candidates: Sequence[str], evidence: Mapping[str, Evidence], info: TieBreak, folds: int = 4) -> Decision:
    """The recommendation from the evidence of every adjusted variant (module docstring).

    Parameters
    ----------
    candidates : the variants that may be recommended (cross-validated; never DG).
    evidence : per adjusted variant (candidates and the others adjusted, DG excluded), its held-out
        control residuals (``cv``, empty when not cross-validated) and check-point residuals.
    info : AIC, observation group and control count per variant (the tie-break).
    folds : folds of the check points for :func:`independent_check`.
    """
    candidates = [c for c in candidates if c in evidence]
    rec, rejected, near = _choose(candidates, evidence, info)
    out = Decision(rec, rejected_by_checks=rejected)
    out.rms = {n: {s: e.get(s).rms() for s in ("cv", "check", "all")} for n, e in evidence.items()}
    cv = {n: out.rms[n]["cv"] for n in candidates if out.rms[n]["cv"] is not None}
    checks = {n: out.rms[n]["check"] for n in evidence if out.rms[n]["check"] is not None}
    out.cv_choice = min(cv, key=lambda n: cv[n]) if cv else None  # type: ignore[arg-type, return-value]
    out.check_choice = min(checks, key=lambda n: checks[n]) if checks else None  # type: ignore[arg-type, return-value]
    if rec is None:
        out.reason = "no variant could be scored on held-out measurements"
        return out
    e = evidence[rec]
    for other in candidates:
        if other != rec:
            out.against[other] = {}
            for source in ("cv", "check", "all"):
                d = paired(e.get(source), evidence[other].get(source))
                out.against[other][source] = None if d is None else d.as_dict()
    out.contradicts_checks = dict(rejected.get(rec, {}))
    rivals = [n for n in candidates if n != rec and out.rms[n]["all"] is not None]
    n_cv, n_check = e.cv.n, e.check.n
    basis = (f"held-out control ({n_cv} measurements) and check points ({n_check})" if n_check
             else f"held-out control ({n_cv} measurements; no check points)")
    parts = [f"{rec}: rms {out.rms[rec]['all']:.3f} px over {basis}"]
    if rivals:
        rival = min(rivals, key=lambda n: out.rms[n]["all"])  # type: ignore[arg-type, return-value]
        margins = [_phrase(rec, rival, paired(e.all(), evidence[rival].all()), "over both")]
        if n_check:
            margins.append(_phrase(rec, rival, paired(e.cv, evidence[rival].cv), "in cross-validation"))
            margins.append(_phrase(rec, rival, paired(e.check, evidence[rival].check), "at the check points"))
        out.margin = f"{rec}, " + "; ".join(margins)
    others = [n for n in near if n != rec]
    if others:
        parts.append(f"{', '.join(others)} within the noise: the lowest AIC among the variants with the same "
                     "observations, then the most control points decided")
    dropped = [n for n in candidates if n in rejected and n != rec]
    if dropped:
        parts.append(f"set aside, significantly worse at the check points: {', '.join(dropped)}")
    if out.contradicts_checks:
        parts.append("NOTE: every candidate is significantly worse at the check points than some variant; "
                     f"{rec} is worse than " + "; ".join(f"{k} ({v})" for k, v in out.contradicts_checks.items()))
    out.reason = "; ".join(parts)
    out.disagreement = _disagreement(out, evidence, candidates)
    out.independent = independent_check(candidates, evidence, info, rec, folds)
    return out


def _disagreement(out: Decision, evidence: Mapping[str, Evidence], candidates: Sequence[str]) -> str | None:
    """Where the cross-validation's choice and the check points' disagree beyond their noise, why (or None):
    the two rank them oppositely (the check points on the points both variants predicted, which the
    lowest check-point rms over each one's own points need not say: a 4-band variant has fewer check
    points) and at least one of them beyond its noise."""
    a, b = out.cv_choice, out.check_choice
    if a is None or b is None or a == b or a not in evidence or b not in evidence:
        return None
    common = paired(evidence[a].check, evidence[b].check)
    if common is not None and common.delta <= 0:
        return None  # on the check points both predicted, the cross-validation's choice is no worse
    checks_say = worse_at_checks(evidence[a], evidence[b])
    d = paired(evidence[b].cv, evidence[a].cv)
    cv_says = d is not None and d.z > Z95
    if not (checks_say or cv_says):
        return None
    text = (f"the cross-validation would choose {a} (held-out control rms {out.rms[a]['cv']:.3f} px), the check points "
            f"{b} ({out.rms[b]['check']:.3f} px)")
    if checks_say:
        text += f"; at the check points {a} is significantly worse than {b}: {checks_say}"
    if cv_says and d is not None:
        text += (f"; in cross-validation {b} is significantly worse than {a}: {d.rms_a:.3f} against {d.rms_b:.3f} px, "
                 f"beyond the noise of {d.noise:.3f} px")
    text += (". The control points lie in bands (the strips' ends, and the breaks in 4-band variants) and cannot see "
             "an orientation error between them; the check points, spread along the strips, can")
    text += f". Recommended: {out.recommended}, weighing both"
    return text


def independent_check(candidates: Sequence[str], evidence: Mapping[str, Evidence], info: TieBreak,
                      recommended: str, folds: int = 4) -> dict:
    """The recommendation made again without each fold of the check points, each fold scored in the variant
    chosen without it (module docstring)."""
    points = sorted({str(p) for e in evidence.values() for p in e.check.point})
    k = max(2, folds)
    parts = [set(points[i::k]) for i in range(k) if points[i::k]]
    if len(parts) < 2:
        return {}
    chosen, scored = [], []
    for fold in parts:
        without = {n: e.without_checks(fold) for n, e in evidence.items()}
        pick, _, _ = _choose([c for c in candidates if c in without], without, info)
        chosen.append(pick)
        if pick is not None:
            scored.append(evidence[pick].check.only(fold))
    rows = Residuals.concat(scored)
    same = sum(c == recommended for c in chosen)
    own = evidence[recommended].check.rms()
    rms = rows.rms()
    if same == len(parts):
        text = (f"the check points measure {recommended} independently: it is chosen with any of {len(parts)} folds of "
                f"them left out, and each fold's rms in it ({rms:.3f} px over all) took no part in choosing it")
    else:
        text = (f"the check points took part in the choice: without each of {len(parts)} folds the choice is "
                f"{', '.join(str(c) for c in chosen)}; each fold scored in the variant chosen without it: "
                + (f"{rms:.3f} px" if rms is not None else "-")
                + (f" (against {own:.3f} px of {recommended} over all check points)" if own is not None else ""))
    return {"folds": len(parts), "chosen": chosen, "same": same, "rms_px": rms, "n": rows.n,
            "recommended_rms_px": own, "text": text}


__all__ = ["Decision", "Difference", "Evidence", "F_LEVEL", "MIN_COMMON", "Residuals", "TieBreak", "Z95", "f_test",
           "independent_check", "paired", "weigh", "worse_at_checks"]
