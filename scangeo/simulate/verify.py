"""What a correction strategy could achieve at best on a simulated block (an oracle, from truth/).

For every strip, the image measurements of all its points (true ground coordinates from
truth/points.csv) are projected through the GPS/IMU trajectory as measured (direct
georeferencing, project.toml's mounting), and a correction of the strategy's form is fitted to them
by linearised least squares (numerical derivatives, iterated twice):

* ``DG``: no correction;
* ``SE``: constant position (3) and attitude (3) offsets;
* ``P<d>``: position polynomials of degree d in normalised time (3 (d + 1)) plus constant attitude;
* ``S<d>``: the strip split at break lines into pieces with position polynomials of degree d,
  continuous at the breaks (C0), plus constant attitude.

With every point used as if it were control, the residuals are the part of the injected GPS/IMU
error that the strategy cannot model, plus the measurement noise: a lower bound of what an
adjustment with real control and tie points reaches, used to check that a preset shows the intended
physics (docs/simulate.md) and by the lead to verify adjustments against truth.
"""
from __future__ import annotations

import csv
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.io.project import Project


@dataclass(frozen=True)
class StripFit:
    """Residual rms (along track in lines, across track in pixels) of one strip under one strategy."""

    strip: str
    strategy: str
    n: int
    rms_along: float
    rms_across: float


def _read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def correction_basis(tau: np.ndarray, strategy: str, tau_breaks: list[float]) -> np.ndarray:
    """Basis functions (n, m) of one position component's correction in normalised time tau."""
    if strategy == "SE":
        return np.ones((tau.size, 1))
    kind, degree = strategy[0], int(strategy[1:] or 0)
    if kind == "P":
        return np.column_stack([tau**k for k in range(degree + 1)])
    if kind == "S":
        knots = np.concatenate([[-1.0], np.sort(tau_breaks), [1.0]])
        cols = [np.interp(tau, knots, np.eye(len(knots))[i]) for i in range(len(knots))]  # C0 hats
        for a, b in zip(knots[:-1], knots[1:]):
            u = np.clip((tau - a) / (b - a), 0.0, 1.0)
            inside = (tau >= a) & (tau <= b)
            for k in range(2, degree + 1):  # bubbles vanishing at both ends of the piece
                cols.append(np.where(inside, (u * (1 - u)) * (2 * u - 1) ** (k - 2), 0.0))
        return np.column_stack(cols)
    raise ValueError(f"unknown strategy {strategy!r} (DG, SE, P<d>, S<d>)")


def fit_strategy(project: Project, strip_id: str, p_P: np.ndarray, line: np.ndarray, pixel: np.ndarray,
                 strategy: str, breaks_lines: Sequence[float] = ()) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (measured - projected) along (lines) and across (pixels) after the best correction."""
    base = project.geometry(strip_id)
    spline = base.spline
    timing = project.timing(strip_id)
    n_lines = project.n_lines(strip_id)
    t_a, t_b = float(timing.time_of_line(np.array([0.0]))[0]), float(timing.time_of_line(np.array([n_lines - 1.0]))[0])
    knot_tau = 2.0 * (spline.knot_times - t_a) / (t_b - t_a) - 1.0
    tau_breaks = [2.0 * (float(timing.time_of_line(np.array([b]))[0]) - t_a) / (t_b - t_a) - 1.0 for b in breaks_lines]

    def project_with(params: np.ndarray, basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        coef = spline.coef.copy()
        m = basis.shape[1]
        for c in range(3):
            coef[:, c] += basis @ params[c * m:(c + 1) * m]
        coef[:, 3:] += params[3 * m:]
        g = project.geometry(strip_id, spline=spline.with_coef(coef))
        ln, px, _ = g.ground_to_image(p_P)
        return ln, px

    if strategy == "DG":
        ln, px = project_with(np.zeros(3), np.zeros((len(knot_tau), 0)))
        return line - ln, pixel - px
    # a B-spline reproduces polynomials from the knot-centred coefficient values only approximately;
    # the correction functions are smooth at the knot spacing, so this is far below a pixel
    basis = correction_basis(knot_tau, strategy, tau_breaks)
    n_par = 3 * basis.shape[1] + 3
    params = np.zeros(n_par)
    steps = np.r_[np.full(3 * basis.shape[1], 0.5), np.full(3, 2e-4)]
    for _ in range(2):
        ln, px = project_with(params, basis)
        r = np.r_[line - ln, pixel - px]
        J = np.empty((r.size, n_par))
        for k in range(n_par):
            d = np.zeros(n_par)
            d[k] = steps[k]
            l2, p2 = project_with(params + d, basis)
            J[:, k] = np.r_[l2 - ln, p2 - px] / steps[k]
        ok = np.isfinite(r) & np.isfinite(J).all(axis=1)
        params = params + np.linalg.lstsq(J[ok], r[ok], rcond=None)[0]
    ln, px = project_with(params, basis)
    return line - ln, pixel - px


def oracle_table(project_dir: str | Path, strategies=("DG", "SE", "P4", "S2"), kinds: str = "EBKHT") -> list[StripFit]:
    """Best-achievable residual rms per strip and strategy of a simulated project (see module doc)."""
    root = Path(project_dir)
    project = Project.load(root)
    info = json.loads((root / "truth" / "errors.json").read_text())
    truth = {row["point"]: row for row in _read_csv(root / "truth" / "points.csv")}
    rows = [r for r in _read_csv(root / "truth" / "measurements.csv")
            if truth[r["point"]]["kind"] in kinds and r["blunder"] == "0"]
    out = []
    for s in project.strips:
        mine = [r for r in rows if r["strip"] == s.id]
        p_P = np.array([[float(truth[r["point"]][k]) for k in ("x_P", "y_P", "z_P")] for r in mine])
        line = np.array([float(r["line"]) for r in mine])
        pixel = np.array([float(r["pixel"]) for r in mine])
        breaks = info["breaks_lines"] if s.id == info.get("problem_strip") else []
        for strategy in strategies:
            if strategy[0] == "S" and strategy != "SE" and not breaks:
                continue
            ra, rc = fit_strategy(project, s.id, p_P, line, pixel, strategy, breaks)
            out.append(StripFit(s.id, strategy, len(mine), float(np.sqrt(np.nanmean(ra**2))),
                                float(np.sqrt(np.nanmean(rc**2)))))
    return out
