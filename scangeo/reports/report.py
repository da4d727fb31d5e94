"""The residual report of a compared project: ``PROJECT/results/report.html`` and ``residuals.gpkg``.

:func:`write_report` reads what ``scangeo compare`` wrote (``results/comparison.json`` and every
variant's ``results/NAME/``), and writes one self-contained HTML file (figures embedded as PNG):

1. the comparison table (and, on a simulated project, the true error of every variant);
2. per strip the check-point residual vectors over the strip's footprint, the reference variant
   and the best variant side by side;
3. the correction functions over time per strip, and for each problem strip (a strip some variant
   corrects with a polynomial or a split) the Z corrections of the P and S variants with the
   GPS/IMU height's deviation from the mean flight height;
4. the GPS/IMU data of each strip (tracks and flight direction, positions and angles over time);
5. the accounting of unknowns, observations and conditions, per variant and per GPS/IMU model;
6. the regularisation and blunder notes of every variant.
7. the reliability of the reference and the best variant: MDB and external reliability maps per
   strip, the non-separable points and a sentence of interpretation (:mod:`scangeo.reports.reliability`).
8. when ``scangeo match`` measured points: their map and counts (:mod:`scangeo.reports.matching`);
9. a quicklook: the recommended variant's mosaic with the strips' footprints and the check points
   (:mod:`scangeo.reports.quicklook`; a note when the mosaic is not there yet);
10. a platform's: the co-registration of its sensors per flight line (:mod:`scangeo.reports.coregistration_section`);
    its sensors' mountings (:mod:`scangeo.reports.platform_section`) and, when its laser strips were
    adjusted with the images, their strip differences before and after (the laser section).

The residual vectors of every variant also go to a GeoPackage (:mod:`scangeo.reports.geopackage`).
"""
from __future__ import annotations

import datetime
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.adjustment.outputs import read_report
from scangeo.adjustment.summary import Comparison
from scangeo.atomic import write_text
from scangeo.io.points import GroundPoints
from scangeo.io.project import Project
from scangeo.orientation.file import FILE_NAME as ORIENTATION_FILE
from scangeo.orientation.file import read_orientation_file
from scangeo.progress import ProgressCallback, no_progress
from scangeo.reports import figures, html
from scangeo.reports.calibration_section import calibration_section
from scangeo.reports.coregistration_section import coregistration_section
from scangeo.reports.corrections import (
    breaks_of,
    correction_series,
    gpsimu_series,
    problem_strips,
    true_gps_error,
    written_orientations,
)
from scangeo.reports.diagnosis_section import diagnosis_section
from scangeo.reports.geopackage import write_geopackage
from scangeo.reports.laser import write_laser_report
from scangeo.reports.matching import match_section
from scangeo.reports.platform_section import laser_section, platform_section
from scangeo.reports.quicklook import quicklook_section
from scangeo.reports.reliability import reliability_section
from scangeo.reports.residual_vectors import ResidualVectors, check_vectors
from scangeo.reports.tables import markdown_tables, read_comparison
from scangeo.reports.unchecked import write_unchecked_report
from scangeo.version import __version__


@dataclass(frozen=True)
class ReportFiles:
    """What :func:`write_report` wrote, and how many figures the HTML holds.

    Parameters
    ----------
    html : Path
        ``PROJECT/results/report.html`` (one self-contained file).
    geopackage : Path or None
        ``PROJECT/results/residuals.gpkg``; None when not written.
    figures : int
        Figures in the HTML.
    """

    html: Path
    geopackage: Path | None
    figures: int


def strip_frame(project: Project, strip_id: str, samples: int = 40) -> figures.StripFrame:
    """The strip's footprint (closed polygon, map x, y in m) from its image edges, and its flight axes
    (origin: the nadir point of the first line), from the GPS/IMU as measured."""
    g = project.geometry(strip_id)
    lines = np.linspace(0.0, g.n_lines - 1.0, samples)
    edges = []
    for pixel in (0.0, 0.5 * (g.sensor.pixels - 1.0), g.sensor.pixels - 1.0):
        p_P, _ = g.image_to_ground(lines, np.full(samples, pixel), project.dtm)
        x, y, _ = project.map_frame.project_to_map(p_P)
        edges.append(np.column_stack([x, y]))
    poly = np.vstack([edges[0], edges[2][::-1], edges[0][:1]])
    centre = edges[1][np.isfinite(edges[1]).all(axis=1)]
    u = centre[-1] - centre[0]
    return figures.StripFrame(centre[0], u / np.linalg.norm(u), poly[np.isfinite(poly).all(axis=1)])


def _rms_title(c: Comparison, name: str, sid: str) -> str:
    ch = c.variant(name).strips.get(sid, {}).get("check", {})
    if not ch.get("n"):
        return f"{name}: no check points"
    return (f"{name}: check rms along {ch['rms_along_px']:.2f} px, across {ch['rms_across_px']:.2f} px "
            f"(n = {ch['n']})")


def _colours(c: Comparison) -> dict[str, str]:
    """One colour per variant, the same in every figure."""
    return {v.name: figures.colour(i) for i, v in enumerate(c.variants)}


def _comparison_section(c: Comparison) -> html.Section:
    tables = markdown_tables(c)
    sec = html.Section("Comparison of strategies", "comparison")
    sec.parts.append(html.paragraph(
        f"Reference {c.reference} = 100 %. Check points: rms of the residuals (model - measured) along track in "
        "lines (= pixels) and across track in pixels, per strip, with the % of the reference. Control: the control "
        "points the adjustment used, by the coordinates they give."))
    sec.parts.append(html.table(*tables["check points"], table_id="comparison-table", text_columns=(0, 1, 2)))
    ok = [v for v in c.variants if v.error is None]
    across = {v.name: [v.strips.get(s, {}).get("check", {}).get("rms_across_px") for s in c.strips] for v in ok}
    sec.parts.append(html.figure(figures.rms_chart(c.strips, [v.name for v in ok], across, c.reference, _colours(c)),
                                 "Check-point rms across track per strip and variant", "fig-rms"))
    if "true error" in tables:
        sec.parts.append("<h3>True error (simulated project)</h3>")
        sec.parts.append(html.paragraph(
            "rms of each variant's orientation error against truth/ over a grid of image positions: along and "
            "across track in pixels, horizontal ground error in metres (no DTM error, no measurement noise)."))
        sec.parts.append(html.table(*tables["true error"], table_id="true-error-table", text_columns=(0,)))
    return sec


def _vectors_section(project: Project, c: Comparison, vectors: dict[str, ResidualVectors],
                     frames: dict[str, figures.StripFrame]) -> html.Section:
    sec = html.Section("Residual vectors at the check points", "residual-vectors")
    shown = [n for n in dict.fromkeys([c.reference, c.best]) if n in vectors]
    sec.parts.append(html.paragraph(
        "Arrows: the ground error of the adjusted orientation at each check point (where the orientation puts the "
        "measured image point minus the point's coordinates), exaggerated; red: flagged by its test. "
        f"Above the reference {c.reference}, below the best variant {c.best or '-'} (lowest check-point rms)."))
    for sid in c.strips:
        png = figures.residual_map(frames[sid], [vectors[n].of_strip(sid) for n in shown],
                                   [_rms_title(c, n, sid) for n in shown], sid)
        sec.parts.append(
            html.figure(png, f"Strip {sid}: residual vectors of {' and '.join(shown)}", f"fig-vectors-{sid}")
        )
    return sec


def _corrections_section(project: Project, c: Comparison) -> html.Section:
    sec = html.Section("Correction functions", "corrections")
    adjusted = [v.name for v in c.variants if v.error is None and v.strategy != "DG"]
    if not adjusted:  # nothing to draw: say why in one line
        direct = [v.name for v in c.variants if v.error is None]
        failed = [v.name for v in c.variants if v.error is not None]
        sec.parts.append(html.paragraph(
            "No correction functions: no variant corrects the GPS/IMU ("
            + "; ".join([f"{', '.join(direct)} use it as measured, strategy DG"] * bool(direct)
                        + [f"{', '.join(failed)} failed"] * bool(failed)) + ")."))
        return sec
    sec.parts.append(
        html.paragraph(
            "The correction each variant applied to the GPS/IMU: adjusted orientation minus GPS/IMU as measured, over "
            "the image (x east, y north, z up in the project frame; angles w.r.t. the project frame's NED axes)."
        )
    )
    orientations = written_orientations(project, adjusted)  # once: every strip's figures use them
    ps = {n: o for n, o in orientations.items() if c.variant(n).strategy in ("P", "S")}
    for sid in problem_strips(project, orientations):
        series = correction_series(project, ps, sid)
        height, _ = gpsimu_series(project, sid)
        png = figures.height_correction_plot(sid, series, height, true_gps_error(project, sid),
                                             breaks_of(project, ps, sid), _colours(c))
        sec.parts.append(
            html.figure(
                png,
                f"Problem strip {sid}: Z corrections of {', '.join(ps)} and the GPS/IMU "
                "height's deviation from the mean flight height",
                f"fig-height-{sid}",
            )
        )
    for sid in c.strips:
        series = correction_series(project, orientations, sid)
        sec.parts.append(
            html.figure(
                figures.correction_plot(sid, series, breaks_of(project, orientations, sid), _colours(c)),
                f"Strip {sid}: corrections of {', '.join(orientations)} over time",
                f"fig-corr-{sid}",
            )
        )
    return sec


def _gpsimu_section(project: Project, c: Comparison, frames: dict[str, figures.StripFrame]) -> html.Section:
    sec = html.Section("GPS/IMU data", "gpsimu")
    tracks, directions = {}, {}
    for sid in c.strips:
        tracks[sid], directions[sid] = gpsimu_series(project, sid)
    footprints = {s: f.footprint for s, f in frames.items()}
    sec.parts.append(
        html.figure(figures.tracks_map(tracks, footprints), "Strips, tracks and flight directions", "fig-tracks")
    )
    for sid in c.strips:
        sec.parts.append(
            html.figure(
                figures.gpsimu_plot(sid, tracks[sid], directions[sid]),
                f"Strip {sid}: GPS/IMU positions and angles, flying {directions[sid]}",
                f"fig-gpsimu-{sid}",
            )
        )
    return sec


def _accounting_section(project: Project, c: Comparison) -> html.Section:
    sec = html.Section("Unknowns, observations and conditions", "accounting")
    sec.parts.append(
        html.paragraph(
            "unknowns = parameters - conditions (the C0 continuity of split models, eliminated by their "
            "parametrisation); redundancy = observations + pseudo-observations - unknowns."
        )
    )
    sec.parts.append(
        html.table(
            *markdown_tables(c)["accounting"], table_id="accounting-table", text_columns=(0, 1), wide_columns=(1,)
        )
    )
    rows = []
    for v in c.variants:
        written = project.root / "results" / v.name / ORIENTATION_FILE
        for m in read_orientation_file(written).models if written.exists() else ():
            rows.append([v.name, m.id, ", ".join(m.strips), f"{m.t_end - m.t_start:.1f}", str(m.position_degree),
                         str(m.attitude_degree), "yes" if m.rotation else "", m.follows or "", str(m.size),
                         str(m.conditions)])
    if rows:
        sec.parts.append("<h3>GPS/IMU models</h3>")
        sec.parts.append(
            html.table(
                [
                    "variant",
                    "model",
                    "strips",
                    "span (s)",
                    "position degree",
                    "attitude degree",
                    "rotation",
                    "follows",
                    "unknowns",
                    "conditions",
                ],
                rows,
                text_columns=(0, 1, 2),
            )
        )
    return sec


def _notes_section(project: Project, c: Comparison) -> html.Section:
    sec = html.Section("Regularisation and blunders", "notes")
    for v in c.variants:
        sec.parts.append(f"<h3>{html.esc(v.name)}</h3>")
        if v.error:
            sec.parts.append(html.paragraph(f"the adjustment failed: {v.error}", "warn"))
            continue
        r = read_report(project.root / "results", v.name)
        reg = [
            f"{n['unknown']} [{n['component']}]: pseudo-observation with sigma {n['sigma']:g} ({n['reason']})"
            for n in r.get("regularisation", [])
        ]
        rej = [
            f"{x['group']} {x['id']} ({', '.join(x['components'])}): w = {x['w']:.1f}, round {x['round']}"
            if x.get("w") is not None
            else f"{x['group']} {x['id']}"
            for x in r.get("rejections", [])
        ]
        sec.parts.append(html.paragraph(f"regularised unknowns: {len(reg) or 'none'}"))
        sec.parts.append(html.bullet_list(reg))
        sec.parts.append(html.paragraph(f"observations rejected by data snooping: {len(rej) or 'none'}"))
        sec.parts.append(html.bullet_list(rej))
        sec.parts.append(html.bullet_list([f"note: {n}" for n in r.get("notes", [])]))
    return sec


def _check_points(root: Path) -> np.ndarray:
    """x, y of ground.csv's check points ((0, 2) without ground.csv)."""
    path = root / "ground.csv"
    if not path.exists():
        return np.zeros((0, 2))
    ground = GroundPoints.read(path)
    return ground.xyz[ground.role == "check", :2]


def write_report(
    project_root, out=None, *, geopackage: bool = True, callback: ProgressCallback = no_progress
) -> ReportFiles:
    """Write ``report.html`` (and ``residuals.gpkg``) of a compared project into ``out`` (default PROJECT/results);
    of a laser project its report (:func:`scangeo.reports.laser.write_laser_report`)."""
    project = Project.from_user_input(project_root)
    root = project.root
    if project.is_laser:  # the laser's report (reports/laser.py): no residual vectors, no GeoPackage
        html_path, count = write_laser_report(root, Path(out) if out else None)
        return ReportFiles(html_path, None, count)
    folder = Path(out) if out else root / "results"
    if not (root / "points.csv").exists() and not (root / "results" / "comparison.json").exists():
        folder.mkdir(parents=True, exist_ok=True)  # no points: a direct georeferencing, unchecked
        frames = {s.id: strip_frame(project, s.id) for s in project.image_strips}
        return ReportFiles(write_unchecked_report(project, frames, folder), None, 1)
    comparison = read_comparison(root / "results")
    folder.mkdir(parents=True, exist_ok=True)
    names = [v.name for v in comparison.variants if v.error is None]
    steps, done = len(names) + 6, 0

    def step(message: str) -> None:
        nonlocal done
        callback(done, steps, f"report: {message}")
        done += 1

    vectors = {}
    for n in names:
        step(f"residual vectors {n}")
        vectors[n] = check_vectors(project, n)
    step("footprints")
    frames = {sid: strip_frame(project, sid) for sid in comparison.strips}
    sections = []
    for title, make in (
        ("comparison", lambda: _comparison_section(comparison)),
        ("residual vectors", lambda: _vectors_section(project, comparison, vectors, frames)),
        ("corrections", lambda: _corrections_section(project, comparison)),
        ("GPS/IMU", lambda: _gpsimu_section(project, comparison, frames)),
        ("accounting and notes", lambda: _accounting_section(project, comparison)),
    ):
        step(title)
        sections.append(make())
    sections.insert(1, diagnosis_section(root, comparison))  # scangeo diagnose, recommendation, correlations
    chosen = comparison.recommended or comparison.best or comparison.reference  # the variant scangeo run rectifies
    sections.insert(2, quicklook_section(root / "results", chosen, {sid: f.footprint for sid, f in frames.items()},
                                         _check_points(root), any(s.image for s in project.strips)))
    coregistration = coregistration_section(root / "results", chosen)  # a platform's sensors
    if coregistration is not None:
        sections.insert(3, coregistration)
    pixels = max(project.scanner_of(s.id).model.pixels for s in project.image_strips)
    calibration = calibration_section(root, comparison, pixels)  # estimates, tests, residuals
    if calibration is not None:
        sections.insert(3, calibration)
    platform = platform_section(root / "results", chosen) if project.is_platform else None
    if platform is not None:  # sensors' mountings, relative mountings, strips without control
        sections.insert(3, platform)
    laser = laser_section(root / "results", chosen) if project.laser_strips else None
    if laser is not None:  # a platform's laser strips adjusted with the images
        sections.insert(4 if platform is not None else 3, laser)
    sections.append(_notes_section(project, comparison))
    shown = [n for n in dict.fromkeys([comparison.reference, comparison.best]) if n in names]
    sections.append(reliability_section(project.root / "results", shown))  # MDB and external reliability maps
    matched = match_section(project.root, {sid: f.footprint for sid, f in frames.items()})  # scangeo match
    if matched is not None:
        sections.append(matched)
    gpkg = None
    if geopackage:
        gpkg = write_geopackage(folder / "residuals.gpkg", [vectors[n] for n in names], project.crs)
    files = [
        f"comparison.md, comparison.csv, comparison.json: the table ({comparison.variants_file})",
        *(
            [f"{gpkg.name}: residual vectors of every variant (layers check_NAME, vectors_NAME), {project.crs}"]
            if gpkg
            else []
        ),
        "NAME/: every variant's orientation.json, adjusted trajectories, residuals.csv and report.json",
    ]
    sections.append(html.Section("Files", "files", [html.bullet_list(files)]))
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    intro = [
        html.paragraph(
            f"Project {root.resolve()} ({project.crs}, {len(comparison.strips)} strips); "
            f"variants from {comparison.variants_file}; scangeo {__version__}, {stamp}."
        )
    ]
    text = html.document(f"scangeo residual report: {root.name}", intro, sections)
    path = write_text(folder / "report.html", text)
    callback(steps, steps, "report: done")
    return ReportFiles(path, gpkg, text.count('class="report-figure"'))


__all__ = ["ReportFiles", "strip_frame", "write_report"]
