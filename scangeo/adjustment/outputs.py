"""Write the results of one variant: ``PROJECT/results/NAME/`` (formats in docs/adjustment.md).

- ``trajectory_<strip>.csv``: the adjusted orientation of the navigation reference point at the
  GPS/IMU sample times, ``time,lat,lon,h,roll,pitch,heading`` (degrees; as the input trajectories);
- ``orientation.json``: the adjusted orientation, machine-readable (splines, GPS/IMU corrections,
  mounting, scanner calibration, project frame; SI units; ``scangeo.orientation.file``,
  docs/formats.md). Everything that rebuilds the variant's geometry reads this file;
- ``residuals.csv``: every observation row with its residual, w-test, redundancy number and flag;
- ``report.json``: sigma0, accounting, iterations, rms per strip, coefficients, the calibration (estimates,
  sigmas, t-tests, priors, correlations: ``scangeo.adjustment.calibration``), notes;
- ``reliability.csv``, ``reliability.json``: MDBs and external reliability per observation unit, per
  strip and kind of point, non-separable points (``scangeo.adjustment.reliability_summary``);
- of a platform (several sensors): ``report.json``'s ``platform`` (per sensor its adjusted mounting with
  its precision, the flight lines and their strips, the relative mountings with their precision and
  prior, per strip its propagated ground precision, whether it has control, and its co-registration
  summary) and ``coregistration.json`` (per strip the propagated 1-sigma relative ground displacement to
  its flight line's reference strip on a grid of its image: ``scangeo.adjustment.coregistration``).

The folder is written under a temporary name and renamed when complete.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from scangeo.adjustment.calibration import block_calibration, calibration_summary
from scangeo.adjustment.coregistration import coregistration, ground_precision
from scangeo.adjustment.image import ImageObservations
from scangeo.adjustment.reliability_summary import COLUMNS as RELIABILITY_COLUMNS
from scangeo.adjustment.reliability_summary import check_columns, row_columns, variant_reliability, write_reliability
from scangeo.adjustment.results import VariantResult
from scangeo.atomic import atomic_directory
from scangeo.lsq.factor import available_backends
from scangeo.orientation.file import FILE_NAME as ORIENTATION_FILE
from scangeo.orientation.file import write_orientation
from scangeo.trajectory.readers import write_trajectory_csv
from scangeo.trajectory.stream import GpsImuStream, ProjectTrajectory

_ANGULAR = ("roll", "pitch", "heading", "omega")
#: A platform's co-registration grids in a variant's results folder (module docstring).
COREGISTRATION_FILE = "coregistration.json"
#: A variant's report in its results folder (module docstring; :func:`read_report`).
REPORT_FILE = "report.json"


def _num(x):
    """JSON-safe float (None for NaN/inf)."""
    return None if x is None or not math.isfinite(float(x)) else float(x)


def coefficient_table(result: VariantResult) -> list[dict]:
    """Per GPS/IMU model and calibration block: value and sigma (m or deg) and significance."""
    stats = result.adjustment.statistics
    out = []
    units = {key: unit for key, _, unit, _ in block_calibration(result.block.project)}
    keys = [m.key for m in result.block.models] + list(units)
    for key in keys:
        if key not in result.adjustment.parameters:
            continue
        block = result.adjustment.parameters[key]
        if not block.free.any():
            continue
        for c in stats.significance(key):
            unit = units.get(key, "rad" if any(c.component.startswith(a) for a in _ANGULAR) else "m")
            deg = unit == "rad"
            f = math.degrees(1.0) if deg else 1.0
            out.append(
                {
                    "block": key.label,
                    "name": c.component,
                    "unit": "deg" if deg else ("" if unit == "1" else unit),
                    "value": _num(c.value * f),
                    "sigma": _num(c.sigma * f),
                    "t": _num(c.t),
                    "significant": c.significant,
                }
            )
    return out


def report_dict(result: VariantResult) -> dict:
    adj = result.adjustment
    sol, stats = adj.solution, adj.statistics
    v = result.variant
    return {
        "variant": v.name,
        "strategy": v.strategy,
        "description": v.description,
        "sigma0": _num(stats.sigma0),
        "accounting": stats.accounting.as_dict(),
        "converged": sol.converged,
        "iterations": [
            {
                "number": it.number,
                "cost": _num(it.cost),
                "max_scaled_step": _num(it.max_scaled_step),
                "damping": it.damping,
                "seconds": round(it.seconds, 4),
            }
            for it in sol.iterations
        ],
        "snooping_rounds": adj.snooping_rounds,
        "full_solutions": adj.full_solutions,
        "solver_backend": sol.factor.backend,
        "backends_available": available_backends(),
        "seconds": round(result.seconds, 3),
        "models": [
            {
                "id": m.id,
                "strips": list(m.strips),
                "t_start": m.t_start,
                "t_end": m.t_end,
                "position_degree": m.position_degree,
                "attitude_degree": m.attitude_degree,
                "rotation": m.rotation,
                "follows": m.follows,
                "unknowns": m.size,
                "conditions": m.conditions,
            }
            for m in result.block.models
        ],
        "strips": result.rms_per_strip(),
        "coefficients": coefficient_table(result),
        "calibration": calibration_summary(result),
        "regularisation": [
            {"unknown": n.key.label, "component": n.component, "sigma": n.sigma, "reason": n.reason}
            for n in sol.regularisation
        ],
        "rejections": [
            {"group": r.group, "id": r.id, "components": list(r.components), "w": _num(r.w), "round": r.round,
             "separable": r.separable, "note": r.note}
            for r in adj.rejections
        ],
        "notes": list(result.notes),
        **({"platform": platform_summary(result)} if result.block.project.is_platform else {}),
        **result.sections,
    }


def _deg(values) -> list[float | None]:
    return [_num(math.degrees(float(v))) for v in values]


def platform_summary(result: VariantResult) -> dict:
    """The platform of a variant (module docstring): sensors' mountings, flight lines, relative mountings,
    per strip its control, ground precision and co-registration (metres and degrees)."""
    project, params, stats = result.block.project, result.adjustment.parameters, result.adjustment.statistics
    sensors = {}
    for sid in project.line_scanners:
        m = result.mounting(sid)
        entry = {"boresight_deg": _deg(m.boresight), "lever_arm_m": [float(v) for v in m.lever_arm_B],
                 "time_offset_s": float(m.time_offset)}
        for key, name, unit, sensor in block_calibration(project):
            if sensor == sid and params[key].free.any():
                sig = stats.sigmas(key)
                entry[f"{name}_sigma_{'deg' if unit == 'rad' else unit}"] = (
                    _deg(sig) if unit == "rad" else [_num(v) for v in sig])
        sensors[sid] = entry
    relative = []
    for r in result.relative_mountings():
        prior = r.prior
        relative.append({
            "sensor": r.sensor, "reference": r.reference, "boresight_deg": _deg(r.boresight),
            "boresight_sigma_deg": _deg(r.boresight_sigma), "lever_arm_m": [float(v) for v in r.lever_arm],
            "lever_arm_sigma_m": [_num(v) for v in r.lever_arm_sigma],
            "prior": None if prior is None else {
                "boresight_deg": None if prior.boresight is None else _deg(prior.boresight),
                "boresight_sigma_deg": None if prior.boresight_sigma is None else _deg(prior.boresight_sigma),
                "lever_arm_m": None if prior.lever_arm is None else [float(v) for v in prior.lever_arm],
                "lever_arm_sigma_m": (None if prior.lever_arm_sigma is None
                                      else [float(v) for v in prior.lever_arm_sigma]),
            }})
    co = {c.strip: c for c in coregistration(result)}
    rms = result.rms_per_strip()
    strips = {}
    for sid, s in result.block.strips.items():
        absolute = ground_precision(result, sid)
        strips[sid] = {"sensor": s.sensor, "flight_line": s.flight_line,
                       "control_measurements": rms[sid]["control"]["n"],
                       "ground_precision_m": None if absolute is None else absolute.summary(),
                       "coregistration": None if sid not in co else {"reference": co[sid].reference,
                                                                      **co[sid].summary()}}
    return {"sensors": sensors,
            "flight_lines": {fid: list(line.strips) for fid, line in result.block.flight_lines.items()},
            "relative_mountings": relative, "strips": strips}


def residual_rows(result: VariantResult):
    """Rows of residuals.csv: every observation row, then the check-point measurements."""
    adj = result.adjustment
    sol, stats = adj.solution, adj.statistics
    yield ["group", "id", "strip", "kind", "component", "residual", "unit", "sigma", "w", "redundancy", "flagged",
           *RELIABILITY_COLUMNS]
    w_all, r_all, res_all = stats.w_tests(), stats.redundancy_numbers(), stats.residuals()
    vr = variant_reliability(result)  # mdb, external reliability, status (reliability_summary.py)
    for gi, (g, act, w, red, res) in enumerate(zip(sol.groups, sol.active, w_all, r_all, res_all)):
        strip = getattr(g, "strip", None) or getattr(g, "flight_line", "")  # a GPS/IMU group: its flight line
        for i in range(g.n_rows):
            pid = str(g.ids[i])
            kind = (
                result.block.role(pid)
                if isinstance(g, ImageObservations) or g.name in ("ground control", "dtm heights")
                else g.kind
            )
            if g.name.startswith("gpsimu"):
                kind = "gpsimu"
            elif g.name == "dtm heights":
                kind = "dtm"
            flagged = (not act[i]) or (math.isfinite(w[i]) and abs(w[i]) > result.variant.critical_value)
            yield [
                g.name,
                pid,
                strip,
                kind,
                g.components[i],
                f"{res[i] * g.sigma[i]:.6g}",
                g.units[i],
                f"{g.sigma[i]:.6g}",
                "" if not math.isfinite(w[i]) else f"{w[i]:.3f}",
                "" if not math.isfinite(red[i]) else f"{red[i]:.4f}",
                int(flagged),
                *row_columns(vr, gi, i),
            ]
    c = result.checks
    crit = result.variant.critical_value
    sigmas = c.sigma_px if c.sigma_px is not None else [float("nan")] * len(c.point)
    for p, s, dl, dp, st, sig in zip(c.point, c.strip, c.line, c.pixel, c.status, sigmas):
        ok = st == 0
        for comp, unit, v in (("line", "line", dl), ("pixel", "px", dp)):
            # w of a check measurement: its residual over its measurement sigma (orientation error ignored)
            w = v / sig
            yield [
                "check points",
                p,
                s,
                "check",
                comp,
                f"{v:.6g}" if ok else "",
                unit,
                f"{sig:.6g}",
                f"{w:.3f}" if ok else "",
                "",
                int(not ok or abs(w) > crit),
                *check_columns(sig, ok, abs(w) > crit, vr.reliability.alpha0, vr.reliability.beta),
            ]


def write_results(result: VariantResult, out_dir=None) -> Path:
    """Write the outputs of a variant to ``out_dir`` (default PROJECT/results/NAME); returns the folder."""
    project = result.block.project
    out = Path(out_dir) if out_dir else project.root / "results" / result.variant.name
    with atomic_directory(out) as tmp:  # a full disk, an interrupt: no partial folder left behind
        _write_folder(result, tmp)
    return out


def _write_folder(result: VariantResult, tmp: Path) -> None:
    """The files of :func:`write_results` into the (temporary) folder ``tmp``."""
    frame = result.block.project.map_frame.frame
    for sid, strip in result.block.strips.items():
        spline = result.spline(sid)
        t = strip.trajectory.time
        t = t[spline.covers(t)]
        vals = spline.evaluate(t)
        traj = ProjectTrajectory(t, vals[:, :3], vals[:, 3:], f"adjusted {sid}")
        write_trajectory_csv(tmp / f"trajectory_{sid}.csv", GpsImuStream.from_project(traj, frame))
    write_orientation(result.orientation(), tmp / ORIENTATION_FILE)
    write_reliability(result, tmp)
    with open(tmp / "residuals.csv", "w", newline="") as f:  # inside write_results' atomic folder
        csv.writer(f).writerows(residual_rows(result))
    (tmp / REPORT_FILE).write_text(json.dumps(report_dict(result), indent=1))
    if result.block.project.is_platform:
        grids = [c.as_dict() for c in coregistration(result)]
        (tmp / COREGISTRATION_FILE).write_text(json.dumps({"schema": "scangeo.coregistration/1", "unit": "m",
                                                           "strips": grids}, indent=1))


def read_report(results: Path, name: str) -> dict:
    """Variant ``name``'s ``report.json`` under ``results`` (``PROJECT/results``), or {} when it has none.

    Returns
    -------
    dict
        What :func:`report_dict` wrote for the variant (empty when the variant was not written).
    """
    path = Path(results) / name / REPORT_FILE
    return json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}


__all__ = ["COREGISTRATION_FILE", "REPORT_FILE", "coefficient_table", "platform_summary", "read_report", "report_dict",
           "residual_rows", "write_results"]
