"""The platform of a report: per sensor its mounting, the relative mountings with their precision, and
per strip its control and propagated ground precision, for the variant the report recommends.

Read from ``results/NAME/report.json``'s ``platform`` (:func:`scangeo.adjustment.outputs.platform_summary`).
A strip without control is said so, in one line with its flight line, the strips it shares the flight
line with, and the propagated precision it reaches through them (and its mounting's prior, where its
sensor has one).
"""
from __future__ import annotations

from pathlib import Path

from scangeo.adjustment.outputs import read_report
from scangeo.reports import html


def _angles(values, sigmas) -> str:
    """Values with their sigmas (a sigma of 0 or none: a value the adjustment held fixed)."""
    if values is None:
        return "-"
    sigmas = sigmas if sigmas is not None else [None] * len(values)
    return ", ".join(f"{v:.4f} ± {s:.4f}" if s else f"{v:.4f}" for v, s in zip(values, sigmas))


def _listed(d: dict, key: str) -> list | None:
    return None if d.get(key) is None else [d[key]]


def _cm(value) -> str:
    return "-" if value is None else f"{100.0 * value:.1f}"


def laser_section(results: Path, variant: str) -> html.Section | None:
    """The laser strips of a platform adjusted jointly with its images (``report.json``'s ``laser``).

    Parameters
    ----------
    results : Path
        ``PROJECT/results``.
    variant : str
        The variant whose joint adjustment is shown (the recommended one).

    Returns
    -------
    html.Section or None
        The strip differences on flat cells before and after, per laser strip and over all, and the check
        patches; None when the variant's report.json has no laser side.
    """
    laser = read_report(results, variant).get("laser")
    if not laser:
        return None
    sec = html.Section(f"The laser strips ({variant}, adjusted with the images)", "laser")
    flat, checks, patches = laser["strip_differences_flat_rms_m"], laser["check_patches_rms_m"], laser["patches"]
    sec.parts.append(html.paragraph(
        f"The laser {laser['sensor']}'s tie patches ({patches['tie']}) and control patches ({patches['control']}) "
        "observed the flight lines' GPS/IMU corrections together with the images' points, in one adjustment. "
        "Strip differences: the height differences of overlapping laser strips on planar cells (flat cells), "
        f"rms in cm; over all strips {_cm(flat['before'])} before, {_cm(flat['after'])} after."))
    rows = [[sid, str(s["flat_cells"]), _cm(s["before_m"]), _cm(s["after_m"])] for sid, s in laser["strips"].items()]
    sec.parts.append(html.table(["laser strip", "flat cells shared with other strips", "before (cm)", "after (cm)"],
                                rows, "laser-strips"))
    if checks.get("count"):
        sec.parts.append(html.paragraph(
            f"Check patches ({checks['count']} patch and strip pairs): mean normal distance of the surveyed points "
            f"to each strip's plane, rms {_cm(checks['before'])} cm before, {_cm(checks['after'])} cm after."))
    return sec


def platform_section(results: Path, variant: str) -> html.Section | None:
    """The platform section for ``variant`` (None: not a platform, or the variant's report.json has none).

    Parameters
    ----------
    results : Path
        ``PROJECT/results``.
    variant : str
        The variant whose adjustment is shown (the recommended one).

    Returns
    -------
    html.Section or None
        Tables of the sensors, the relative mountings and the strips; the notes on strips without control.
    """
    report = read_report(results, variant)
    platform = report.get("platform")
    if not platform:
        return None
    sec = html.Section(f"The platform ({variant})", "platform")
    sec.parts.append(html.paragraph(
        "The sensors share the flight lines' trajectory and its GPS/IMU corrections; each has its own mounting. "
        "Angles in degrees (± 1 sigma a posteriori where the adjustment estimated them; without: held at "
        "project.toml's values), lengths in metres."))
    rows = []
    for sid, s in platform["sensors"].items():
        rows.append([sid, _angles(s["boresight_deg"], s.get("boresight_sigma_deg")),
                     _angles(s["lever_arm_m"], s.get("lever_arm_sigma_m")), f"{s['time_offset_s']:.4f}"])
    laser = report.get("laser")
    if laser:  # adjusted jointly with the images (scangeo.strategy.platform)
        m = laser["mounting"]
        rows.append([f"{laser['sensor']} (laser)", _angles(m["boresight_deg"], m.get("boresight_sigma_deg")),
                     _angles(m["lever_arm_m"], m.get("lever_arm_sigma_m")), "-"])
    sec.parts.append(html.table(["sensor", "boresight roll, pitch, heading (deg)", "lever arm x, y, z (m)",
                                 "time offset (s)"], rows, "platform-sensors"))
    if laser:
        m = laser["mounting"]
        offset = _angles([m["range_offset_m"]], _listed(m, "range_offset_sigma_m"))
        index = _angles([m["scan_index_deg"]], _listed(m, "scan_index_sigma_deg"))
        sec.parts.append(html.paragraph(f"The laser {laser['sensor']}: range offset {offset} m, scan-angle index "
                                        f"{index} deg."))
    rel = platform.get("relative_mountings", [])
    if rel:
        rows = []
        for r in rel:
            prior = r.get("prior")
            rows.append([f"{r['sensor']} to {r['reference']}", _angles(r["boresight_deg"], r["boresight_sigma_deg"]),
                         "-" if not prior else _angles(prior["boresight_deg"], prior["boresight_sigma_deg"]),
                         _angles(r["lever_arm_m"], r["lever_arm_sigma_m"])])
        sec.parts.append(html.paragraph(
            "Relative mounting: R_rel = R_BS(reference)^T R_BS(sensor) as roll, pitch, heading, and the lever arm "
            "of the sensor minus the reference's; the prior is the one given in project.toml."))
        sec.parts.append(html.table(["sensor to reference", "adjusted (deg)", "prior (deg)",
                                     "lever arm difference (m)"], rows, "platform-relative"))
    rows, notes = [], []
    lines = platform["flight_lines"]
    priors = {r["sensor"]: r for r in rel if r.get("prior")}
    for sid, s in platform["strips"].items():
        gp = s.get("ground_precision_m") or {}
        median = gp.get("median_m")
        rows.append([sid, s["sensor"], s["flight_line"], str(s["control_measurements"]),
                     "-" if median is None else f"{median:.3f}",
                     "-" if gp.get("max_m") is None else f"{gp['max_m']:.3f}"])
        if s["control_measurements"] == 0:
            sisters = [x for x in lines.get(s["flight_line"], []) if x != sid]
            through = (f"its flight line {s['flight_line']}'s trajectory corrections (shared with "
                       f"{', '.join(sisters)})" if sisters else f"its flight line {s['flight_line']}")
            if laser:
                through += f" and the laser {laser['sensor']}'s patches on its flight line"
            mount = (f" and its mounting from the relative-mounting prior to {priors[s['sensor']]['reference']}"
                     if s["sensor"] in priors else "")
            reach = "" if median is None else f": propagated ground precision {median:.3f} m (median, 1 sigma)"
            notes.append(f"strip {sid} ({s['sensor']}) has no control point; it is georeferenced through "
                         f"{through}{mount}{reach}")
    sec.parts.append(html.table(["strip", "sensor", "flight line", "control measurements",
                                 "ground precision median (m)", "max (m)"], rows, "platform-strips"))
    sec.parts.append(html.bullet_list(notes))
    return sec


__all__ = ["laser_section", "platform_section"]
