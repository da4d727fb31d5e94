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
from scangeo.lidar.keys import Plane, RangeOffset
from scangeo.lsq.engine import Adjustment
from scangeo.lsq.keys import Key
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
    group: str
    patch: str
    w: float
    round: int


@dataclass(frozen=True)
class TiltTests:
    """The t-tests of the patch planes' tilts (u, v), per patch kind: how many, how many significant."""

    patches: int
    significant: int
    max_t: float


@dataclass
class LaserResult:
    """What ``scangeo lidar adjust`` found (:func:`scangeo.lidar.workflow.adjust_laser`)."""

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

    @property
    def calibration(self) -> list[Estimate]:
        return [e for e in self.estimates if e.is_calibration]

    @property
    def corrections(self) -> list[Estimate]:
        return [e for e in self.estimates if isinstance(e.key, Correction)]

    def to_dict(self) -> dict:
        """``results.json``."""
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
        }


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
