"""Planning: the reliability of a block before the flight, from its geometry alone.

Redundancy numbers, MDBs and external reliability depend on the geometry and the sigmas, not on the
measurements. :func:`plan_block` takes a project whose strips hold the *planned* trajectories (e.g.
written by ``scangeo simulate``; the GPS/IMU as planned), the planned control in ``ground.csv``
(optional) and a grid of tie points, makes the image measurements by projecting every point into
every strip that sees it (``StripGeometry.ground_to_image`` with the planned orientation), adjusts
the variant once (no blunders, no snooping: the measurements fit exactly) and computes the
reliability (:mod:`scangeo.adjustment.reliability_summary`).

Tie points: a square grid of ``tie_spacing_m`` over the block on the DTM, each kept where at least
two strips see it; ``points.csv`` of the project, if any, is not read (no measurements needed).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from scangeo.adjustment.block import adjust_variant
from scangeo.adjustment.reliability_summary import VariantReliability, variant_reliability
from scangeo.adjustment.results import CheckResiduals, VariantResult
from scangeo.adjustment.variants import Variant, find_variant
from scangeo.errors import AdjustmentError
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from scangeo.progress import ProgressCallback, no_progress

#: Probe grid of the planning maps (lines x pixels per strip): denser than for an adjusted variant.
PLAN_GRID = (25, 9)
#: Image measurements closer than this to the image's edge (pixels, lines) are not planned.
EDGE = 5.0


@dataclass
class Plan:
    """A planned block: its variant result (planned measurements, exact fit) and reliability."""

    result: VariantResult
    reliability: VariantReliability
    tie_points: int
    control_points: int


def _empty_ground() -> GroundPoints:
    e = np.zeros(0)
    return GroundPoints(e.astype(object), np.zeros((0, 3)), e, e, e.astype(object), e.astype(int), "<planned>")


def block_extent(project: Project) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) in map coordinates of the strips' footprints on the DTM."""
    xs, ys = [], []
    for s in project.strips:
        g = project.geometry(s.id)
        L, X = np.meshgrid(np.linspace(0, g.n_lines - 1, 11), [0.0, g.sensor.pixels - 1.0])
        p_P, _ = g.image_to_ground(L.ravel(), X.ravel(), project.dtm)
        ok = np.isfinite(p_P).all(axis=1)
        x, y, _ = project.map_frame.project_to_map(p_P[ok])
        xs.append(x)
        ys.append(y)
    x, y = np.concatenate(xs), np.concatenate(ys)
    if not x.size:
        raise AdjustmentError(f"{project.root}: no strip's image reaches the DTM with the planned orientation")
    return float(x.min()), float(y.min()), float(x.max()), float(y.max())


def planned_measurements(project: Project, names, xyz: np.ndarray, sigma_px: float) -> ImagePoints:
    """Image measurements of map points ``xyz`` (n, 3; orthometric H) in every strip that sees them."""
    p_P = project.map_frame.map_to_project(xyz[:, 0], xyz[:, 1], xyz[:, 2])
    pts, strips, lines, pixels = [], [], [], []
    for s in project.strips:
        g = project.geometry(s.id)
        line, pixel, status = g.ground_to_image(p_P)
        inside = ((status == 0) & (line >= EDGE) & (line <= g.n_lines - 1 - EDGE)
                  & (pixel >= EDGE) & (pixel <= g.sensor.pixels - 1 - EDGE))
        k = np.flatnonzero(inside)
        pts.append(np.asarray(names, dtype=object)[k])
        strips.append(np.full(k.size, s.id, dtype=object))
        lines.append(line[k])
        pixels.append(pixel[k])
    n = sum(a.size for a in pts)
    return ImagePoints(np.concatenate(pts), np.concatenate(strips), np.concatenate(lines), np.concatenate(pixels),
                       np.full(n, sigma_px), np.zeros(n, int), "<planned>")


def plan_block(project_root, variant: str | Variant = "SE", variants_file=None, tie_spacing_m: float = 500.0,
               sigma_px: float = 0.3, callback: ProgressCallback = no_progress) -> Plan:
    """The reliability of the planned block (see the module's docstring).

    Parameters
    ----------
    project_root : the project folder (planned trajectories in project.toml, planned control in
        ground.csv, optional).
    variant : the adjustment variant to plan for (name or :class:`Variant`).
    tie_spacing_m : grid spacing of the planned tie points (m, map units).
    sigma_px : measurement sigma (pixels) unless the variant sets ``image_sigma_px``.
    """
    t0 = time.perf_counter()
    project = Project.from_user_input(project_root)
    v = variant if isinstance(variant, Variant) else find_variant(project.root, variant, variants_file)
    if not tie_spacing_m > 0:
        raise AdjustmentError(f"tie point spacing must be positive, not {tie_spacing_m}")
    ground_file = project.root / "ground.csv"
    ground = GroundPoints.read(ground_file) if ground_file.exists() else _empty_ground()
    callback(0.0, 1.0, "planning: tie points")
    xmin, ymin, xmax, ymax = block_extent(project)
    gx, gy = np.meshgrid(np.arange(xmin + tie_spacing_m / 2, xmax, tie_spacing_m),
                         np.arange(ymin + tie_spacing_m / 2, ymax, tie_spacing_m))
    gx, gy = gx.ravel(), gy.ravel()
    H = project.dtm.height_at_map(gx, gy)
    ok = np.isfinite(H)
    tie_names = np.array([f"PLAN{k:05d}" for k in range(int(ok.sum()))], dtype=object)
    sigma = sigma_px if v.image_sigma_px is None else float(v.image_sigma_px)
    ties = planned_measurements(project, tie_names, np.column_stack([gx[ok], gy[ok], H[ok]]), sigma)
    used = {p for p, c in zip(*np.unique(ties.point.astype(str), return_counts=True)) if c >= 2}
    keep = np.isin(ties.point.astype(str), list(used))
    ctrl = planned_measurements(project, ground.point, ground.xyz, sigma) if len(ground) else None
    parts = [ties] + ([ctrl] if ctrl is not None else [])
    cat = [np.concatenate([getattr(p, f)[keep] if p is ties else getattr(p, f) for p in parts])
           for f in ("point", "strip", "line", "pixel", "sigma_px", "file_line")]
    points = ImagePoints(cat[0], cat[1], cat[2], cat[3], cat[4], cat[5], "<planned>")
    callback(0.2, 1.0, "planning: adjustment")
    block, adj = adjust_variant(project, v, points, ground, snooping=False)
    e = np.zeros(0)
    result = VariantResult(block, adj, CheckResiduals(e.astype(object), e.astype(object), e, e, e.astype(int), e),
                           time.perf_counter() - t0, list(block.notes))
    callback(0.6, 1.0, "planning: reliability")
    rel = variant_reliability(result, grid=PLAN_GRID)
    n_ctrl = len({str(p) for p in (ctrl.point if ctrl is not None else [])
                  if block.role(str(p)) in ("control", "height", "planimetric")})
    callback(1.0, 1.0, "planning: done")
    return Plan(result, rel, len(used), n_ctrl)


__all__ = ["PLAN_GRID", "Plan", "block_extent", "plan_block", "planned_measurements"]
