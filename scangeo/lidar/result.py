"""The result of a laser strip adjustment, typed (:class:`LaserResult`), and its ``results.json`` form.

Every estimated correction coefficient and calibration unknown comes with its t-test against zero
(``t = |value| / sigma``, two-sided at 5 %, the redundancy's degrees of freedom), and so do the tilts
of the patch planes (``u``, ``v``: the tilt of each adjusted plane from its initial normal, in
radians): the paper asks for both, a coefficient that is not significant is a candidate to drop, a
significant tilt a plane that the strips turned.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from scangeo.adjustment.keys import Boresight, LeverArm, ScanIndex
from scangeo.lidar.adjust import LaserBlock
from scangeo.lidar.evaluation import Evaluation, block_unit
from scangeo.lidar.groups import laser_calibration_keys
from scangeo.lidar.keys import Plane, RangeOffset
from scangeo.lsq.engine import Adjustment
from scangeo.lsq.keys import Key
from scangeo.lsq.reliability import delta0
from scangeo.orientation.models import Correction

CALIBRATION = (Boresight, LeverArm, RangeOffset, ScanIndex)


@dataclass(frozen=True)
class Estimate:
    """One estimated unknown: value and sigma in ``unit`` (m or deg), its t-test against zero."""

    key: Key
    component: str
    value: float
    sigma: float
    unit: str
    t: float
    significant: bool

    @property
    def is_calibration(self) -> bool:
        return isinstance(self.key, CALIBRATION)

    def as_dict(self) -> dict:
        return {"key": self.key.label, "component": self.component, "value": self.value, "sigma": self.sigma,
                "unit": self.unit, "t": self.t, "significant": self.significant}


@dataclass(frozen=True)
class Regularised:
    """An unknown the solver held by a pseudo-observation because no observation determined it."""

    key: Key
    component: str
    sigma: float
    reason: str

    @property
    def is_plane(self) -> bool:
        return isinstance(self.key, Plane)


@dataclass(frozen=True)
class Rejection:
    """A patch observation (one strip's anchors of one patch) data snooping removed: its normalised
    residual ``w`` when it was removed, and its MDB (m) in the final solution (``sigma delta0 sqrt(1 + h)``
    with the leverage ``h`` it would have were it put back)."""

    group: str
    patch: str
    w: float
    round: int
    mdb: float = float("nan")


@dataclass(frozen=True)
class TiltTests:
    """The t-tests of the patch planes' tilts (u, v), per patch kind: how many, how many significant."""

    patches: int
    significant: int
    max_t: float


@dataclass
class LaserResult:
    """What the adjustment of one laser variant found (:func:`laser_result`); :meth:`to_dict` is its
    ``results.json``.

    Parameters
    ----------
    mode, mode_description : str
        How the strips were corrected (trajectory corrections or trajectory-free), in a word and in words.
    strips : dict
        Strip id -> its figures.
    patches : dict
        Counts of tie, control and check patches.
    sigma0 : float
        sigma0 a posteriori.
    accounting : dict
        Observations, unknowns, conditions, redundancy.
    converged : bool
        The adjustment converged.
    estimates : list of Estimate
        Every unknown with its value and precision (metres, degrees).
    tilts : TiltTests
        The tests of the patches' tilts.
    regularised : list of Regularised
        Coefficients held by their pseudo-observations, and why.
    rejections : list of Rejection
        What data snooping removed.
    notes : list of str
        Remarks.
    evaluation : dict or None
        Against a simulation's truth, when there is one.
    folder : Path or None
        Where the results went (None: not written).
    variant : str
        The variant's name.
    options : dict
        The options used.
    patch_map : list of dict
        Every patch of the adjustment: id, kind, x, y (map CRS), the strips it was found in.
    """

    mode: str
    mode_description: str
    strips: dict[str, dict]
    patches: dict[str, int]
    sigma0: float
    accounting: dict
    converged: bool
    estimates: list[Estimate]
    tilts: TiltTests
    regularised: list[Regularised]
    rejections: list[Rejection]
    notes: list[str]
    evaluation: dict | None
    folder: Path | None = None
    variant: str = ""
    options: dict = field(default_factory=dict)
    #: every patch of the adjustment: id, kind, x, y (map), the strips it was found in
    patch_map: list[dict] = field(default_factory=list)

    @property
    def strips_per_patch(self) -> dict[str, int]:
        """The block's connectivity: how many tie patches were found in 2, 3, ... strips.

        Returns
        -------
        dict
            Number of strips (as a string) -> tie patches found in that many, ascending.
        """
        counts: dict[str, int] = {}
        for p in self.patch_map:
            if p["kind"] == "tie":
                counts[str(p["strips"])] = counts.get(str(p["strips"]), 0) + 1
        return dict(sorted(counts.items(), key=lambda kv: int(kv[0])))

    @property
    def calibration(self) -> list[Estimate]:
        """The calibration unknowns (boresight, lever arm, scanner).

        Returns
        -------
        list of Estimate
            Value and precision of each.
        """
        return [e for e in self.estimates if e.is_calibration]

    @property
    def corrections(self) -> list[Estimate]:
        """The GPS/IMU correction coefficients.

        Returns
        -------
        list of Estimate
            Value and precision of each.
        """
        return [e for e in self.estimates if isinstance(e.key, Correction)]

    def to_dict(self) -> dict:
        """What ``results.json`` holds.

        Returns
        -------
        dict
            JSON-able: every figure of the result.
        """
        return {
            "variant": self.variant,
            "mode": self.mode,
            "mode_description": self.mode_description,
            "strips": self.strips,
            "patches": self.patches,
            "sigma0": self.sigma0,
            "accounting": self.accounting,
            "converged": self.converged,
            "parameters": [e.as_dict() for e in self.estimates],
            "patch_tilts": asdict(self.tilts),
            "regularisation": [{"key": r.key.label, "component": r.component, "sigma": r.sigma, "reason": r.reason}
                               for r in self.regularised],
            "rejections": [asdict(r) for r in self.rejections],
            "notes": self.notes,
            "evaluation": self.evaluation,
            "options": self.options,
            "strips_per_patch": self.strips_per_patch,
            "patch_map": self.patch_map,
        }


def rejected_mdb(result: Adjustment) -> dict[tuple[str, str], float]:
    """The MDB (m) of every rejected observation unit, ``(group, unit id) -> MDB`` (:class:`Rejection`)."""
    sol, h = result.solution, result.statistics.leverages
    d0 = delta0()
    out: dict[tuple[str, str], float] = {}
    for g, act, sl in zip(sol.groups, sol.active, sol.system.row_slices):
        if act.all() or g.kind != "observation":
            continue
        rows = np.flatnonzero(~act)
        mdb = np.asarray(g.sigma, float)[rows] * d0 * np.sqrt(1.0 + np.maximum(h[sl][rows], 0.0))
        for r, m in zip(rows, mdb):
            key = (g.name, str(g.ids[r]))
            out[key] = max(out.get(key, 0.0), float(m))
    return out


def estimates(result: Adjustment, keys: list[Key], unit: float) -> list[Estimate]:
    """Every free component of ``keys`` with sigma and significance (metres and degrees; map units x
    ``unit`` for the position corrections of the trajectory-free mode)."""
    st = result.statistics
    rows = []
    for key in keys:
        if not result.parameters[key].free.any():
            continue
        for c in st.significance(key):
            angular = isinstance(key, (Boresight, ScanIndex)) or (
                isinstance(key, Correction) and c.component.rstrip("0123456789") in ("roll", "pitch", "heading")
            )
            f = np.degrees(1.0) if angular else (1.0 if isinstance(key, (LeverArm, RangeOffset)) else unit)
            rows.append(Estimate(key, c.component, c.value * f, c.sigma * f, "deg" if angular else "m", c.t,
                                 c.significant))
    return rows


def tilt_tests(result: Adjustment, planes: list[Plane]) -> TiltTests:
    """t-tests of the tilts (u, v) of the given planes (those in the adjustment)."""
    st = result.statistics
    significant, max_t, n = 0, 0.0, 0
    for key in planes:
        tests = [c for c in st.significance(key) if c.component in ("u", "v")]
        if not tests:
            continue
        n += 1
        significant += any(c.significant for c in tests)
        max_t = max(max_t, *(c.t for c in tests))
    return TiltTests(n, significant, max_t)


def _patch_map(block: LaserBlock) -> list[dict]:
    """Every patch of the block: id, kind, map position of its reference point, how many strips have it."""
    strips = np.zeros(len(block.kinds), int)
    for a in block.anchors.values():
        strips[np.unique(a["patch"])] += 1
    xy = block.to_map(block.frames.c0) if len(block.kinds) else np.zeros((0, 3))
    return [{"id": pid, "kind": kind, "x": round(float(xy[i, 0]), 3), "y": round(float(xy[i, 1]), 3),
             "strips": int(strips[i])} for i, (pid, kind) in enumerate(zip(block.frames.ids, block.kinds))]


def laser_result(block: LaserBlock, result: Adjustment, evaluation: Evaluation | None) -> LaserResult:
    """The typed result of an adjusted laser block (its variant's name included)."""
    st = result.statistics
    keys = [m.key for m in block.models] + list(laser_calibration_keys(block.sensor))
    planes = [Plane(i) for i, kind in zip(block.frames.ids, block.kinds) if kind != "check"]
    mdb = rejected_mdb(result)
    v = block.variant
    return LaserResult(
        mode=block.mode,
        mode_description=(
            "trajectory: GPS/IMU correction polynomials, calibration, tie planes"
            if block.mode == "trajectory"
            else "points (provisional solution, no trajectory): XYZ correction polynomials in time per strip"
        ),
        strips={
            s: {"returns": f.count, "t_start": f.t_start, "t_end": f.t_end, "planar_cells": int(f.cells.cells.size),
                "patches": int(f.patches.cells.size)}
            for s, f in block.found.items()
        },
        patches={k: int(sum(1 for x in block.kinds if x == k)) for k in ("tie", "control", "height", "check")},
        sigma0=st.sigma0,
        accounting=st.accounting.as_dict(),
        converged=result.solution.converged,
        estimates=estimates(result, keys, block_unit(block)),
        tilts=tilt_tests(result, planes),
        regularised=[Regularised(r.key, r.component, r.sigma, r.reason) for r in result.solution.regularisation],
        rejections=[Rejection(r.group, r.id, r.w, r.round, mdb.get((r.group, r.id), float("nan")))
                    for r in result.rejections],
        notes=list(block.notes),
        evaluation=evaluation.summary() if evaluation is not None else None,
        variant=v.name,
        options={"strategy": v.strategy, "description": v.description, "position_degree": v.position_degree,
                 "attitude_degree": v.attitude_degree, "calibrate": list(v.calibrate),
                 "patch_search": block.options.patch_search},
        patch_map=_patch_map(block),
    )
