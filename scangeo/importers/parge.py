"""``scangeo import parge``: a PARGE status file (a HySpex line) as a scangeo project.

PARGE's conventions, found on the two shared HySpex lines by ground control residuals and applied
here (docs/real-data.md shows each measurement):

* **Roll** is positive with the left wing down: scangeo's roll (right wing down) is ``-rollarr``.
* **Heading** is a grid heading (clockwise from the map grid's north): scangeo's true heading is
  ``headarr + gamma`` with ``gamma`` the meridian convergence of the map CRS at the aircraft
  (pyproj; about -0.76 deg for UTM 6N at 147.8 W, 64.9 N).
* **Pitch** is positive nose up, as scangeo's.
* **Look angles**: ``sensarr`` (or the HySpex sensor model) gives ``vinkelx`` positive to the left of
  the flight direction and ``vinkely`` positive forward: scangeo's across-track angle is
  ``-vinkelx``, its along-track angle ``vinkely``.
* **Pixel and line** of a GCP are 0-based indices of the raw image; scangeo takes them as pixel
  centres.
* **Heights**: ``gpsarr`` holds the GNSS altitude, ``navarr``'s height is that minus PARGE's height
  offset ``aux[6].OFFSET``, and the GCP heights come from the DEM PARGE used. Without a ``geoid``,
  scangeo takes PARGE's height offset as the undulation N (so the heights are PARGE's); a number or a
  raster of N gives the real one.
* **Offsets**: the attitude arrays may already hold some of PARGE's offsets. The history
  (``pr.HSRY``) lists each change of the offsets (boresight results, a user's offset events); the
  offsets not yet in the arrays are a suffix of that list. Each split of the list is a hypothesis;
  the one whose fixed boresight fits the used GCPs best is taken, and every hypothesis's figures are
  written to ``import.json``.

The project is written into a new folder, complete or not at all (:func:`scangeo.atomic.atomic_directory`).
"""
from __future__ import annotations

import logging
import math
import re
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import pyproj

from scangeo.errors import ImportFileError, MissingFileError, ParGeFileError
from scangeo.importers.envi import EnviCube
from scangeo.importers.hyspex import HySpexSensorModel
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
    with_boresight,
    write_project,
)
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project
from scangeo.progress import ProgressCallback, no_progress
from scangeo.rotation import matrix_to_rph, rph_to_matrix
from scangeo.sensors.strip import Mounting, StripGeometry
from scangeo.trajectory.stream import GpsImuStream

log = logging.getLogger(__name__)

#: Standard deviations written into ground.csv and points.csv for PARGE's GCPs: measured on an IFSAR
#: orthoimage of 0.625 m pixels and a 0.5 m DEM, and in the raw image.
GCP_SIGMA_XY_M = 0.3
GCP_SIGMA_Z_M = 0.5
GCP_SIGMA_PX = 0.5

#: The three variants the import writes (variants.toml).
VARIANTS = ("PARGE", "BORESIGHT", "CALIBRATED")


@dataclass(frozen=True)
class OffsetHypothesis:
    """Which of PARGE's offsets the arrays hold: the first ``held`` changes of the history.

    ``remainder_deg``: PARGE's offsets (roll, pitch, heading; PARGE's signs) not in the arrays;
    ``boresight_deg``: the same as scangeo's boresight (its conventions); ``fit_px``: the rms of the
    used GCPs' residuals with that boresight fixed (along track in lines, across track in pixels);
    ``approximation_deg``: how far the constant boresight is from PARGE's per-record offsets at most.
    """

    held: int
    description: str
    remainder_deg: tuple[float, float, float]
    boresight_deg: tuple[float, float, float]
    approximation_deg: float
    fit_px: tuple[float, float] | None = None


@dataclass
class ImportResult:
    """What ``scangeo import parge`` wrote and decided."""

    folder: Path
    strip: str
    line_rate_hz: float
    line_rate_source: str
    geoid: str
    boresight_deg: tuple[float, float, float]
    offsets: OffsetHypothesis
    hypotheses: list[OffsetHypothesis]
    control: int
    check: int
    dtm: str
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def import_parge(status, out, *, sensor_model=None, dtm=None, geoid: float | str | Path | None = None,
                 image=None, progress: ProgressCallback = no_progress) -> ImportResult:
    """Write a scangeo project from a PARGE status file.

    Parameters
    ----------
    status : path of the PARGE status file (``.gcs``).
    out : the project folder to write; it must not exist or be empty.
    sensor_model : a HySpex sensor-model file (``pixel vinkelx vinkely``) to take the look angles
        from instead of the status file's ``sensarr``; its pixel count must be the image's.
    dtm : a DTM raster (orthometric heights in any CRS GDAL knows; the project refers to it by its
        absolute path), or a number: a plane at that height (m). Default: a surface through the GCPs'
        heights, labelled as such; without GCPs no DTM (the project says it needs one).
    geoid : the geoid undulation N (m, a number) or a raster of N; default: PARGE's height offset.
    image : the line's cube (ENVI, e.g. PARGE's ``.img`` with its ``.hdr``); its samples and lines
        must be the status file's pixels and lines. The project refers to it by its absolute path.
    progress : ``callback(done, total, message)``.

    Returns
    -------
    ImportResult : what was written and decided (also in ``OUT/import.json``).

    Raises
    ------
    ParGeFileError : the status or sensor-model file cannot be imported (names the file and why).
    ImportFileError : the cube does not fit the status file (names its header and both sizes).
    ProjectFileError : ``out`` exists and is not empty.
    """
    out = check_out(out)
    record = ImportRecord("parge")
    progress(0, 5, "import: reading the PARGE status")
    st = ParGeStatus.read(status)
    record.source("status", st.path)
    across, along, look_source = _look_angles(st, sensor_model)
    strip = _strip_id(st)
    cube = _cube(st, image, record)
    rate, rate_source = _line_rate(st, record)
    geoid_value, geoid_text = _geoid(st, geoid, record.notes)
    _check_names(st, sensor_model, record)
    _check_start_time(st, record)
    if st.placeholder_gcps:
        record.note(f"gcparr holds {st.placeholder_gcps} row{'s' if st.placeholder_gcps > 1 else ''} of zeros: "
                    "PARGE's empty list, not GCPs (left out)")
    convergence = _convergence(st)
    stream = line_stream(st, rate, convergence)
    roll, heading = stream.roll, stream.heading
    dtm_choice = _dtm(st, dtm, record)
    sensor = ImportedSensor(st.camera, along, across, rate, measurement_time="line", source=f"from {look_source}")
    line = ImportedLine(strip, stream, st.lines, sensor, first_line_time=st.start_seconds,
                        image=cube.data.resolve() if cube is not None else None, control=_control(st, strip))
    hypotheses = _hypotheses(st, roll, st.pitch, heading)
    plan = ProjectPlan(crs=_crs_text(st.crs_wkt), crs_wkt=st.crs_wkt, geoid=geoid_value, origin=_origin(st),
                       knot_spacing_s=1.0 / rate, dtm=dtm_choice, box=_footprint(st, across, along), tool="parge",
                       comment=f"{st.path.name} ({st.camera})")
    chosen_box: list[OffsetHypothesis] = []

    def refine(tmp: Path, lines: list[ImportedLine], plan: ProjectPlan) -> tuple[list[ImportedLine], ProjectPlan]:
        progress(2, 5, "import: testing which offsets the attitude arrays hold")
        if st.gcps.used.any():
            project = Project.load(tmp)
            nominal = project.geometry(strip, check=False)  # the spline fitted once; each hypothesis its mounting
            for i, h in enumerate(hypotheses):
                hypotheses[i] = _fitted(project, nominal, st, h)
            chosen = min(hypotheses, key=lambda h: math.hypot(*h.fit_px) if h.fit_px else math.inf)
        else:
            chosen = _default_hypothesis(hypotheses)
            record.note(f"no used GCPs: which offsets the arrays hold could not be tested; assumed "
                        f"'{chosen.description}'")
        chosen_box.append(chosen)
        progress(3, 5, "import: variants")
        return with_boresight(lines, chosen.boresight_deg), replace(plan, variants=_variants_toml(st, chosen))

    progress(1, 5, "import: writing the project")
    ids = _point_ids(st)
    record.extra.update(source=str(st.path), camera=st.camera, pixels=st.pixels, lines=st.lines, bands=st.bands,
                        look_angles=look_source, points=ids, parge_offsets=st.offsets,
                        parge_sensor_boresight_rad=list(st.sensor_boresight),
                        history=[asdict(e) for e in st.events], image=st.image_name, dem=st.dem_name,
                        mean_convergence_deg=float(np.degrees(np.mean(convergence))), conventions=CONVENTIONS,
                        strip=strip, line_rate_hz=rate, line_rate_source=rate_source, geoid=geoid_text,
                        dtm=dtm_choice.why, control=int(st.gcps.used.sum()), check=int((~st.gcps.used).sum()),
                        hypotheses=hypotheses)

    def record_offsets(tmp: Path, lines: list[ImportedLine], plan: ProjectPlan):
        lines, plan = refine(tmp, lines, plan)
        chosen = chosen_box[-1]
        record.extra.update(offsets=chosen, boresight_deg=chosen.boresight_deg, hypotheses=hypotheses)
        record.decide("offsets", chosen.description, "the split of PARGE's history whose fixed boresight fits the "
                      "used GCPs best" if chosen.fit_px else "not testable without used GCPs",
                      {"fit_lines_px": chosen.fit_px, "boresight_deg": chosen.boresight_deg},
                      {h.description: {"fit_lines_px": h.fit_px} for h in hypotheses if h is not chosen})
        return lines, plan

    write_project(out, [line], plan, record, refine=record_offsets)
    chosen = chosen_box[-1]
    progress(5, 5, "import: done")
    return ImportResult(out, strip, rate, rate_source, geoid_text, chosen.boresight_deg, chosen, hypotheses,
                        int(st.gcps.used.sum()), int((~st.gcps.used).sum()), dtm_choice.why, list(record.notes),
                        list(record.warnings))


#: The conventions applied, as written into import.json (module docstring).
CONVENTIONS = {
    "roll": "scangeo roll = -rollarr (PARGE's roll is positive with the left wing down)",
    "pitch": "scangeo pitch = pitcharr",
    "heading": "scangeo true heading = headarr (grid) + meridian convergence of the map CRS",
    "look_angles": "scangeo across = -vinkelx, along = +vinkely (sensarr columns 1, 2)",
    "image_coordinates": "GCP pixel and line are 0-based indices of the raw image, pixel centres",
    "heights": "trajectory h = gpsarr altitude; GCP and DTM heights as PARGE's DEM; N = PARGE's height "
               "offset unless a geoid is given",
}


def line_stream(st: ParGeStatus, rate: float, convergence: np.ndarray,
                offsets_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> GpsImuStream:
    """The line's navigation in scangeo's conventions (module docstring), one record a line at ``rate``.

    ``offsets_deg``: PARGE's offsets (roll, pitch, heading; PARGE's signs, deg) added back to the
    attitude arrays first: with the offsets the arrays hold, the GNSS/INS's own attitude (a
    platform's trajectory, :mod:`scangeo.importers.parge_platform`)."""
    times = st.start_seconds + np.arange(st.lines) / rate
    roll, pitch, heading = st.roll, st.pitch, st.heading
    if any(offsets_deg):
        o = np.radians(offsets_deg)
        roll, pitch, heading = roll + o[0], pitch + o[1], heading + o[2]
    return GpsImuStream(times, np.radians(st.lat), np.radians(st.lon), st.altitude, -roll, pitch,
                        heading + convergence, source=str(st.path))


def _strip_id(st: ParGeStatus) -> str:
    keep = "".join(c if c.isalnum() or c in "-_" else "_" for c in st.camera)
    return keep or "line"


def _look_angles(st: ParGeStatus, sensor_model) -> tuple[np.ndarray, np.ndarray, str]:
    """scangeo's across- and along-track look angles (rad) and where they came from."""
    if sensor_model is not None:
        model = HySpexSensorModel.read(sensor_model, pixels=st.pixels)
        vx, vy, source = model.vinkelx, model.vinkely, f"{Path(sensor_model).name} (the HySpex sensor model given)"
    else:
        vx, vy, source = st.look_across, st.look_along, "the status file's sensarr"
    across = -np.asarray(vx, float)
    if not (np.all(np.diff(across) > 0) or np.all(np.diff(across) < 0)):
        raise ParGeFileError(f"{sensor_model or st.path}: the across-track look angles are not monotonic over the "
                             "pixels")
    return across, np.asarray(vy, float), source


def _line_rate(st: ParGeStatus, record: ImportRecord) -> tuple[float, str]:
    """The line rate: the camera's frame period where its header gives one, else PARGE's SCANFREQ.

    PARGE's navigation has one record a line, spaced 1 / SCANFREQ: a frame period that says another
    rate is a line rate that disagrees with the navigation's spacing (a warning)."""
    if st.frame_period_us:
        rate = 1e6 / st.frame_period_us
        figures = {"frame_period_us": st.frame_period_us, "scanfreq_hz": st.scan_frequency_hz,
                   "duration_s_at_frame_period": round(st.lines / rate, 3),
                   "duration_s_at_scanfreq": round(st.lines / st.scan_frequency_hz, 3)}
        if abs(rate - st.scan_frequency_hz) > 1e-6 * rate:
            record.warn(f"{st.path.name}: the camera's frame period ({st.frame_period_us:g} us) says {rate:.4f} "
                        f"lines/s, PARGE's SCANFREQ (the spacing of its navigation records) {st.scan_frequency_hz:g} "
                        f"Hz: the frame period is taken ({st.lines / rate:.1f} s instead of "
                        f"{st.lines / st.scan_frequency_hz:.1f} s for the line)")
        record.decide("line_rate", f"{rate:.4f} Hz (the camera's frame period)",
                      "the camera's header is the camera's own; PARGE's SCANFREQ a processing setting", figures)
        return rate, f"frame period {st.frame_period_us:g} us (camera header)"
    record.decide("line_rate", f"{st.scan_frequency_hz:g} Hz (PARGE's SCANFREQ)", "the camera's header gives no "
                  "frame period", {"scanfreq_hz": st.scan_frequency_hz})
    return st.scan_frequency_hz, "PARGE's SCANFREQ"


#: camera families that HySpex (and other makers) name in file names
_FAMILIES = ("VNIR", "SWIR", "MWIR", "LWIR")


def _names(text: str) -> tuple[set[str], set[str]]:
    """(camera families, serial numbers) named in a file name or description."""
    upper = text.upper()
    families = {f for f in _FAMILIES if re.search(rf"(?<![A-Z]){f}(?![A-Z])", upper)}
    serials = set(re.findall(r"SN[_-]?(\d+)", upper))
    return families, serials


def _same_serial(a: set[str], b: set[str]) -> bool:
    return bool({int(v) for v in a} & {int(v) for v in b})


def _check_names(st: ParGeStatus, sensor_model, record: ImportRecord) -> None:
    """A warning when the image's name and the sensor (its model file, its description) name other cameras."""
    image_f, image_s = _names(st.image_name)
    sources = [("the sensor's model file", st.sensor_file), ("the sensor's description", st.sensor_description),
               ("the camera's header ID", st.camera)]
    if sensor_model is not None:
        sources.append(("the sensor model given", Path(sensor_model).name))
    for what, text in sources:
        fam, ser = _names(text)
        if (image_f and fam and not image_f & fam) or (image_s and ser and not _same_serial(image_s, ser)):
            record.warn(f"{st.path.name}: image.NAME names a {_camera_words(image_f, image_s)} "
                        f"({_file_name(st.image_name)}), but {what} names a {_camera_words(fam, ser)} "
                        f"({_file_name(text)}): check that the status file, its image and its sensor model are "
                        "of one camera")
            return


def _camera_words(families: set[str], serials: set[str]) -> str:
    words = "/".join(sorted(families)) or "camera"
    return words + (f" SN{'/'.join(sorted(serials))}" if serials else "")


def _file_name(text: str) -> str:
    """The last part of a Windows or POSIX path (PARGE writes Windows paths)."""
    return Path(text.replace("\\", "/")).name


def _check_start_time(st: ParGeStatus, record: ImportRecord) -> None:
    """A warning when the line's first navigation time is not a time of the line's day."""
    start, end = st.start_seconds, st.start_seconds + st.lines / st.line_rate_hz
    if not (0.0 <= start < 86400.0):
        record.warn(f"{st.path.name}: the line's first navigation time is {start:.1f} s (image.STARTTIME "
                    f"{st.start_hours:g} h), not a time of its day {st.date or '(no date)'}: its times are not the "
                    "GNSS's (a time offset to other navigation would be meaningless)")
    record.decide("start_time", f"{start:.3f} s of the day (image.STARTTIME x 3600)",
                  "PARGE's STARTTIME is the first line's time in hours of the day",
                  {"start_s": start, "end_s": round(end, 3), "date": st.date})


def _cube(st: ParGeStatus, image, record: ImportRecord) -> EnviCube | None:
    """The line's cube, checked against the status file; None without one."""
    if image is None:
        record.note(f"no image: image.NAME names {_file_name(st.image_name)}; give the cube "
                    "to rectify the line")
        return None
    cube = EnviCube.read(image)
    if (cube.samples, cube.lines) != (st.pixels, st.lines):
        raise ImportFileError(f"{cube.header}: {cube.samples} samples x {cube.lines} lines, but the status file "
                              f"{st.path.name} has {st.pixels} pixels x {st.lines} lines (another line's cube?)")
    if cube.bands != st.bands:
        record.warn(f"{cube.header.name}: {cube.bands} bands, the status file says {st.bands} (a subset of the "
                    "bands? the geometry does not depend on them)")
    record.source("cube", cube.data)
    return cube


def _dtm(st: ParGeStatus, dtm, record: ImportRecord) -> DtmChoice:
    if dtm is not None:
        return given_dtm(dtm)
    if len(st.gcps):
        return DtmChoice("gcps", why=f"a surface through the {len(st.gcps)} GCPs' heights (not a DEM)")
    record.warn(f"{st.path.name}: no GCPs and no DTM given: the project has no DTM, and scangeo run stops at its "
                "check; give the DTM (dtm: a raster or a height)")
    return DtmChoice("none", why="none: the line needs a DTM")


def _point_ids(st: ParGeStatus) -> list[str]:
    n = len(st.gcps) + st.placeholder_gcps
    width = max(2, len(str(n)))
    return [f"GCP{k + 1:0{width}d}" for k in st.gcps.row]


def _control(st: ParGeStatus, strip: str) -> Control | None:
    n = len(st.gcps)
    if not n:
        return None
    ids = np.array(_point_ids(st), dtype=object)
    roles = np.where(st.gcps.used, "control", "check")
    ground = GroundPoints(ids, st.gcps.xyz, np.full(n, GCP_SIGMA_XY_M), np.full(n, GCP_SIGMA_Z_M),
                          np.array(roles, dtype=object), np.arange(n))
    points = ImagePoints(ids, np.array([strip] * n, dtype=object), st.gcps.line, st.gcps.pixel,
                         np.full(n, GCP_SIGMA_PX), np.arange(n))
    return Control(ground, points)


def _geoid(st: ParGeStatus, geoid, notes: list[str]) -> tuple[float | str, str]:
    """The geoid undulation (m) or raster of the project, and a sentence saying where it came from."""
    diff = st.altitude - st.height
    offset = float(np.median(diff))
    if np.ptp(diff) > 1e-3:
        notes.append(f"gpsarr altitude - navarr height varies by {np.ptp(diff):.3f} m; its median {offset:.3f} m "
                     "is taken as PARGE's height offset")
    if geoid is None:
        return offset, (f"N = {offset:.3f} m: PARGE's height offset (gpsarr altitude - navarr height), not a geoid "
                        "model (give the real undulation as the geoid)")
    if isinstance(geoid, int | float):
        return float(geoid), f"N = {float(geoid):.3f} m (given)"
    path = Path(geoid)
    try:
        value = float(str(geoid))
    except ValueError:
        if not path.exists():
            raise MissingFileError(f"{geoid}: no such geoid raster (the geoid is a number of metres or a "
                                   "raster)") from None
        return str(path.resolve()), f"geoid raster {path.resolve()} (given)"
    return value, f"N = {value:.3f} m (given)"


def _convergence(st: ParGeStatus) -> np.ndarray:
    """Meridian convergence (rad) of the map CRS at every record: true heading = grid heading + gamma."""
    crs = pyproj.CRS.from_wkt(st.crs_wkt)
    if crs.is_geographic:
        return np.zeros(st.lines)
    factors = pyproj.Proj(crs).get_factors(st.lon, st.lat)
    return np.radians(np.asarray(factors.meridian_convergence, float))


def _nominal_agl(st: ParGeStatus) -> float:
    if len(st.gcps):
        return float(np.median(st.height) - np.median(st.gcps.xyz[:, 2]))
    return 700.0


def _footprint(st: ParGeStatus, across: np.ndarray, along: np.ndarray) -> tuple[float, float, float, float]:
    """Map box (xmin, ymin, xmax, ymax) of the line's ground footprint, with a margin."""
    agl = max(_nominal_agl(st), 10.0)
    reach = agl * np.tan(np.max(np.abs(across)) + np.max(np.abs(-st.roll)) + 0.05)
    reach_along = agl * np.tan(np.max(np.abs(st.pitch)) + np.max(np.abs(along)) + 0.05)
    r = max(reach, reach_along) + 50.0
    return (float(st.easting.min() - r), float(st.northing.min() - r),
            float(st.easting.max() + r), float(st.northing.max() + r))


def _origin(st: ParGeStatus) -> tuple[float, float, float]:
    """The project frame's origin: the line's middle, at the ground's height (ellipsoidal)."""
    k = st.lines // 2
    ground = float(np.median(st.gcps.xyz[:, 2])) if len(st.gcps) else float(st.height[k]) - _nominal_agl(st)
    return float(st.lat[k]), float(st.lon[k]), ground


def _crs_text(wkt: str) -> str:
    """``EPSG:32606`` where PROJ identifies the status file's WKT with an EPSG code, else the WKT."""
    code = pyproj.CRS.from_wkt(wkt).to_epsg(min_confidence=90)
    return f"EPSG:{code}" if code else wkt


def _hypotheses(st: ParGeStatus, roll: np.ndarray, pitch: np.ndarray, heading: np.ndarray) -> list[OffsetHypothesis]:
    """Every split of the history's offset changes into held by the arrays / still to apply.

    The history is read two ways. Added: each boresight result and offset event adds to the offsets
    (``aux`` = the offsets older than the history + every change; true of both shared lines). Set: a
    boresight result sets the offsets to itself and the later events add to it. The states after
    each change, under both readings (the same ones once), are the candidates; the arrays holding
    none and all of the offsets are two of them."""
    total = np.degrees([st.offsets["roll"], st.offsets["pitch"], st.offsets["heading"]])
    changes = [np.array(e.degrees) for e in st.events]
    before = total - (np.sum(changes, axis=0) if changes else 0.0)  # offsets older than the history kept
    states: list[tuple[str, np.ndarray]] = [("the arrays hold none of PARGE's offsets", np.zeros(3))]
    held = before.copy()
    if np.abs(before).max() > 1e-6:  # the history prints 8 digits
        states.append(("the arrays hold the offsets older than the history, not its changes", held.copy()))
    for k, (e, c) in enumerate(zip(st.events, changes)):
        held = held + c
        last = k == len(changes) - 1
        states.append(("the arrays hold all of PARGE's offsets" if last and np.abs(held - total).max() < 1e-6 else
                       f"the arrays hold the offsets up to {_event_name(e)}, not the later ones", held.copy()))
    set_state: np.ndarray | None = None
    for e, c in zip(st.events, changes):  # the other reading: a boresight result sets the offsets
        set_state = c.copy() if e.kind == "crossbore" else (None if set_state is None else set_state + c)
        if set_state is not None:
            states.append((f"the arrays hold the offsets as set by the boresight results, up to {_event_name(e)}",
                           set_state.copy()))
    states.append(("the arrays hold all of PARGE's offsets", total.copy()))
    out: list[OffsetHypothesis] = []
    for text, state in states:
        remainder = total - state
        if any(np.abs(np.array(h.remainder_deg) - remainder).max() < 1e-6 for h in out):
            continue  # the same split, reached the other way
        bs, worst = _as_boresight(roll, pitch, heading, remainder)
        out.append(OffsetHypothesis(len(out), text, tuple(float(v) for v in remainder), bs, worst))  # type: ignore[arg-type]
    return out


def _event_name(e) -> str:
    if e.kind == "crossbore":
        return f"the boresight result of {e.time}"
    axis = ("roll", "pitch", "heading")[int(np.argmax(np.abs(e.degrees)))]
    return f"the {axis} offset of {e.time}"


def _as_boresight(roll, pitch, heading, remainder_deg) -> tuple[tuple[float, float, float], float]:
    """The constant boresight (deg) closest to adding PARGE's offsets to the attitude angles, and the
    largest angle (deg) between it and the exact per-record rotation."""
    r = np.radians(remainder_deg)
    R_arrays = rph_to_matrix(roll, pitch, heading)
    R_parge = rph_to_matrix(roll - r[0], pitch + r[1], heading + r[2])  # PARGE's roll sign is scangeo's negative
    per_record = np.einsum("nji,njk->nik", R_arrays, R_parge)
    u, _, vt = np.linalg.svd(per_record.sum(axis=0))
    mean = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    dev = np.einsum("ji,njk->nik", mean, per_record)
    angle = np.degrees(np.arccos(np.clip((np.trace(dev, axis1=1, axis2=2) - 1) / 2, -1, 1))).max()
    rph = np.degrees(matrix_to_rph(mean))
    return (float(rph[0]), float(rph[1]), float(rph[2])), float(angle)


def _fitted(project: Project, nominal: StripGeometry, st: ParGeStatus, h: OffsetHypothesis) -> OffsetHypothesis:
    """The hypothesis with the rms of the used GCPs' residuals (lines, pixels) under its boresight,
    at the measured lines' poses, as the adjustment computes them (``measurement_time = "line"``)."""
    mounting = Mounting(project.sensor.mounting.lever_arm_B, np.radians(h.boresight_deg),
                        project.sensor.mounting.time_offset)
    geometry = StripGeometry(nominal.sensor, nominal.spline, nominal.timing, nominal.n_lines, mounting,
                             nominal.strip_id)
    used = st.gcps.used
    xyz = st.gcps.xyz[used]
    p_P = project.map_frame.map_to_project(xyz[:, 0], xyz[:, 1], xyz[:, 2])
    dl, dp = geometry.measured_line_residuals(p_P, st.gcps.line[used], st.gcps.pixel[used])
    ok = np.isfinite(dl) & np.isfinite(dp)
    if not ok.any():
        return replace(h, fit_px=(math.inf, math.inf))
    return replace(h, fit_px=(float(np.sqrt(np.mean(dl[ok] ** 2))), float(np.sqrt(np.mean(dp[ok] ** 2)))))


def _default_hypothesis(hypotheses: list[OffsetHypothesis]) -> OffsetHypothesis:
    """Without GCPs: the arrays hold everything up to the last boresight result (as on the lines where
    the GCPs could tell), else all of the offsets."""
    for h in reversed(hypotheses):
        if "boresight result" in h.description:
            return h
    return hypotheses[-1]


#: variants.toml after its comments, of a line with used GCPs (the platform's says "the lines")
VARIANTS_BODY = """[defaults]
strategy = "DG"                     # GPS/IMU as measured: a single line has no tie points to adjust it with
gps_sigma_m = [0.05, 0.05, 0.10]
imu_sigma_deg = [0.003, 0.003, 0.005]

[variants.PARGE]
description = "PARGE's boresight held fixed"
snooping = false

[variants.BORESIGHT]
description = "boresight (roll, pitch, heading) calibrated from the control GCPs"
calibrate = ["boresight"]

[variants.CALIBRATED]
description = "boresight, and what the control determines of the look angles and the time offset"
calibrate = ["boresight", "across_offset", "across_scale", "along_offset", "time_offset"]
# the look angles' calibration and the time offset are kept only where significant (t-test, alpha 0.05):
# the offsets duplicate the boresight's roll and pitch, the scale and time offset need wide, varied control
test_calibration = ["across_offset", "across_scale", "along_offset", "time_offset"]
"""


def _variants_toml(st: ParGeStatus, chosen: OffsetHypothesis) -> str:
    bs = ", ".join(f"{v:.4f}" for v in chosen.boresight_deg)
    if not st.gcps.used.any():
        return f"""# Written by scangeo import parge ({st.path.name}); edit freely: scangeo run keeps it.
# PARGE's boresight in scangeo's convention is [sensor] boresight_deg = [{bs}] (project.toml).
# The line has no used GCPs: nothing can be calibrated, and the orthoimage is a direct georeferencing.

[defaults]
strategy = "DG"

[variants.PARGE]
description = "PARGE's boresight held fixed (direct georeferencing: no control)"
snooping = false
"""
    return f"""# Written by scangeo import parge ({st.path.name}); edit freely: scangeo run keeps it.
# PARGE's boresight in scangeo's convention is [sensor] boresight_deg = [{bs}] (project.toml).

{VARIANTS_BODY}"""


__all__ = ["CONVENTIONS", "ImportResult", "OffsetHypothesis", "VARIANTS", "import_parge", "line_stream"]
