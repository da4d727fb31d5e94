"""How the adjusted unknowns move where a strip's pixels land on the ground.

For image positions ``(line, pixel)`` of a strip, the adjusted geometry gives their ground points on the
DTM; linearising the image observation of those points (held fixed) with respect to every unknown of
the adjustment, and of the points' own horizontal coordinates, gives

    dG_xy = -(dimage/dG_xy)^-1 dimage/dx

the horizontal shift (x, y in metres, project frame, at fixed height) of each position's ground point
for a change ``dx`` of the unknowns. The reliability's orientation probes
(:mod:`scangeo.adjustment.reliability_summary`) and the co-registration of a platform's sensors
(:mod:`scangeo.adjustment.coregistration`) are built on it.
"""
from __future__ import annotations

from collections import ChainMap
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from scangeo.adjustment.image import ImageObservations
from scangeo.adjustment.keys import Ground
from scangeo.adjustment.results import VariantResult
from scangeo.lsq.parameters import JacobianPart, Layout, Parameters


@dataclass(frozen=True)
class GroundSensitivity:
    """Image positions of a strip that hit the DTM (``line``, ``pixel``; ``index`` into the positions
    asked for), their ground points ``p_P`` (k, 3) in the project frame, and ``matrix`` (2 k x n, CSR):
    the horizontal shift of each ground point per unknown (the adjustment's layout columns, unscaled)."""

    strip: str
    index: np.ndarray
    line: np.ndarray
    pixel: np.ndarray
    p_P: np.ndarray
    matrix: sp.csr_matrix


def image_grid(result: VariantResult, strip: str, grid: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """A regular grid of ``grid[0]`` lines by ``grid[1]`` pixels over a strip's image (lines, pixels flat)."""
    g = result.geometry(strip)
    L, X = np.meshgrid(np.linspace(0.0, g.n_lines - 1.0, grid[0]),
                       np.linspace(0.0, g.sensor.pixels - 1.0, grid[1]), indexing="ij")
    return L.ravel(), X.ravel()


def ground_sensitivity(result: VariantResult, strip: str, line: np.ndarray, pixel: np.ndarray,
                       values=None) -> GroundSensitivity | None:
    """How the unknowns move the ground points of a strip's image positions (module docstring).

    Parameters
    ----------
    result : VariantResult
        The adjusted variant.
    strip : str
        The strip's id.
    line, pixel : (m,) ndarray
        Image positions (lines, pixels) of the strip.
    values : mapping of Key to ndarray, optional
        The adjusted unknowns (default: the solution's; pass them when probing many strips).

    Returns
    -------
    GroundSensitivity or None
        The positions that hit the DTM with their ground points and the sensitivity matrix; None when
        none does.
    """
    sol = result.adjustment.solution
    values = sol.parameters.values() if values is None else values
    project = result.block.project
    s = result.block.strips[strip]
    geometry = result.geometry(strip)
    line, pixel = np.asarray(line, float), np.asarray(pixel, float)
    p_P, _ = geometry.image_to_ground(line, pixel, project.dtm)
    ok = np.isfinite(p_P).all(axis=1)
    if not ok.any():
        return None
    scanner = project.scanner_of(strip)
    ids = [f"probe {strip} {k}" for k in range(int(ok.sum()))]
    probe = ImageObservations(strip, scanner.model, s.spline, project.timing(strip), ids, line[ok], pixel[ok], 1.0,
                              name=f"probe {strip}", measured_time=scanner.measured_time,
                              flight_line=s.flight_line, sensor_id=s.sensor)
    keys = [Ground(i) for i in ids]
    lin = probe.linearise(ChainMap(dict(zip(keys, p_P[ok])), values))
    # columns of the adjustment (probe points fixed), and of the probe points alone (x, y free)
    inside, outside = _split_parts(lin.parts, set(keys))
    J_x = sol.layout.matrix(outside, probe.n_rows).tocsr()
    J_g = _probe_layout(keys, p_P[ok]).matrix(inside, probe.n_rows).toarray()   # d(line, pixel)/d(x, y)
    blocks = [np.linalg.inv(J_g[2 * i:2 * i + 2, 2 * i:2 * i + 2]) for i in range(len(ids))]
    M = -(sp.block_diag(blocks, format="csr") @ J_x)
    return GroundSensitivity(strip, np.flatnonzero(ok), line[ok], pixel[ok], p_P[ok], M.tocsr())


def _probe_layout(keys: list[Ground], p_P: np.ndarray) -> Layout:
    """The columns of the probe points alone: x, y free, z fixed (positions on the DTM)."""
    params = Parameters()
    for k, p in zip(keys, p_P):
        params.add(k, p, free=np.array([True, True, False]))
    return Layout.of(params)


def _split_parts(parts, keys: set) -> tuple[list[JacobianPart], list[JacobianPart]]:
    """The Jacobian parts' entries with respect to ``keys`` and those with respect to any other key."""
    inside: list[JacobianPart] = []
    outside: list[JacobianPart] = []
    for part in parts:
        if part.block is None:
            (inside if part.keys[0] in keys else outside).append(part)
            continue
        r, c, v, b = (np.ravel(a) for a in np.broadcast_arrays(part.rows, part.cols, part.values, part.block))
        is_key = np.array([k in keys for k in part.keys], dtype=bool)
        for side, sel in ((inside, is_key[b]), (outside, ~is_key[b])):
            own = np.flatnonzero(is_key == (side is inside))   # the part's keys on this side, renumbered
            number = np.full(len(part.keys), -1, dtype=np.int64)
            number[own] = np.arange(own.size)
            if own.size:
                side.append(JacobianPart([part.keys[k] for k in own], r[sel], c[sel], v[sel], number[b[sel]]))
    return inside, outside


__all__ = ["GroundSensitivity", "ground_sensitivity", "image_grid"]
