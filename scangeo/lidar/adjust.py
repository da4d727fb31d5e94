"""Simultaneous georeferencing of laser strips with tie patches (Kager 2003) in the common engine.

Set-up (:func:`build`): patch finding in every strip (in parallel with ``workers``), homologous tie
patches, control and check patches from ground.csv, anchors (three per patch and strip, with their
original observations recovered from the trajectory and the nominal calibration), the variant's
GPS/IMU models (correction polynomials per strip, split at breaks, per mission or for the block; a
:class:`~scangeo.adjustment.variants.Variant` as for images), its priors (preventive regularisation:
coefficients of degree >= 1, and optionally the constants, = 0 with a sigma;
:mod:`scangeo.adjustment.priors`), the calibration blocks, the observation groups of ``groups.py``.
Then :func:`scangeo.lsq.engine.adjust` with the variant's data snooping. Two modes:

- ``trajectory``: every strip has a trajectory; unknowns are the position and attitude correction
  polynomials, boresight (and optionally lever arm, range offset, scan-angle index), the planes;
- ``points`` (the paper's provisional solution): point clouds with GPS time only; per strip an XYZ
  correction polynomial in time, added to the points, in the map CRS's units.

``[adjustment]`` keys of project.toml (all optional, the patch search) are the fields of
:class:`LaserOptions`; what is adjusted is the variant's.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pyproj

from scangeo.adjustment.priors import (
    ANGLE_REGULARISATION_RAD,
    LEVER_ARM_REGULARISATION_M,
    RANGE_OFFSET_REGULARISATION_M,
    add_calibration,
    correction_sigmas,
    snooping_options,
)
from scangeo.adjustment.variants import Variant
from scangeo.errors import LidarError
from scangeo.io.project import LaserSensor, Project, StripConfig
from scangeo.lidar.control import GivenPatches, read_patch_ground
from scangeo.lidar.georeference import Calibration, Polar, TrajectorySampler, georeference, recover
from scangeo.lidar.groups import ControlPatchPoints, PatchFrames, StripAnchors, laser_calibration_keys
from scangeo.lidar.options import LaserOptions
from scangeo.lidar.patches import PatchOptions, TiePatch, grid_name, homologous
from scangeo.lidar.planes import ANCHORS, anchors
from scangeo.lidar.search import MIN_RETURNS_PER_LINE, StripFound, find_all, seed_name
from scangeo.lsq.engine import Adjustment, adjust
from scangeo.lsq.observations import ObservationGroup
from scangeo.lsq.parameters import Parameters
from scangeo.lsq.solver import SolverOptions
from scangeo.orientation.models import ModelSet, group_model, strip_models
from scangeo.progress import ProgressCallback, no_progress

log = logging.getLogger(__name__)

@dataclass
class LaserBlock:
    """The adjustment problem and what is needed to apply its result."""

    project: Project
    options: LaserOptions
    variant: Variant
    mode: str
    found: dict[str, StripFound]
    ties: list[TiePatch]
    given: GivenPatches | None
    frames: PatchFrames
    kinds: list[str]  # per patch: tie, control, check
    models: ModelSet
    parameters: Parameters
    groups: list
    samplers: dict[str, TrajectorySampler]
    nominal: Calibration
    reference: np.ndarray  # work frame origin in map coordinates (points mode)
    anchors: dict[str, dict]  # strip -> arrays of its anchors (all patches, check included)
    notes: list[str] = field(default_factory=list)
    sensor: str = ""  # the laser's id (its calibration keys); "": the one sensor of a laser project
    lines: dict[str, str] = field(default_factory=dict)  # strip -> the id its GPS/IMU models serve (its flight line)

    def line(self, strip: str) -> str:
        """The id the GPS/IMU models serve ``strip`` under: its flight line on a platform, else the strip."""
        return self.lines.get(strip, strip)

    def to_work(self, xyz: np.ndarray) -> np.ndarray:
        if self.mode == "trajectory":
            return self.project.map_frame.map_to_project(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        return xyz - self.reference

    def to_map(self, p: np.ndarray) -> np.ndarray:
        if self.mode == "trajectory":
            return np.column_stack(self.project.map_frame.project_to_map(p))
        return p + self.reference


def _models(found: dict[str, StripFound], variant: Variant, mode: str, missions: dict[str, str]) -> ModelSet:
    """The variant's GPS/IMU models (the shared builder of :mod:`scangeo.orientation.models`): none (DG),
    one for the block (BE), one per mission (ME), or one per strip split at its breaks (SE, P, S)."""
    if variant.strategy == "DG":
        return ModelSet([])
    if variant.strategy in ("BE", "ME"):
        adeg = variant.attitude_degree if mode == "trajectory" else -1
        groups: dict[str, list[str]] = {}
        for sid in found:
            groups.setdefault("block" if variant.strategy == "BE" else f"mission {missions[sid]}", []).append(sid)
        return ModelSet([
            group_model(gid, sids, min(found[s].t_start for s in sids), max(found[s].t_end for s in sids) + 1e-6,
                        variant.position_degree, adeg)
            for gid, sids in groups.items()
        ])
    models = []
    for sid, f in found.items():
        cfg = variant.strip_models(sid)
        pdeg = variant.position_degree if cfg.position_degree is None else cfg.position_degree
        adeg = variant.attitude_degree if cfg.attitude_degree is None else cfg.attitude_degree
        edges = [f.t_start] + sorted(float(b) for b in cfg.breaks_times) + [f.t_end + 1e-6]
        models += strip_models(sid, edges, pdeg, adeg if mode == "trajectory" else -1)
    return ModelSet(models)


def _priors(params: Parameters, models: ModelSet, variant: Variant, unit: float, mode: str) -> None:
    """The correction coefficients with the variant's priors (:func:`scangeo.adjustment.priors.correction_sigmas`);
    without a trajectory the constant position terms are held within 0.3 m unless the variant says
    otherwise (flat patches do not determine horizontal shifts)."""
    for m in models:
        names = m.names()
        prior, regularisation = correction_sigmas(m, variant, unit, None if mode == "trajectory" else 0.3)
        params.add(m.key, np.zeros(len(names)), True, prior_sigma=prior, prior_values=np.zeros(len(names)),
                   regularisation_sigma=regularisation, names=names, conditions=m.conditions)


def nominal_calibration(sensor: LaserSensor) -> Calibration:
    """The scanner's calibration as project.toml gives it (radians and metres)."""
    return Calibration.of(np.radians(sensor.boresight_deg), sensor.lever_arm_m, sensor.range_offset_m,
                          np.radians(sensor.index_error_deg))


def strip_trajectory(project: Project, strip: StripConfig):
    """The strip's GPS/IMU in the project frame (ProjectTrajectory)."""
    return project.stream(strip.id).to_project(project.map_frame.frame)


def _sampler(project: Project, strip: StripConfig, f: StripFound) -> TrajectorySampler:
    sampler = TrajectorySampler(strip_trajectory(project, strip), str(strip.trajectory))
    lo, hi = sampler.span
    if f.t_start < lo or f.t_end > hi:
        raise LidarError(
            f"strip {strip.id}: the returns' GPS times {f.t_start:.3f}..{f.t_end:.3f} s are not covered by "
            f"its trajectory {strip.trajectory} ({lo:.3f}..{hi:.3f} s)"
        )
    return sampler


def map_unit(crs) -> float:
    """Metres per unit of the map CRS's first axis (1 for metres, 0.3048... for feet)."""
    info = pyproj.CRS.from_user_input(crs).axis_info
    return float(info[0].unit_conversion_factor) if info else 1.0


def _mode(project: Project, options: LaserOptions) -> str:
    mode = options.mode
    if mode == "auto":
        mode = "trajectory" if project.has_trajectories else "points"
    if mode == "trajectory" and not project.has_trajectories:
        missing = [s.id for s in project.strips if not s.has_trajectory]
        raise LidarError(f"mode trajectory: strip {missing[0]} has no trajectory in project.toml")
    return mode


def _search_notes(found: dict[str, StripFound], ties: list[TiePatch], options: LaserOptions, seeded: bool) -> list[str]:
    what = "candidates" if seeded else "planar cells"
    notes = [
        f"{len(ties)} tie patches in {len(found)} strips ("
        + ", ".join(
            f"{s}: {f.candidates.size if f.candidates is not None else f.patches.cells.size} {what}"
            for s, f in found.items()
        )
        + ")"
    ]
    if options.patch_search == "rows" and not seeded:
        notes.append(f"patch_search rows: fewer than {MIN_RETURNS_PER_LINE} returns per scan line in a strip "
                     "(a thinned or resampled cloud): the grid cells are the patches")
    return notes


def _patches(ties: list[TiePatch], given: GivenPatches | None, found: dict[str, StripFound], notes: list[str]):
    """Every patch of the adjustment: ids, kinds (tie, control, height, check) and members
    ``[(strip, "cells" | "given", row)]``."""
    ids, kinds, members = [], [], []
    for tie in ties:
        ids.append(tie.id)
        kinds.append("tie")
        members.append([(s, "cells", i) for s, i in tie.members])
    if given is not None:
        for k, pid in enumerate(given.ids):
            mem = [(s, "given", k) for s, f in found.items() if f.given_ok is not None and f.given_ok[k]]
            if not mem:
                notes.append(f"{given.role[k]} patch {pid}: no strip has a planar patch there; left out")
                continue
            ids.append(pid)
            kinds.append(given.role[k])
            members.append(mem)
    if not ids:
        raise LidarError(
            "no tie patch found: the strips do not overlap on planar surfaces (check patch_size and "
            "max_patch_sigma, and that the strips overlap)"
        )
    return ids, kinds, members


def _anchors(block: LaserBlock, members: list, prior: float) -> None:
    """The four anchors of every member, per strip (``block.anchors``), in map and work coordinates.

    Each anchor's sigma is ``2 sigma / sqrt(n)`` (:func:`~scangeo.lidar.planes.anchors`), ``sigma`` the
    plane fit's a posteriori sigma but at least the a priori one, the range noise along the normal
    (``prior`` times the cosine of the incidence, :func:`_incidence_cosine`): estimated from 13-40
    returns, the a posteriori sigma scatters by 11-20 % (chi-square with ``n - 3`` degrees of freedom),
    and a patch it puts low would weigh more than its returns' noise allows (docs/lidar.md, 6.5b).
    """
    per_strip: dict[str, list] = {s: [] for s in block.found}
    for p, mem in enumerate(members):
        for sid, src, i in mem:
            per_strip[sid].append((p, src, i))
    for sid, items in per_strip.items():
        if not items:
            block.notes.append(f"strip {sid} has no patch shared with another strip or control")
            continue
        f = block.found[sid]
        rows_cells = np.array([i for _, src, i in items if src == "cells"], int)
        rows_given = np.array([i for _, src, i in items if src == "given"], int)
        pts, times, sig, fit = [], [], [], []
        for planes, rows in ((f.patches.planes, rows_cells), (f.given, rows_given)):
            if rows.size and planes is not None:
                a, t, s = anchors(planes.take(rows))
                pts.append(a)
                times.append(t)
                floor = prior * _incidence_cosine(block, sid, a, planes.time[rows])
                sig.append(np.maximum(s, floor * 2.0 / np.sqrt(planes.count[rows])))
                fit.append(s)
        patch = np.array([p for p, src, _ in items if src == "cells"] + [p for p, src, _ in items if src == "given"])
        a_map = np.concatenate(pts).reshape(-1, 3)
        block.anchors[sid] = {
            "patch": np.repeat(patch, ANCHORS),
            "map": a_map,
            "work": block.to_work(a_map),
            "time": np.concatenate(times).ravel(),
            "sigma": np.repeat(np.concatenate(sig), ANCHORS),
            "fit_sigma": np.repeat(np.concatenate(fit), ANCHORS),
        }


def _incidence_cosine(block: LaserBlock, strip: str, anchors_map: np.ndarray, time: np.ndarray) -> np.ndarray:
    """``|cos|`` of the angle between each patch's normal and the beam from the strip's trajectory at the
    patch's mean time (1 without a trajectory): the share of the range noise along the normal.

    ``anchors_map`` (m, 4, 3): the four anchors of each patch (map coordinates); ``time`` (m,) seconds.
    """
    sampler = block.samplers.get(strip)
    if sampler is None:
        return np.ones(anchors_map.shape[0])
    w = block.to_work(anchors_map.reshape(-1, 3)).reshape(anchors_map.shape)
    n = np.cross(w[:, 0] - w[:, 1], w[:, 2] - w[:, 3])
    beam = w.mean(axis=1) - sampler.at(time)[0]
    cos = np.abs(np.einsum("ij,ij->i", n, beam)) / (np.linalg.norm(n, axis=1) * np.linalg.norm(beam, axis=1))
    return np.where(np.isfinite(cos), cos, 1.0)


def _frames(ids: list[str], anchor_data: dict[str, dict]) -> PatchFrames:
    """Patch frames (reference point and normal) from the anchors of the member whose plane fit was the
    most precise (by the fit's own sigma, before the a priori floor of :func:`_anchors`)."""
    centre = np.zeros((len(ids), 3))
    normal = np.zeros((len(ids), 3))
    best = np.full(len(ids), np.inf)
    for adata in anchor_data.values():
        w = adata["work"].reshape(-1, ANCHORS, 3)
        pat = adata["patch"][::ANCHORS]
        s = adata["fit_sigma"][::ANCHORS]
        n = np.cross(w[:, 0] - w[:, 1], w[:, 2] - w[:, 3])
        n *= np.where(n[:, 2] < 0, -1.0, 1.0)[:, None]
        for k, p in enumerate(pat):
            if s[k] < best[p]:
                best[p], centre[p], normal[p] = s[k], w[k].mean(axis=0), n[k]
    return PatchFrames.from_points(ids, centre, normal)


def _parameters(block: LaserBlock, unit: float) -> Parameters:
    """Correction coefficients (with their priors), calibration blocks and the patch planes."""
    variant, nominal, mode = block.variant, block.nominal, block.mode
    params = Parameters()
    _priors(params, block.models, variant, unit, mode)
    cal = set(variant.calibrate) if mode == "trajectory" else set()
    bore, lever, offset, index = laser_calibration_keys(block.sensor)
    add_calibration(params, [
        ("boresight", bore, nominal.boresight, ("roll", "pitch", "heading"), ANGLE_REGULARISATION_RAD),
        ("lever_arm", lever, nominal.lever_arm, ("x", "y", "z"), LEVER_ARM_REGULARISATION_M),
        ("range_offset", offset, [nominal.range_offset], ("dr",), RANGE_OFFSET_REGULARISATION_M),
        ("index_error", index, [nominal.scan_index], ("index",), ANGLE_REGULARISATION_RAD),
    ], cal)
    for key, kind in zip(block.frames.keys, block.kinds):
        if kind == "check":
            continue
        params.add(key, np.zeros(3), True, regularisation_sigma=[0.01, 0.01, 1.0 / unit], names=["u", "v", "d"])
    return params


def _groups(block: LaserBlock, ids: list[str], unit: float,
            exclude: frozenset[tuple[str, str]] = frozenset()) -> list[ObservationGroup]:
    """The anchors of every strip (less the ``(strip, patch)`` pairs of ``exclude``) and the surveyed
    points of the control and height patches."""
    groups: list[ObservationGroup] = []
    kinds, given = block.kinds, block.given
    for sid, adata in block.anchors.items():
        use = np.array([kinds[p] != "check" and (sid, ids[p]) not in exclude for p in adata["patch"]])
        if not use.any():
            continue
        patch, work, t, sig = adata["patch"][use], adata["work"][use], adata["time"][use], adata["sigma"][use]
        sampler = block.samplers.get(sid)
        polar = recover(work, t, sampler, block.nominal, solve_time=True) if sampler is not None else None
        groups.append(StripAnchors(sid, patch, patch, sig, block.frames, block.models, work, t, polar, sampler,
                                   block.lines.get(sid), block.sensor))
    if given is None:
        block.notes.append("no ground.csv: no control patches; the datum comes from the GPS/IMU and the priors alone")
        return groups
    used = [k for k, pid in enumerate(given.ids) if given.role[k] != "check" and pid in ids]
    for role, vertical in (("control", False), ("height", True)):
        sel = np.flatnonzero(np.isin(given.point_patch, used) & (given.point_role == role))
        if sel.size:
            patch = np.array([ids.index(given.ids[given.point_patch[i]]) for i in sel])
            groups.append(ControlPatchPoints(given.point_ids[sel], patch, block.to_work(given.xyz[sel]),
                                             given.sigma[sel] / unit, block.frames, vertical))
    if not used:
        block.notes.append("no control patch in the adjustment: the datum comes from the GPS/IMU and the priors alone")
    return groups


def _search_settings(project: Project, options: LaserOptions, mode: str) -> tuple[float, PatchOptions, float]:
    """Metres per work unit, the patch options in work units, the plane fits' a priori sigma."""
    unit = 1.0 if mode == "trajectory" else map_unit(project.crs)
    popt = replace(
        options.patches,
        size=options.patch_size / unit,
        max_sigma=options.max_patch_sigma / unit,
        max_offset=options.max_offset / unit,
        thin_cell=options.thin_cell / unit,
    )
    return unit, popt, project.laser.range_sigma_m / unit


def find_patches(project: Project, options: LaserOptions, ground: Path | None = None,
                 callback: ProgressCallback = no_progress) -> dict[str, StripFound]:
    """The patch search over every strip (:func:`scangeo.lidar.search.find_all`), with the control and
    check patches of ``ground`` (a ground.csv) fitted in every strip too."""
    _, popt, prior = _search_settings(project, options, _mode(project, options))
    given = read_patch_ground(ground) if ground is not None and Path(ground).exists() else None
    return find_all(project, popt, prior, given, options.workers, callback, options.patch_search, options.scheduler)


def tie_patches(project: Project, options: LaserOptions, found: dict[str, StripFound]) -> list[TiePatch]:
    """The homologous patches of the strips' ``found`` patches (what :func:`build` ties them with; it
    depends on the patches and the search settings, not on the variant)."""
    _, popt, _ = _search_settings(project, options, _mode(project, options))
    seeded = any(f.candidates is not None for f in found.values())
    return homologous({s: f.patches for s, f in found.items()}, popt, name=seed_name(found) if seeded else grid_name)


def build(
    project: Project,
    options: LaserOptions,
    variant: Variant,
    ground: Path | None = None,
    callback: ProgressCallback = no_progress,
    found: dict[str, StripFound] | None = None,
    exclude: frozenset[tuple[str, str]] = frozenset(),
    ties: list[TiePatch] | None = None,
    models: ModelSet | None = None,
    lines: dict[str, str] | None = None,
) -> LaserBlock:
    """Find patches (or reuse ``found`` of an earlier set-up), set up the variant's unknowns and the
    observation groups; ``exclude``: ``(strip, patch)`` observations left out (set aside by cleaning);
    ``ties``: :func:`tie_patches` of ``found`` (the same for every variant: computed once by the caller).

    ``models`` and ``lines``: the GPS/IMU models of another block and the id each strip is served under
    (the laser strips of a platform: the image block's models of their flight lines,
    :mod:`scangeo.lidar.joint`, whose breaks are times already); None: the variant's models of the laser
    strips."""
    if models is None and variant.strategy in ("P", "S", "SE") and any(m.breaks_lines for m in variant.strips):
        raise LidarError(f"variant {variant.name}: breaks_lines of a laser strip (it has no lines): give breaks_times")
    mode = _mode(project, options)
    unit, popt, prior = _search_settings(project, options, mode)
    given = read_patch_ground(ground) if ground is not None and Path(ground).exists() else None
    if found is None:
        found = find_all(project, popt, prior, given, options.workers, callback, options.patch_search,
                         options.scheduler)
    seeded = any(f.candidates is not None for f in found.values())
    if ties is None:
        ties = tie_patches(project, options, found)
    notes = _search_notes(found, ties, options, seeded)
    strips = {s.id: s for s in project.strips}
    samplers = {sid: _sampler(project, strips[sid], f) for sid, f in found.items()} if mode == "trajectory" else {}
    ids, kinds, members = _patches(ties, given, found, notes)
    all_xyz = np.vstack([f.cells.planes.centroid for f in found.values()])
    reference = np.round(np.median(all_xyz, axis=0), -1 if unit == 1.0 else 0)
    empty = PatchFrames.from_points([], np.zeros((0, 3)), np.zeros((0, 3)))
    block = LaserBlock(project, options, variant, mode, found, ties, given, empty, kinds, ModelSet([]), Parameters(),
                       [], samplers, nominal_calibration(project.laser), reference, {}, notes, project.laser.id,
                       dict(lines or {}))
    _anchors(block, members, prior)
    block.frames = _frames(ids, block.anchors)
    block.models = models if models is not None else _models(found, variant, mode,
                                                             {st.id: st.mission for st in project.strips})
    block.parameters = _parameters(block, unit)
    block.groups = _groups(block, ids, unit, exclude)
    for note in notes:
        log.info("%s", note)
    return block


def run(block: LaserBlock, callback: ProgressCallback = no_progress) -> Adjustment:
    """Adjust the block with the variant's data snooping."""
    v = block.variant
    return adjust(block.parameters, block.groups, SolverOptions(max_iterations=v.max_iterations, backend=v.backend),
                  snooping_options(v), callback)


def calibration_of(values, sensor: str = "") -> Calibration:
    """The laser calibration of ``sensor`` (its id; ``""``: the one sensor of a laser project) in ``values``."""
    bore, lever, offset, index = laser_calibration_keys(sensor)
    return Calibration(np.asarray(values[bore], float), np.asarray(values[lever], float), float(values[offset][0]),
                       float(values[index][0]))


def corrector(block: LaserBlock, strip: str, values):
    """A function ``(xyz_map, t) -> corrected xyz_map`` of the strip's returns for the given unknowns."""
    coefficients = {m.key: np.asarray(values[m.key], float) for m in block.models}
    if block.mode == "trajectory":
        sampler, cal = block.samplers[strip], calibration_of(values, block.sensor)

        def correct(xyz: np.ndarray, t: np.ndarray) -> np.ndarray:
            sampler.check_covers(t, f"strip {strip}")
            p = block.to_work(xyz)
            polar = recover(p, t, sampler, block.nominal)
            pos, ang = sampler.at(t)
            c = block.models.correction(block.line(strip), t, pos, coefficients)
            return block.to_map(georeference(pos + c[:, :3], ang + c[:, 3:], polar, cal))
    else:

        def correct(xyz: np.ndarray, t: np.ndarray) -> np.ndarray:
            c = block.models.correction(block.line(strip), t, xyz, coefficients)
            return xyz + c[:, :3]

    return correct


def anchor_points(block: LaserBlock, strip: str, values) -> np.ndarray:
    """All anchors of a strip (check patches included) in the work frame under ``values``."""
    a = block.anchors[strip]
    coefficients = {m.key: np.asarray(values[m.key], float) for m in block.models}
    if block.mode == "trajectory":
        polar = a.get("polar_all")
        if polar is None:
            polar = a["polar_all"] = recover(
                a["work"], a["time"], block.samplers[strip], block.nominal, solve_time=True
            )
        pos, ang = block.samplers[strip].at(polar.time)
        c = block.models.correction(block.line(strip), polar.time, pos, coefficients)
        return georeference(pos + c[:, :3], ang + c[:, 3:], polar, calibration_of(values, block.sensor))
    c = block.models.correction(block.line(strip), a["time"], a["work"], coefficients)
    return a["work"] + c[:, :3]


__all__ = ["LaserOptions", "LaserBlock", "anchor_points", "build", "corrector", "find_patches", "nominal_calibration",
           "run", "tie_patches",
           "strip_trajectory", "Polar"]
