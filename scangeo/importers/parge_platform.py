"""``scangeo import parge STATUS.gcs [STATUS.gcs ...] OUT``: several PARGE lines as one platform project.

Every status file is first imported as its own line, by the rules of :mod:`scangeo.importers.parge`
(its conventions, its line rate, which of PARGE's offsets its arrays hold, its GCPs), into a
temporary folder: each camera's geometry is what its single-line import gives. Then:

1. **One flight.** The lines must be of one flight: one day (``image.DATE``) and one map CRS; else
   an error naming both files and what differs.
2. **Sensors.** One ``[[sensors]]`` entry per camera (the camera header's ID), its id from the
   camera's family (``vnir``, ``swir``; the ID itself where two cameras share a family). Lines of
   one camera share its sensor (and must have its pixels, look angles and line rate).
3. **Flight lines.** The lines whose navigation is one stretch of one GNSS/INS become one flight
   line (:mod:`scangeo.importers.navigation_agreement`). PARGE's arrays are the INS's attitude with
   every stored offset (``aux[0..3].OFFSET``) taken off the angles: added back, the copies of two
   cameras agree to micro-degrees in the mean, where the offsets the single-line import found held
   leave the later offset events' differences (docs/real-data.md, "The platform"). The flight
   line's trajectory is the INS of its line with the most records a second (the reference); the
   other lines' times are moved by the time offset found between the copies (PARGE's STARTTIME is
   a float32 of hours: 3.4 ms apart at 13 h). Lines that do not agree (or do not overlap in time)
   are flight lines of their own, and the import says why.
4. **Mountings.** Each sensor's boresight is the constant rotation closest to its single-line
   attitude (the arrays and its single-line boresight) over the flight line's INS at its line
   times: PARGE's offsets leave the trajectory and enter the mounting. PARGE adds its offsets to the
   attitude *angles*, which is a constant rotation of the body only in level flight: how far each
   camera's single-line attitude departs from its constant mounting (rms, largest) is in
   ``import.json`` (``sensors``).
5. **Heights.** One project has one geoid undulation: a given ``geoid``, else PARGE's height
   offset of the reference line of the first flight line; the other lines' offsets and what their
   heights move by are a warning.

Each camera's GCPs keep their roles (PARGE's used ones control, its unused ones check), their ids
prefixed by the sensor (``vnir-GCP01``). Relative-mounting priors (:func:`parse_relative_mounting`)
become ``[[relative_mountings]]``. The project is written whole or not at all.
"""
from __future__ import annotations

import json
import math
import tempfile
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import pyproj

from scangeo.errors import ArgumentError, ImportFileError
from scangeo.importers.navigation_agreement import AgreementThresholds, NavigationAgreement
from scangeo.importers.parge import (
    VARIANTS_BODY,
    ImportResult,
    _control,
    _crs_text,
    _footprint,
    _geoid,
    _look_angles,
    _names,
    _origin,
    import_parge,
)
from scangeo.importers.parge_flight_lines import (
    PlatformLine,
    SensorMounting,
    boresight_result,
    camera_stream,
    flight_line_trajectory,
    group_flight_lines,
    held_offsets,
    ins_stream,
    ordered,
    parge_offsets_relative_mounting,
    sensor_mountings,
    stored_offsets,
    triple_deg,
)
from scangeo.importers.parge_status import ParGeStatus
from scangeo.importers.record import ImportRecord
from scangeo.importers.writer import (
    Control,
    DtmChoice,
    ImportedLine,
    ImportedSensor,
    ProjectPlan,
    check_out,
    given_dtm,
    write_project,
)
from scangeo.io.points import ImagePoints
from scangeo.io.project_schema import RelativeMountingKeys
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rotation import small_rotation


@dataclass
class PlatformImportResult:
    """What ``scangeo import parge`` wrote and decided for several lines."""

    folder: Path
    strips: dict[str, str]
    sensors: dict[str, SensorMounting]
    flight_lines: dict[str, list[str]]
    agreements: dict[str, NavigationAgreement]
    time_offsets_s: dict[str, float]
    geoid: str
    control: int
    check: int
    lines: dict[str, ImportResult]
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def import_parge_platform(statuses, out, *, sensor_models=None, cubes=None, dtm=None,
                          geoid: float | str | Path | None = None,
                          relative_mountings: tuple[RelativeMountingKeys, ...] = (),
                          thresholds: AgreementThresholds | None = None,
                          progress: ProgressCallback = no_progress) -> PlatformImportResult:
    """Write one platform project from several PARGE status files (module docstring).

    Parameters
    ----------
    statuses : paths of the PARGE status files (``.gcs``), two or more, of one flight.
    out : the project folder to write; it must not exist or be empty.
    sensor_models : per status file, a HySpex sensor-model file or None (as ``import_parge``'s).
    cubes : per status file, the line's ENVI cube or None.
    dtm : a DTM raster or a height (m), as ``import_parge``'s; default a surface through every line's
        GCPs' heights.
    geoid : the geoid undulation N (m) or a raster of N; default PARGE's height offset of the first
        flight line's reference line.
    relative_mountings : priors on one sensor's mounting relative to another's (sensor ids as the
        import names them: :func:`parse_relative_mounting`).
    thresholds : when two lines' navigation is one stretch of one GNSS/INS (default
        :class:`~scangeo.importers.navigation_agreement.AgreementThresholds`).
    progress : ``callback(done, total, message)``.

    Returns
    -------
    PlatformImportResult : what was written and decided (also in ``OUT/import.json``).

    Raises
    ------
    ArgumentError : fewer than two status files, per-file lists of another length, a prior naming an
        unknown sensor.
    ImportFileError : a status file given twice; lines of different flights, or of one camera with
        other look angles or line rates, or twice on one stretch (naming both files).
    ParGeFileError, ImportFileError : as ``import_parge`` (naming the file).
    ProjectFileError : ``out`` exists and is not empty.
    """
    out = check_out(out)
    thresholds = thresholds or AgreementThresholds()
    paths = [Path(s) for s in statuses]
    if len(paths) < 2:
        raise ArgumentError("statuses: expected two or more PARGE status files (one: import_parge)")
    sensor_models = _per_file(sensor_models, len(paths), "sensor_models")
    cubes = _per_file(cubes, len(paths), "cubes")
    _no_twice(paths)
    record = ImportRecord("parge")
    total = len(paths) + 3
    lines: list[PlatformLine] = []
    with tempfile.TemporaryDirectory(prefix="scangeo-parge-lines-") as scratch:
        for k, path in enumerate(paths):
            progress(k, total, f"import: line {k + 1} of {len(paths)} ({path.name})")
            st = ParGeStatus.read(path)
            if lines:
                _one_flight(lines[0].st, st)
            folder = Path(scratch) / f"line{k}"
            # the line's own DTM is not used: a plane unless one is given (no stand-in surface, no warning)
            result = import_parge(path, folder, sensor_model=sensor_models[k], dtm=0.0 if dtm is None else dtm,
                                  geoid=geoid, image=cubes[k])
            single = json.loads((folder / "import.json").read_text())
            lines.append(PlatformLine(st, result, single, sensor_models[k], cubes[k]))
    for line in lines:
        record.source(f"status {line.st.path.name}", line.st.path)
        record.sources.update({f"{line.st.path.name} {role}": p for role, p in line.record["sources"].items()
                               if role != "status"})
    progress(len(paths), total, "import: sensors and flight lines")
    _name_sensors(lines)
    groups, agreements = group_flight_lines(lines, thresholds, record)
    mountings = sensor_mountings(groups, lines)
    geoid_value, geoid_text = _platform_geoid(groups, lines, geoid, record)
    imported = [_imported_line(line, mountings[line.sensor]) for line in ordered(groups)]
    references = [g[0] for g in groups]
    streams = tuple((group[0].flight_line, flight_line_trajectory(group, agreements, record)) for group in groups)
    _check_priors(relative_mountings, mountings)
    first = references[0]
    plan = ProjectPlan(crs=_crs_text(first.st.crs_wkt), crs_wkt=first.st.crs_wkt, geoid=geoid_value,
                       origin=_origin(first.st), knot_spacing_s=1.0 / max(line.result.line_rate_hz for line in lines),
                       dtm=_platform_dtm(lines, dtm, record),
                       box=_union_box(lines), tool="parge",
                       comment=", ".join(f"{line.st.path.name} ({line.sensor})" for line in lines),
                       variants=_variants_toml(lines, mountings), flight_lines=streams,
                       relative_mountings=tuple(relative_mountings))
    _record(record, lines, groups, agreements, mountings, thresholds, geoid_text)
    progress(len(paths) + 1, total, "import: writing the project")
    write_project(out, imported, plan, record)
    progress(total, total, "import: done")
    control = sum(int(line.st.gcps.used.sum()) for line in lines)
    check = sum(int((~line.st.gcps.used).sum()) for line in lines)
    return PlatformImportResult(out, {line.strip: str(line.st.path) for line in lines}, mountings,
                                {ref.flight_line: [m.strip for m in g] for ref, g in zip(references, groups)},
                                agreements, {line.strip: line.time_offset_s for line in lines}, geoid_text, control,
                                check, {line.strip: line.result for line in lines}, list(record.notes),
                                list(record.warnings))


def _per_file(values, n: int, name: str) -> list:
    if values is None:
        return [None] * n
    values = list(values)
    if len(values) != n:
        raise ArgumentError(f"{{{name}}}: {len(values)} given for {n} status files (one per status file, None for "
                            "none)", **{name: values})
    return values


def _no_twice(paths: list[Path]) -> None:
    seen: dict[Path, Path] = {}
    for p in paths:
        key = p.resolve()
        if key in seen:
            raise ImportFileError(f"{p}: given twice (each status file once)")
        seen[key] = p


def _one_flight(a: ParGeStatus, b: ParGeStatus) -> None:
    """Both lines of one flight: one day and one map CRS (an error naming both files otherwise)."""
    differs = []
    if a.date and b.date and a.date != b.date:
        differs.append(f"other days: {a.date} and {b.date}")
    if not pyproj.CRS.from_wkt(a.crs_wkt).equals(pyproj.CRS.from_wkt(b.crs_wkt)):
        differs.append(f"other map CRSs: {_crs_text(a.crs_wkt)[:60]} and {_crs_text(b.crs_wkt)[:60]}")
    if not differs:
        return
    ta, tb = _span(a), _span(b)
    if ta[1] < tb[0] or tb[1] < ta[0]:
        differs.append(f"no common time: {ta[0]:.1f}-{ta[1]:.1f} s and {tb[0]:.1f}-{tb[1]:.1f} s of the day")
    distance = _distance_km(a, b)
    if distance > 1.0:
        differs.append(f"{distance:.0f} km apart")
    raise ImportFileError(f"{a.path} and {b.path} are of different flights ({'; '.join(differs)}): one import takes "
                        "the lines of one flight")


def _span(st: ParGeStatus) -> tuple[float, float]:
    return st.start_seconds, st.start_seconds + (st.lines - 1) / st.line_rate_hz


def _distance_km(a: ParGeStatus, b: ParGeStatus) -> float:
    """The smallest distance between the two lines' tracks (km, every 50th record)."""
    geod = pyproj.Geod(ellps="WGS84")
    la, oa = np.asarray(a.lat)[::50], np.asarray(a.lon)[::50]
    lb, ob = np.asarray(b.lat)[::50], np.asarray(b.lon)[::50]
    _, _, d = geod.inv(np.repeat(oa, len(ob)), np.repeat(la, len(lb)), np.tile(ob, len(oa)), np.tile(lb, len(la)))
    return float(np.min(d)) / 1000.0


def _name_sensors(lines: list[PlatformLine]) -> None:
    """Sensor ids (by camera) and strip ids (sensor-flight line later): a camera's family, else its ID."""
    cameras: dict[str, list[PlatformLine]] = {}
    for line in lines:
        cameras.setdefault(line.st.camera, []).append(line)
    families = {camera: sorted(_names(camera)[0] or _names(group[0].st.image_name)[0])
                for camera, group in cameras.items()}
    taken: set[str] = set()
    for camera, group in cameras.items():
        fam = families[camera]
        shared = sum(families[c] == fam for c in cameras) > 1
        name = fam[0].lower() if len(fam) == 1 and not shared else _safe(camera).lower()
        while name in taken:
            name += "_"
        taken.add(name)
        first = group[0]
        for line in group:
            line.sensor = name
            if line is not first:
                _samecamera_stream(first, line)


def _samecamera_stream(a: PlatformLine, b: PlatformLine) -> None:
    sa, sb = _sensor(a), _sensor(b)
    if sa.pixels != sb.pixels or not (np.allclose(sa.across, sb.across, atol=1e-9, rtol=0)
                                      and np.allclose(sa.along, sb.along, atol=1e-9, rtol=0)):
        raise ImportFileError(f"{a.st.path} and {b.st.path}: one camera ({a.st.camera}) with other look angles "
                            "(another sensor model?)")
    if not math.isclose(sa.line_rate_hz, sb.line_rate_hz, rel_tol=1e-9):
        raise ImportFileError(f"{a.st.path} and {b.st.path}: one camera ({a.st.camera}) at other line rates "
                            f"({sa.line_rate_hz:g} and {sb.line_rate_hz:g} Hz)")


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in text) or "camera"


def _platform_geoid(groups, lines: list[PlatformLine], geoid, record: ImportRecord) -> tuple[float | str, str]:
    """One undulation for the platform: the given one, else the first reference line's PARGE height offset."""
    ref = groups[0][0]
    value, text = _geoid(ref.st, geoid, record.notes)
    offsets = {line.strip: _geoid(line.st, None, [])[0] for line in lines}
    figures = {"parge_height_offsets_m": offsets}
    if geoid is None:
        apart = {s: float(o) - float(value) for s, o in offsets.items() if abs(float(o) - float(value)) > 0.005}
        if apart:
            record.warn("PARGE's height offsets of the lines differ (" + ", ".join(
                f"{s} {float(o):.3f} m" for s, o in offsets.items()) + f"): the platform has one geoid undulation, "
                f"{float(value):.3f} m of {ref.strip}; the heights of " + ", ".join(
                f"{s} move by {d:+.3f} m" for s, d in apart.items()) + " from their single-line imports (give the "
                "real undulation as the geoid)")
        record.decide("geoid", f"N = {float(value):.3f} m: PARGE's height offset of {ref.strip}",
                      "one trajectory has one height datum; the first flight line's reference line's", figures)
    else:
        record.decide("geoid", text, "given", figures)
    return value, text


def _sensor(line: PlatformLine) -> ImportedSensor:
    across, along, source = _look_angles(line.st, line.sensor_model)
    return ImportedSensor(line.st.camera, along, across, line.result.line_rate_hz, measurement_time="line",
                          source=f"{line.st.camera} from {source}", id=line.sensor)


def _imported_line(line: PlatformLine, mounting: SensorMounting) -> ImportedLine:
    st = line.st
    sensor = replace(_sensor(line), boresight_deg=mounting.boresight_deg)
    return ImportedLine(line.strip, camera_stream(line), st.lines, sensor,
                        first_line_time=st.start_seconds + line.time_offset_s,
                        image=Path(line.cube).resolve() if line.cube is not None else None,
                        control=_prefixed(_control(st, line.strip), line.sensor), flight_line=line.flight_line)


def _prefixed(control: Control | None, prefix: str) -> Control | None:
    """The line's GCPs with ids ``PREFIX-GCPnn``: every camera lists its own GCP01..."""
    if control is None:
        return None
    ids = np.array([f"{prefix}-{p}" for p in control.ground.point], dtype=object)
    p = control.points
    return Control(replace(control.ground, point=ids),
                   ImagePoints(ids, p.strip, p.line, p.pixel, p.sigma_px, p.file_line))


def _platform_dtm(lines: list[PlatformLine], dtm, record: ImportRecord) -> DtmChoice:
    """The given DTM, else a surface through every line's GCPs' heights, else none (a warning)."""
    if dtm is not None:
        return given_dtm(dtm)
    n = sum(len(line.st.gcps) for line in lines)
    if n:
        return DtmChoice("gcps", why=f"a surface through the {n} GCPs' heights of the lines (not a DEM)")
    record.warn("no line has GCPs and no DTM is given: the project has no DTM, and scangeo run stops at its check; "
                "give the DTM (dtm: a raster or a height)")
    return DtmChoice("none", why="none: the lines need a DTM")


def _union_box(lines: list[PlatformLine]) -> tuple[float, float, float, float]:
    boxes = np.array([_footprint(line.st, *_look_angles(line.st, line.sensor_model)[:2]) for line in lines])
    return (float(boxes[:, 0].min()), float(boxes[:, 1].min()), float(boxes[:, 2].max()), float(boxes[:, 3].max()))


def _check_priors(priors, mountings: dict[str, SensorMounting]) -> None:
    for prior in priors:
        for name in (prior.sensor, prior.reference):
            if name not in mountings:
                raise ArgumentError("{relative_mountings}: " + _plain(f"the prior of {prior.sensor} relative to "
                                    f"{prior.reference} names an unknown sensor {name!r} (the import's sensors: "
                                    f"{', '.join(mountings)})"), relative_mountings=_spelled(prior))
        if prior.sensor == prior.reference:
            raise ArgumentError("{relative_mountings}: " + _plain(f"a prior of {prior.sensor} relative to itself"),
                                relative_mountings=_spelled(prior))


def _plain(text: str) -> str:
    """Text for an :class:`ArgumentError` message (whose braces name arguments)."""
    return text.replace("{", "{{").replace("}", "}}")


def _spelled(prior: RelativeMountingKeys) -> str:
    """A prior as ``parse_relative_mounting`` reads it."""
    angles = ",".join(f"{v:g}" for v in prior.boresight_deg or ())
    sigmas = ",".join(f"{v:g}" for v in prior.boresight_sigma_deg or ())
    return f"{prior.sensor}:{prior.reference}:{angles}:{sigmas}"


def parse_relative_mounting(text: str) -> RelativeMountingKeys:
    """``SENSOR:REFERENCE:ROLL,PITCH,HEADING:SIGMA[,SIGMA,SIGMA]`` (degrees) as a prior.

    The angles are those of ``R_rel = R_BS(reference)^T R_BS(sensor)`` (docs/formats.md,
    ``[[relative_mountings]]``); one sigma serves all three angles."""
    parts = text.split(":")
    expected = "expected SENSOR:REFERENCE:ROLL,PITCH,HEADING:SIGMA[,SIGMA,SIGMA] (degrees)"

    def error(why: str) -> ArgumentError:
        return ArgumentError("{relative_mounting}: " + _plain(why), relative_mounting=text)

    if len(parts) != 4 or not parts[0] or not parts[1]:
        raise error(expected)
    try:
        angles = [float(v) for v in parts[2].split(",")]
        sigmas = [float(v) for v in parts[3].split(",")] if parts[3] else []
    except ValueError:
        raise error(f"not numbers; {expected}") from None
    if not sigmas:
        raise error(f"no sigma (a prior needs its sigma); {expected}")
    if len(angles) != 3 or len(sigmas) not in (1, 3):
        raise error(f"{len(angles)} angles and {len(sigmas)} sigmas; {expected}")
    if not all(math.isfinite(v) for v in angles + sigmas) or min(sigmas) <= 0:
        raise error("the sigmas must be positive and every value finite")
    return RelativeMountingKeys(sensor=parts[0], reference=parts[1], boresight_deg=tuple(angles),  # type: ignore[arg-type]
                                boresight_sigma_deg=tuple(sigmas * 3 if len(sigmas) == 1 else sigmas))  # type: ignore[arg-type]


def _record(record: ImportRecord, lines: list[PlatformLine], groups, agreements, mountings, thresholds,
            geoid_text: str) -> None:
    for line in lines:
        for d in line.record["decisions"]:
            record.decide(f"{line.strip}.{d['topic']}", d["choice"], d["reason"], d["figures"], d["alternatives"])
        record.warnings.extend(w for w in line.record["warnings"] if w not in record.warnings)
        record.notes.extend(f"{line.strip}: {n}" for n in line.record["notes"])
    sensors = {}
    for sensor_id, m in mountings.items():
        sensors[sensor_id] = asdict(m)
    pairs = {}
    ids = list(mountings)
    by_sensor = {line.sensor: line for line in reversed(lines)}  # each sensor's first line
    for i, ref in enumerate(ids):
        for sensor in ids[i + 1:]:
            Mr, Ms = (small_rotation(np.radians(mountings[s].boresight_deg)) for s in (ref, sensor))
            a, b = by_sensor[ref], by_sensor[sensor]
            ins = ins_stream(next(g[0] for g in groups if a in g))
            sa, sb, ra, rb = stored_offsets(a), stored_offsets(b), boresight_result(a), boresight_result(b)
            pairs[f"{sensor}:{ref}"] = {
                "imported_deg": triple_deg(Mr.T @ Ms),
                "parge_stored_offsets_deg": parge_offsets_relative_mounting(sa, sb),
                "parge_stored_offsets_on_the_line_deg": parge_offsets_relative_mounting(sa, sb, ins),
                "parge_stored_offsets_difference_deg": [x - y for x, y in zip(sa, sb)],
                "parge_boresight_results_deg": parge_offsets_relative_mounting(ra, rb) if ra and rb else None}
    record.extra.update(
        platform=True, geoid=geoid_text, thresholds=asdict(thresholds),
        lines={line.strip: {"status": str(line.st.path), "camera": line.st.camera, "sensor": line.sensor,
                            "flight_line": line.flight_line, "first_line_time": line.st.start_seconds
                            + line.time_offset_s, "time_offset_s": line.time_offset_s,
                            "line_rate_hz": line.result.line_rate_hz, "offsets": asdict(line.result.offsets),
                            "offsets_held_deg": held_offsets(line),
                            "hypotheses": [asdict(h) for h in line.result.hypotheses],
                            "parge_offsets": line.st.offsets, "history": [asdict(e) for e in line.st.events],
                            "control": int(line.st.gcps.used.sum()), "check": int((~line.st.gcps.used).sum())}
               for line in lines},
        flight_lines={g[0].flight_line: {"reference": g[0].strip, "strips": [m.strip for m in g],
                                         "agreement": {m.strip: asdict(agreements[m.st.path.name]) for m in g[1:]},
                                         "arrays": {m.strip: record.extra["arrays"][m.st.path.name] for m in g[1:]}}
                      for g in groups},
        sensors=sensors, relative_mountings=pairs)
    record.extra.pop("arrays", None)


def _variants_toml(lines: list[PlatformLine], mountings: dict[str, SensorMounting]) -> str:
    bs = "; ".join(f"{s} [{', '.join(f'{v:.4f}' for v in m.boresight_deg)}]" for s, m in mountings.items())
    names = ", ".join(line.st.path.name for line in lines)
    body = VARIANTS_BODY.replace("a single line has no", "the lines have no").replace(
        "PARGE's boresight held fixed", "PARGE's offsets held fixed, in every sensor's mounting")
    return f"""# Written by scangeo import parge ({names}); edit freely: scangeo run keeps it.
# The sensors' boresights on the flight lines' INS, in scangeo's convention: {bs} (project.toml);
# calibrate = ["boresight"] calibrates every sensor's.

{body}"""


__all__ = ["PlatformImportResult", "SensorMounting", "import_parge_platform", "parge_offsets_relative_mounting",
           "parse_relative_mounting"]  # SensorMounting and the offsets' relative mounting: parge_flight_lines
