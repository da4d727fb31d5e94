"""Height precision of the mean terrain height of an area, from an error budget.

Each error component averages down differently (all in metres, 1 sigma):

=============  ==========================  ==============================
component      reduced by                  contribution
=============  ==========================  ==============================
seasonal       nothing                     sigma_seasonal
daily          nothing                     sigma_daily
local          number of points N          sigma_local / sqrt(N)
noise          number of points N          sigma_noise / sqrt(N)
short          number of ~100 m pieces     sigma_short / sqrt(pieces)
long           number of strips            sigma_long / sqrt(n_strips)
offset         only the factor alpha       alpha * sigma_offset
=============  ==========================  ==============================

``total = sqrt(sum of squared contributions)``. ``alpha`` is given, or follows from the covariance
``C`` (m^2) of the offsets of the strips covering the area after a strip adjustment:
``alpha * sigma_offset = sqrt(1^T C 1) / n`` (the standard deviation of the mean offset).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import ClassVar

import numpy as np

from scangeo.errors import ArgumentError, InputFileError, OptionsError
from scangeo.io.schema import check, setting
from scangeo.textfile import read_text


@dataclass(frozen=True)
class BudgetSigmas:
    """Standard deviations of the budget's components (m, 1 sigma). The defaults are assumed typical
    values, not measured ones (docs/lidar.md, "Height precision of an area's mean height").

    Parameters
    ----------
    seasonal, daily, local, noise, short, long, offset : float
        One component's standard deviation, m (>= 0; 0 leaves the component out).

    Raises
    ------
    OptionsError
        ``BudgetSigmas.noise: expected a number >= 0 (m), found -0.01``.
    """

    schema_error: ClassVar[type[Exception]] = OptionsError

    seasonal: float = setting(0.02, unit="m", ge=0, doc="vegetation/soil/snow state between seasons on open ground")
    daily: float = setting(0.01, unit="m", ge=0, doc="day-to-day change (moisture, grass)")
    local: float = setting(0.05, unit="m", ge=0, doc="micro-relief of open terrain within the area")
    noise: float = setting(0.03, unit="m", ge=0, doc="ranging noise per return (current ALS systems: 0.02-0.05 m)")
    short: float = setting(0.03, unit="m", ge=0, doc="short-wave (~100 m) strip errors: IMU noise, GPS high frequency")
    long: float = setting(0.03, unit="m", ge=0, doc="long-wave strip errors: GPS drift within a strip")
    offset: float = setting(0.05, unit="m", ge=0, doc="strip height offset before a strip adjustment")

    def __post_init__(self) -> None:
        check(self)


def area_mean_budget(points: int, pieces: int, n_strips: int, alpha: float = 1.0,
                     sigmas: BudgetSigmas = BudgetSigmas()) -> dict:
    """Contributions of every component to the mean height of an area, and the total.

    Parameters
    ----------
    points : int
        Number of points in the area (>= 1).
    pieces : int
        Number of ~100 m strip pieces in the area (>= 1).
    n_strips : int
        Number of strips covering the area (>= 1).
    alpha : float
        Offset reduction factor (>= 0; 1: no strip adjustment).
    sigmas : BudgetSigmas
        The components' standard deviations, m.

    Returns
    -------
    dict
        ``{"total_m": float, "components": {name: m}, "alpha": alpha}`` (1 sigma, m).

    Raises
    ------
    ArgumentError
        An argument out of range (``n_strips=0: expected 1 or more``).
    """
    for name, value in (("points", points), ("pieces", pieces), ("n_strips", n_strips)):
        if value < 1:
            raise ArgumentError(f"{{{name}}}: expected 1 or more", **{name: value})
    if not alpha >= 0:
        raise ArgumentError("{alpha}: expected a number >= 0", alpha=alpha)
    s = sigmas
    components = {
        "seasonal": s.seasonal,
        "daily": s.daily,
        "local": s.local / np.sqrt(points),
        "noise": s.noise / np.sqrt(points),
        "short": s.short / np.sqrt(pieces),
        "long": s.long / np.sqrt(n_strips),
        "offset": alpha * s.offset,
    }
    total = float(np.sqrt(sum(v * v for v in components.values())))
    return {"total_m": total, "components": {k: float(v) for k, v in components.items()}, "alpha": float(alpha)}


def alpha_from_covariance(offset_covariance: str | Path, sigma_offset: float) -> float:
    """alpha from an offset covariance matrix file.

    Parameters
    ----------
    offset_covariance : str or Path
        The covariance (m^2) of the offsets of the strips covering the area: ``.npy`` or a
        whitespace-separated text matrix.
    sigma_offset : float
        The strip offset's standard deviation before the adjustment, m (> 0).

    Returns
    -------
    float
        ``sqrt(1^T C 1) / n / sigma_offset``: the mean offset's standard deviation over ``sigma_offset``.

    Raises
    ------
    InputFileError
        The file cannot be read or is not a symmetric square matrix.
    ArgumentError
        ``sigma_offset`` not > 0.
    """
    path = Path(offset_covariance)
    lines = None if path.suffix == ".npy" else read_text(path, "a covariance matrix (text)").splitlines()
    try:
        C = np.load(path) if lines is None else np.loadtxt(lines, ndmin=2)
    except (OSError, ValueError) as exc:
        raise InputFileError(f"{path}: cannot read an offset covariance matrix ({exc})") from exc
    C = np.atleast_2d(np.asarray(C, dtype=float))
    if C.shape[0] != C.shape[1] or not np.allclose(C, C.T, atol=1e-12 * max(np.abs(C).max(), 1e-30)):
        raise InputFileError(
            f"{path}: a {C.shape[0]}x{C.shape[1]} matrix, expected a symmetric square covariance (m^2)"
        )
    if not sigma_offset > 0:
        raise ArgumentError("{sigma_offset}: expected a number > 0 (alpha is the mean offset's sigma over it)",
                            sigma_offset=sigma_offset)
    n = C.shape[0]
    sigma_mean = np.sqrt(max(C.sum(), 0.0)) / n
    return float(sigma_mean / sigma_offset)


@dataclass(frozen=True)
class FlightScenario:
    """A flight scenario for the cost-benefit table (area mean over ``area_m2``)."""

    name: str
    density: float  # points per m^2 (all flights together)
    control_areas: int
    flights: int = 1  # how often the block is flown
    alpha: float = 1.0
    relative_cost: float = 1.0


def scenario_row(
    scenario: FlightScenario, area_m2: float = 100.0 * 100.0, sigmas: BudgetSigmas = BudgetSigmas()
) -> dict:
    """Budget of one scenario over an area of ``area_m2`` (default a 100 m x 100 m block cell).

    Returns
    -------
    dict
        The scenario's fields, its ``points``, ``pieces`` and ``n_strips``, and
        :func:`area_mean_budget`'s ``total_m``, ``components`` (m) and ``alpha``.
    """
    side = np.sqrt(area_m2)
    points = max(int(scenario.density * area_m2), 1)
    pieces = scenario.flights * max(int(np.ceil(side / 100.0)), 1)
    n_strips = scenario.flights
    out = area_mean_budget(points, pieces, n_strips, scenario.alpha, sigmas)
    return {**asdict(scenario), "points": points, "pieces": pieces, "n_strips": n_strips, **out}


def default_scenarios(alpha_few: float, alpha_many: float) -> list[FlightScenario]:
    """Standard comparison: density, number of control areas, flying twice.

    ``alpha_few``/``alpha_many``: offset reduction with few/many control areas (e.g. from the
    network design of :mod:`scangeo.lidar.network`). Relative cost model (illustrative, documented):
    one flight at 1 pt/m^2 = 1; cost grows with sqrt(density) per flight (lower and slower flying);
    each control area costs 0.02.
    """
    base = FlightScenario("1 pt/m2, 4 control areas", 1.0, 4, 1, alpha_few, 1.0 + 4 * 0.02)
    return [
        base,
        replace(base, name="4 pt/m2, 4 control areas", density=4.0, relative_cost=2.0 + 4 * 0.02),
        replace(
            base, name="1 pt/m2, 12 control areas", control_areas=12, alpha=alpha_many, relative_cost=1.0 + 12 * 0.02
        ),
        replace(
            base,
            name="flown twice, 2 pt/m2, 4 control areas",
            density=2.0,
            flights=2,
            alpha=alpha_few / np.sqrt(2.0),
            relative_cost=2.0 + 4 * 0.02,
        ),
    ]
