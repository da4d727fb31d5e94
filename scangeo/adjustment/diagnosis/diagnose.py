"""Which strips need more than a constant GPS/IMU correction, and where their error changes course.

``diagnose(project)`` adjusts the project with strip models of degree 0 (SE: control, tie points,
no DTM heights, no automatic rejection, the paper's reference) and arranges what that model leaves
along each strip's lines:

* the **DTM-height misclosure** of every tie point on open terrain (adjusted height minus the DTM's):
  a height or across-track error of one strip moves the intersection of its ray with the other
  strips' rays, so the misclosure of a tie point seen in strips a and b is, to first order,
  ``g_a . e_a(l_a) + g_b . e_b(l_b)``, with ``e_s(l)`` the (across-track, vertical) position error of
  strip s at line l and ``g_s`` the sensitivity of the least-squares ray intersection's height to
  a shift of strip s's sensor (``e_z^T (sum_t A_t)^-1 A_s``, ``A_s = I - d_s d_s^T`` for the ray
  direction ``d_s``); a common shift of all strips moves it by the shift, an across-track shift of
  one strip up on one side and down on the other;
* the **image residuals** (along and across track, pixels) of the tie and control measurements,
  one function per strip and direction (optional; measured to add nothing on the simulated blocks,
  see docs/adjustment.md).

:mod:`scangeo.adjustment.diagnosis.patterns` fits C0 piecewise-linear error functions to them and
chooses the breaks by BIC; a strip with at least one break is a problem strip. Check points are
never used: they stay independent for the comparison.

On a platform the error functions belong to the **flight line** (its GPS/IMU drift is one drift, whichever
sensor sees it): the diagnosis's strips are one per flight line, the first of its strips in the block,
whose lines are the axis of the flight line's functions (:func:`flight_line_units`); the measurements of
the other strips on it enter at the unit's line of their time. A tie point counts once per flight line
(rays of one flight line's sensors meet at a small angle: no height). A one-sensor project's strips are
their own units.
"""
from __future__ import annotations

import fnmatch
import logging
from dataclasses import dataclass, field

import numpy as np

from scangeo.adjustment.block import strips_read_once
from scangeo.adjustment.diagnosis.attribution import (
    ADOPT_BIC,
    AMBIGUOUS_BIC,
    SPLIT_PREFILTER,
    Attribution,
    AttributionCheck,
    adopt,
    attribution_checks,
    preferred_by_split_model,
    split_model_difference,
)
from scangeo.adjustment.diagnosis.patterns import (
    BreakEstimate,
    Fit,
    PatternData,
    SelectionOptions,
    alternatives,
    break_intervals,
    evaluate,
    select_breaks,
)
from scangeo.adjustment.diagnosis.refine import DEFAULT_REFINE, RefineOptions, refine_breaks, s_model_cost
from scangeo.adjustment.keys import Ground
from scangeo.adjustment.plausibility import sigma0_warning
from scangeo.adjustment.results import VariantResult, run_variant
from scangeo.adjustment.variants import Variant
from scangeo.io.project import Project
from scangeo.progress import ProgressCallback, no_progress

log = logging.getLogger(__name__)

#: The components of the strip error functions the misclosures observe (metres).
COMPONENTS = ("across_m", "vertical_m", "along_px", "across_px")


@dataclass
class StripSeries:
    """What SE leaves along one strip (for the report): misclosures and image residuals by line."""

    strip: str
    n_lines: int
    tie_line: np.ndarray
    tie_misclosure_m: np.ndarray
    tie_point: np.ndarray
    image_line: np.ndarray
    image_along_px: np.ndarray
    image_across_px: np.ndarray
    image_kind: np.ndarray

    def as_dict(self) -> dict:
        return {"strip": self.strip, "n_lines": self.n_lines,
                "tie": {"point": [str(p) for p in self.tie_point], "line": _r(self.tie_line, 1),
                        "misclosure_m": _r(self.tie_misclosure_m, 3)},
                "image": {"line": _r(self.image_line, 1), "along_px": _r(self.image_along_px, 3),
                          "across_px": _r(self.image_across_px, 3), "kind": [str(k) for k in self.image_kind]}}


def _r(a, d):
    return [round(float(v), d) for v in a]


@dataclass
class Diagnosis:
    """The result of :func:`diagnose`: the problem strips, their breaks, and the fits that chose them.

    Parameters
    ----------
    project : str
        The project folder.
    strips : list of str
        The strips diagnosed, in the project's order.
    n_lines : dict
        Strip id -> image lines.
    breaks : list of BreakEstimate
        Every break found: strip, line (image lines), its interval (low, high), how it was placed.
    fit, null : Fit
        The piecewise fit with the breaks and without any (BIC, parameters, serial correlation).
    sigma0 : float
        sigma0 of the SE adjustment diagnosed.
    series : list of StripSeries
        Per strip the misclosures along it (for plots).
    notes : list of str
        Remarks (too few tie points, a break dropped, ...).
    options : SelectionOptions
        The break selection's options.
    channels : tuple of str
        The residual channels fitted.
    attribution : list of AttributionCheck
        Per problem strip (one entry with ``strip`` None when there is none) its runner-up attribution,
        the criterion difference and whether the attribution is ambiguous
        (:mod:`scangeo.adjustment.diagnosis.attribution`).
    adopted : list of Attribution
        The alternatives that replaced the search's model, in turn, each with its BIC (and split model's)
        difference to the model it replaced (empty: the search's model stands; :func:`choose_model`).
    search : Fit or None
        The search's own model when an alternative replaced it.
    """

    project: str
    strips: list[str]
    n_lines: dict[str, int]
    breaks: list[BreakEstimate]
    fit: Fit
    null: Fit
    sigma0: float
    series: list[StripSeries] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    options: SelectionOptions = field(default_factory=SelectionOptions)
    channels: tuple[str, ...] = ()
    attribution: list[AttributionCheck] = field(default_factory=list)
    adopted: list[Attribution] = field(default_factory=list)
    search: Fit | None = None

    @property
    def problem_strips(self) -> list[str]:
        """The strips with at least one break.

        Returns
        -------
        list of str
            Strip ids, in the project's order.
        """
        return [s for s in self.strips if any(b.strip == s for b in self.breaks)]

    @property
    def search_problem_strips(self) -> list[str] | None:
        """The problem strips of the search's own model, when an alternative replaced it.

        Returns
        -------
        list of str or None
            Strip ids (empty: the search found none); None when the search's model stands.
        """
        return None if self.search is None else _with_breaks(self.strips, self.search)

    @property
    def ambiguous(self) -> bool:
        """Whether the attribution is in doubt.

        Returns
        -------
        bool
            True when an alternative attribution casts doubt on the chosen one (a competing one within
            the threshold, or a richer one that fits better; docs/adjustment.md, "Attribution").
        """
        return any(c.ambiguous for c in self.attribution)

    def plausible(self) -> list[Attribution]:
        """The other attributions that make the chosen one ambiguous.

        Returns
        -------
        list of Attribution
            Each once, with its strips and breaks (placed by the split model unless the diagnosis kept
            the BIC's lines); the comparison builds variants for each.
        """
        out: list[Attribution] = []
        for c in self.attribution:
            for a in c.plausible:
                if all(a.breaks != b.breaks for b in out) and a.breaks != self.chosen_breaks():
                    out.append(a)
        return out

    def chosen_breaks(self) -> dict[str, tuple[float, ...]]:
        """The chosen attribution's strips and breaks.

        Returns
        -------
        dict
            Problem strip id -> its break lines (as an :class:`Attribution`'s ``breaks``).
        """
        return {s: self.breaks_of(s) for s in self.problem_strips}

    def breaks_of(self, strip: str) -> tuple[float, ...]:
        """A strip's breaks.

        Parameters
        ----------
        strip : str
            The strip's id.

        Returns
        -------
        tuple of float
            Its break lines (image lines, rounded to whole lines; empty: no break).
        """
        return tuple(round(b.line) for b in self.breaks if b.strip == strip)

    def as_dict(self) -> dict:
        """What ``diagnosis.json`` holds (docs/formats.md).

        Returns
        -------
        dict
            JSON-able: problem strips, breaks with their intervals, the criterion, the attribution, the
            series.
        """
        return {"project": self.project, "strips": self.strips, "n_lines": self.n_lines,
                "problem_strips": self.problem_strips,
                "breaks": [{"strip": b.strip, "line": round(b.line, 1), "low": round(b.low, 1),
                            "high": round(b.high, 1), "method": b.method,
                            "bic_line": None if b.bic_line is None else round(b.bic_line, 1),
                            "f_statistic": None if b.f_statistic is None else round(b.f_statistic, 3),
                            "p_value": None if b.p_value is None else float(f"{b.p_value:.3g}")} for b in self.breaks],
                "criterion": {"name": "BIC", "with_breaks": self.fit.bic, "without_breaks": self.null.bic,
                              "parameters": self.fit.k, "parameters_without_breaks": self.null.k,
                              "serial_correlation": self.fit.rho, "rss": self.fit.rss, "channels": list(self.channels)},
                "attribution": [c.as_dict() for c in self.attribution], "ambiguous": self.ambiguous,
                "adopted": self._adopted_dict(),
                "se_sigma0": self.sigma0, "notes": list(self.notes),
                "series": [s.as_dict() for s in self.series]}

    def _adopted_dict(self) -> dict | None:
        if self.search is None:
            return None
        return {"search_problem_strips": self.search_problem_strips, "search_bic": self.search.bic,
                "threshold": ADOPT_BIC, "delta_bic": round(self.adopted[0].delta_bic, 3),
                "steps": [a.as_dict() for a in self.adopted]}


def _with_breaks(strips, fit: Fit) -> list[str]:
    return [s for s, b in zip(strips, fit.breaks) if b]


def adopted_note(search: Fit, adopted: list[Attribution], strips, final: Fit | None = None) -> str:
    """The note of a diagnosis whose search's model an alternative replaced (:func:`choose_model`); ``final``:
    the model the search's last steps made of it, named when its problem strips differ."""
    own = _with_breaks(strips, search)

    def why(a: Attribution) -> str:
        if a.delta_bic < -ADOPT_BIC:
            return (f"more than {ADOPT_BIC:g} below the model it replaces by the BIC, beyond what the best-placed "
                    "breaks gain on drift-free blocks")
        return f"more than {AMBIGUOUS_BIC:g} below it by the split model"

    steps = "; then by ".join(f"{a.describe()} ({why(a)})" for a in adopted)
    last = _with_breaks(strips, final) if final is not None else list(adopted[-1].strips)
    moved = "" if last == [s for s in adopted[-1].strips if adopted[-1].breaks[s]] else (
        f"; the search's last steps then moved it to {'problem strips ' + ', '.join(last) if last else 'none'}")
    return (f"the search's own model ({'problem strips ' + ', '.join(own) if own else 'no problem strip'}) is "
            f"replaced by {steps}{moved} (docs/adjustment.md, \"Adoption\")")


def _across_axes(result: VariantResult) -> dict[str, np.ndarray]:
    """Per strip, the horizontal unit vector across its flight, all pointing to the same side."""
    out: dict[str, np.ndarray] = {}
    ref = None
    for sid, s in result.block.strips.items():
        p = s.gpsimu[:, :3]
        v = p[-1] - p[0]
        a = np.array([v[1], -v[0], 0.0])
        a /= np.linalg.norm(a) or 1.0
        if ref is None:
            ref = a
        out[sid] = a if a @ ref >= 0 else -a
    return out


def _ray_weights(centres: np.ndarray, point: np.ndarray) -> np.ndarray:
    """(m, 3): sensitivity of the height of the least-squares intersection of m rays to each sensor's shift."""
    d = point[None, :] - centres
    d /= np.linalg.norm(d, axis=1)[:, None]
    A = np.eye(3)[None] - d[:, :, None] * d[:, None, :]
    G = np.linalg.inv(A.sum(axis=0))
    return np.einsum("k,mkl->ml", G[2], A)


def flight_line_units(result: VariantResult) -> tuple[list[str], dict[str, str]]:
    """The diagnosis's strips (one per flight line: its first strip in the block) and each strip's unit
    (module docstring)."""
    units: list[str] = []
    unit_of: dict[str, str] = {}
    first: dict[str, str] = {}
    for sid, s in result.block.strips.items():
        if s.flight_line not in first:
            first[s.flight_line] = sid
            units.append(sid)
        unit_of[sid] = first[s.flight_line]
    return units, unit_of


def _unit_lines(project: Project, strip: str, unit: str, lines: np.ndarray, n_unit: int) -> np.ndarray:
    """Lines of a strip as lines of its unit: the unit's line at the same time (within the unit's lines)."""
    if strip == unit:
        return np.asarray(lines, float)
    t = project.timing(strip).time_of_line(np.asarray(lines, float))
    return np.clip(project.timing(unit).line_of_time(t), 0.0, n_unit - 1.0)


def pattern_data(result: VariantResult, dtm_height_points=("*",), image_channels: bool = False
                 ) -> tuple[PatternData, list[StripSeries]]:
    """The diagnosis's observations from an adjusted SE block (module docstring)."""
    block, adj = result.block, result.adjustment
    project = block.project
    strips, unit_of = flight_line_units(result)
    every = list(block.strips)
    n_lines = [project.n_lines(s) for s in strips]
    n_of = {s: project.n_lines(s) for s in strips}
    axes = _across_axes(result)
    params = adj.parameters
    pts, sts = block.points.point.astype(str), block.points.strip.astype(str)
    ties = sorted({p for p in pts if block.role(p) == "tie" and Ground(p) in params
                   and any(fnmatch.fnmatchcase(p, pat) for pat in dtm_height_points)})
    P = np.array([params[Ground(p)].values for p in ties]).reshape(-1, 3)
    mis, _ = project.dtm.height_condition(P) if ties else (np.zeros(0), None)
    centre = {}
    for sid in every:
        sel = np.flatnonzero(sts == sid)
        t = project.timing(sid).time_of_line(block.points.line[sel])
        centre[sid] = dict(zip(pts[sel], result.spline(sid).evaluate(t)[:, :3]))
    value: list[float] = []
    channel: list[int] = []
    trow: list[int] = []
    tstrip: list[int] = []
    tcomp: list[int] = []
    tline: list[float] = []
    tw: list[float] = []
    lines_of = {(p, s): line for p, s, line in zip(pts, sts, block.points.line)}

    def unit_line(p: str, s: str) -> float:
        u = unit_of[s]
        return float(_unit_lines(project, s, u, np.array([lines_of[(p, s)]]), n_of[u])[0])

    tie_series: dict[str, list] = {s: [] for s in strips}
    for i, p in enumerate(ties):
        seen = list({unit_of[s]: s for s in reversed(every) if p in centre[s]}.values())[::-1]  # one per unit
        if len(seen) < 2 or not np.isfinite(mis[i]):
            continue
        g = _ray_weights(np.array([centre[s][p] for s in seen]), P[i])
        r = len(value)
        value.append(float(mis[i]))
        channel.append(0)
        for s, gs in zip(seen, g):
            line = unit_line(p, s)
            tie_series[unit_of[s]].append((line, float(mis[i]), p))
            for k, w in ((0, -float(gs @ axes[s])), (1, -float(gs[2]))):
                trow.append(r)
                tstrip.append(strips.index(unit_of[s]))
                tcomp.append(k)
                tline.append(line)
                tw.append(w)
    _control_rows(result, strips, unit_of, axes, value, channel, trow, tstrip, tcomp, tline, tw)
    ip, istrip, dl, dp, act = result.image_residuals(("control", "height", "planimetric", "tie"))
    parts: dict[str, list] = {s: [] for s in strips}
    for s in every:
        sel = (istrip == s) & act
        lines = np.array([unit_line(p, s) for p in ip[sel]], float)
        parts[unit_of[s]].append((lines, dl[sel], dp[sel], np.array([block.role(p) for p in ip[sel]], dtype=object)))
        if image_channels:
            for c, (res, k) in enumerate(((dl[sel], 2), (dp[sel], 3)), start=2):
                for line, v in zip(lines, res):
                    trow.append(len(value))
                    value.append(float(v))
                    channel.append(c)
                    tstrip.append(strips.index(unit_of[s]))
                    tcomp.append(k)
                    tline.append(float(line))
                    tw.append(1.0)
    image_lines = {u: tuple(np.concatenate(c) for c in zip(*parts[u])) for u in strips}
    channels = ("misclosure_m", "control_across_px") + (("along_px", "across_px") if image_channels else ())
    data = PatternData(np.asarray(value, float), np.asarray(channel, int), np.asarray(trow, int),
                       np.asarray(tstrip, int), np.asarray(tcomp, int), np.asarray(tline, float),
                       np.asarray(tw, float), tuple(strips), tuple(n_lines), channels, COMPONENTS)
    series = []
    for s, n in zip(strips, n_lines):
        ties_s = sorted(tie_series[s])
        lines, along, across, kind = image_lines[s]
        order = np.argsort(lines)
        series.append(StripSeries(s, n, np.array([x[0] for x in ties_s]), np.array([x[1] for x in ties_s]),
                                  np.array([x[2] for x in ties_s], dtype=object), lines[order], along[order],
                                  across[order], kind[order]))
    return data, series


def _control_rows(result: VariantResult, strips, unit_of, axes, value, channel, trow, tstrip, tcomp, tline,
                  tw) -> None:
    """Rows of the across-track image residuals of full control points: ``J . e_s(l)``, with ``J`` the
    change of the point's pixel with its ground position (a shift of the sensor by ``e`` moves the
    pixel as a shift of the point by ``-e``, and the model lacks ``e``); every strip's rows go to its
    unit's functions (``unit_of``), at the unit's lines."""
    block = result.block
    project = block.project
    ip, istrip, dl, dp, act = result.image_residuals(("control",))
    given = {str(p): i for i, p in enumerate(block.ground.point)}
    frame = block.project.map_frame
    lines_of = {(str(p), str(s)): line for p, s, line in zip(block.points.point, block.points.strip, block.points.line)}
    for s in block.strips:
        sel = np.flatnonzero((istrip == s) & act)
        unit = unit_of[s]
        n_unit = project.n_lines(unit)
        if sel.size == 0:
            continue
        xyz = block.ground.xyz[[given[str(p)] for p in ip[sel]]]
        P = frame.map_to_project(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        geometry = result.geometry(s)
        _, pix0, st0 = geometry.ground_to_image(P)
        jac = []
        for d in (axes[s], np.array([0.0, 0.0, 1.0])):
            _, pix1, st1 = geometry.ground_to_image(P + d)
            jac.append(np.where((st0 == 0) & (st1 == 0), pix1 - pix0, np.nan))
        for i, k in enumerate(sel):
            if not (np.isfinite(jac[0][i]) and np.isfinite(jac[1][i])):
                continue
            r = len(value)
            value.append(float(dp[k]))
            channel.append(1)
            line = float(_unit_lines(project, s, unit, np.array([lines_of[(str(ip[k]), s)]]), n_unit)[0])
            for comp, w in ((0, jac[0][i]), (1, jac[1][i])):
                trow.append(r)
                tstrip.append(strips.index(unit))
                tcomp.append(comp)
                tline.append(line)
                tw.append(float(w))


def dropped_notes(proposed: list[BreakEstimate], kept: list[BreakEstimate], level: float | None) -> list[str]:
    """A note for every break the BIC proposed (``proposed``) that the split model's test dropped (absent
    from ``kept``, whose breaks carry their BIC line in ``bic_line``)."""
    lines = {(b.strip, b.bic_line if b.bic_line is not None else b.line) for b in kept}
    test = f" (F test at {100 * level:g} %)" if level is not None else ""
    return [f"strip {b.strip}: the BIC's break at line {b.line:.0f} was dropped, the split model does not need it{test}"
            for b in proposed if (b.strip, b.line) not in lines]


def se_variant() -> Variant:
    """The adjustment the diagnosis starts from: SE, degree 0, no DTM heights, no automatic rejection."""
    return Variant("diagnosis-SE", "SE", "strip models of degree 0 for the diagnosis", snooping=False)


@strips_read_once()  # its 26 adjustments read each trajectory once
def diagnose(project_root, *, dtm_height_points=("*",), image_channels: bool = False,
             options: SelectionOptions | None = None, refine: RefineOptions | None = DEFAULT_REFINE,
             callback: ProgressCallback = no_progress) -> Diagnosis:
    """Find the problem strips and their breaks from an SE adjustment of the project (module docstring).

    Parameters
    ----------
    project_root : the project folder.
    dtm_height_points : glob patterns of the tie points on open terrain (their DTM misclosure is used).
    image_channels : also fit the image residuals of tie and control measurements.
    options : the break selection's options.
    refine : options of placing every break by adjusting the S model around the BIC's line
        (:mod:`scangeo.adjustment.diagnosis.refine`); None keeps the BIC's lines.
    """
    project = Project.from_user_input(project_root)
    root = project.root
    options = options or SelectionOptions()
    steps = 6 if refine is not None else 3
    callback(0, steps, "diagnosis: adjusting SE")
    result = run_variant(project, se_variant())
    callback(1, steps, "diagnosis: choosing breaks")
    data, series = pattern_data(result, dtm_height_points, image_channels)
    notes = []
    checks: list[AttributionCheck] = []
    adopted: list[Attribution] = []
    search: Fit | None = None
    n_ties = int((data.channel == 0).sum())
    if n_ties < 10:
        notes.append(f"only {n_ties} tie points with a DTM misclosure: too few to look for breaks")
        null = evaluate(data, [[] for _ in data.strips], None, options.degree, range(len(data.strips)))
        fit, breaks = null, []
    else:
        search = select_breaks(data, options)
        fit, checks, adopted = choose_model(root, data, search, options, refine, dtm_height_points,
                                            lambda m: callback(2, steps, m))
        if adopted:
            notes.append(adopted_note(search, adopted, data.strips, fit))
        null = evaluate(data, [[] for _ in data.strips], fit.rho, options.degree, range(len(data.strips)))
        callback(2, steps, "diagnosis: break intervals")
        breaks = break_intervals(data, fit, options)
        if refine is not None and breaks:
            n_lines = dict(zip(data.strips, data.n_lines))
            proposed = breaks
            breaks, _ = refine_breaks(
                breaks, n_lines, s_model_cost(project, dtm_height_points, refine.position_degree), refine,
                lambda i, n: callback(3 + i / n, steps, f"diagnosis: placing break {i} of {n} with the S model"))
            notes += dropped_notes(proposed, breaks, refine.test_level)
        if refine is not None:
            plausible = [a for c in checks for a in c.plausible]
            for i, a in enumerate(plausible):
                callback(5 + i / len(plausible), steps, f"diagnosis: placing the breaks of attribution {a.label}")
                place_breaks(root, a, breaks, dict(zip(data.strips, data.n_lines)), dtm_height_points, refine)
    callback(steps, steps, "diagnosis: done")
    warning = sigma0_warning(float(result.adjustment.statistics.sigma0), "the diagnosis's SE adjustment", root)
    if warning:
        log.warning("%s", warning)
        notes.insert(0, warning)
    d = Diagnosis(str(root), list(data.strips), dict(zip(data.strips, data.n_lines)), breaks, fit, null,
                  float(result.adjustment.statistics.sigma0), series, notes, options, data.channels, checks,
                  adopted, search if adopted else None)
    for c in checks:
        if c.ambiguous:
            log.warning("%s", c.sentence())
    log.info("diagnosis of %s: problem strips %s, breaks %s", root, d.problem_strips or "none",
             ", ".join(f"{b.strip}@{b.line:.0f}" for b in breaks) or "none")
    return d


def choose_model(root, data: PatternData, search: Fit, options: SelectionOptions, refine: RefineOptions | None,
                 dtm_height_points=("*",), say=lambda message: None
                 ) -> tuple[Fit, list[AttributionCheck], list[Attribution]]:
    """The diagnosis's model: the search's, or an alternative that beats it (module docstring of
    :mod:`~.attribution`): by the BIC beyond :data:`~.attribution.ADOPT_BIC` (:func:`~.attribution.adopt`),
    then, a competing one, by the split model's criterion beyond :data:`~.attribution.AMBIGUOUS_BIC`
    (:func:`~.attribution.preferred_by_split_model`; with ``refine``, which asks the split model's opinion of
    every competing alternative, :func:`split_model_opinion`), again from each model so adopted until the
    split model prefers none of its alternatives (never a model twice). Returns the model, its attribution
    checks and the alternatives adopted in turn."""
    fit, checks, adopted = adopt(data, search, attribution_checks(data, search, options), options)
    if refine is None or not any(c.strip is not None for c in checks):
        return fit, checks, adopted
    say("diagnosis: the split model's opinion of the other attributions")
    chosen = _bic_breaks(data, fit)
    split_model_opinion(root, checks, chosen, dtm_height_points, refine.position_degree)
    seen = [chosen]
    for _ in range(len(data.strips)):  # from each adopted model, its own alternatives asked again
        better = preferred_by_split_model(checks)
        if better is None or better.fit is None:
            break
        chosen = _bic_breaks(data, better.fit)
        if chosen in seen:
            break
        seen.append(chosen)
        fit = better.fit
        fit.alternatives = alternatives(data, fit, options)
        checks = attribution_checks(data, fit, options)
        adopted.append(better)
        if not any(c.strip is not None for c in checks):
            break
        split_model_opinion(root, checks, chosen, dtm_height_points, refine.position_degree)
    return fit, checks, adopted


def _bic_breaks(data: PatternData, fit: Fit) -> dict[str, tuple[float, ...]]:
    return {data.strips[s]: tuple(round(float(b), 1) for b in br) for s, br in enumerate(fit.breaks) if br}


def split_model_opinion(root, checks: list[AttributionCheck], chosen: dict[str, tuple[float, ...]],
                        dtm_height_points=("*",), position_degree: int = 2) -> None:
    """Every competing alternative within :data:`~.attribution.SPLIT_PREFILTER` of the chosen attribution asked
    of the split model too (:func:`~.attribution.split_model_difference`, both at the BIC's lines): a
    second opinion from the adjustment itself; the checks' ``plausible`` updated."""
    for c in checks:
        for a in c.alternatives:
            if a.competing and a.delta_bic < SPLIT_PREFILTER and a.breaks != chosen:
                cost = s_model_cost(root, dtm_height_points, position_degree)  # no warm start across models
                a.delta_split = split_model_difference(cost, chosen, a.breaks)
        c.update()


def place_breaks(root, attribution: Attribution, chosen: list[BreakEstimate], n_lines: dict[str, int],
                 dtm_height_points=("*",), refine: RefineOptions = DEFAULT_REFINE) -> None:
    """The breaks of another attribution placed by the split model, as the chosen ones are: the strips
    it gives new breaks are refined (:func:`~.refine.refine_breaks`) with the chosen problem strips it
    keeps split at their placed lines; ``attribution.breaks`` updated in place."""
    placed = {b.strip for b in chosen}
    keep = {s: tuple(b.line for b in chosen if b.strip == s) for s in attribution.breaks if s in placed}
    if attribution.kind == "moved":
        keep.pop(attribution.strip, None)
    new = [BreakEstimate(s, float(line), float(line), float(line)) for s, lines in attribution.breaks.items()
           if s not in keep for line in lines]
    if not new:
        return
    cost = s_model_cost(root, dtm_height_points, refine.position_degree)
    moved, _ = refine_breaks(new, n_lines, cost, refine, fixed=keep)
    attribution.breaks = {s: keep[s] if s in keep else tuple(round(b.line, 1) for b in moved if b.strip == s)
                          for s in attribution.breaks}
    attribution.placed = True


__all__ = ["COMPONENTS", "Diagnosis", "StripSeries", "diagnose", "dropped_notes", "pattern_data", "place_breaks",
           "se_variant", "split_model_opinion"]
