"""Height precision of the mean terrain height of an area, from an error budget.

Each error component averages down differently (all in cm, 1 sigma):

=============  ==========================  ==============================
component      reduced by                  contribution
=============  ==========================  ==============================
seasonal       nothing                     sigma_seasonal
daily          nothing                     sigma_daily
local          number of points N          sigma_local / sqrt(N)
noise          number of points N          sigma_noise / sqrt(N)
short          number of ~100 m pieces     sigma_short / sqrt(pieces)
long           number of strips            sigma_long / sqrt(strips)
offset         only the factor alpha       alpha * sigma_offset
=============  ==========================  ==============================

``total = sqrt(sum of squared contributions)``. ``alpha`` is given, or follows from the covariance
``C`` (m^2) of the offsets of the strips covering the area after a strip adjustment:
``alpha * sigma_offset = sqrt(1^T C 1) / n`` (the standard deviation of the mean offset).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from scangeo.errors import InputFileError, LidarError
from scangeo.textfile import read_text


@dataclass(frozen=True)
class BudgetSigmas:
    """Standard deviations of the components, cm. Defaults: see docs/lidar.md (assumed values)."""

    seasonal: float = 2.0
    daily: float = 1.0
    local: float = 5.0
    noise: float = 3.0
    short: float = 3.0
    long: float = 3.0
    offset: float = 5.0


def area_mean_budget(points: int, pieces: int, strips: int, alpha: float = 1.0,
                     sigmas: BudgetSigmas = BudgetSigmas()) -> dict:
    """Contributions (cm) of every component to the mean height of an area, and the total.

    Returns ``{"total_cm": float, "components": {name: cm}, "alpha": alpha}``.
    """
    for name, value in (("points", points), ("pieces", pieces), ("strips", strips)):
        if value < 1:
            raise LidarError(f"--{name} {value}: expected at least 1")
    if not alpha >= 0:
        raise LidarError(f"--alpha {alpha}: expected >= 0")
    s = sigmas
    components = {
        "seasonal": s.seasonal,
        "daily": s.daily,
        "local": s.local / np.sqrt(points),
        "noise": s.noise / np.sqrt(points),
        "short": s.short / np.sqrt(pieces),
        "long": s.long / np.sqrt(strips),
        "offset": alpha * s.offset,
    }
    total = float(np.sqrt(sum(v * v for v in components.values())))
    return {"total_cm": total, "components": {k: float(v) for k, v in components.items()}, "alpha": float(alpha)}


def alpha_from_covariance(path: str | Path, sigma_offset_cm: float) -> float:
    """alpha from an offset covariance matrix file (m^2; ``.npy`` or whitespace-separated text)."""
    path = Path(path)
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
    if sigma_offset_cm <= 0:
        raise LidarError(f"--sigma-offset {sigma_offset_cm}: expected > 0 with --offset-covariance")
    n = C.shape[0]
    sigma_mean_cm = 100.0 * np.sqrt(max(C.sum(), 0.0)) / n
    return float(sigma_mean_cm / sigma_offset_cm)


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
    """Budget of one scenario: area of ``area_m2`` (default a 100 m x 100 m block cell)."""
    side = np.sqrt(area_m2)
    points = max(int(scenario.density * area_m2), 1)
    pieces = scenario.flights * max(int(np.ceil(side / 100.0)), 1)
    strips = scenario.flights
    out = area_mean_budget(points, pieces, strips, scenario.alpha, sigmas)
    return {**asdict(scenario), "points": points, "pieces": pieces, "strips": strips, **out}


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
