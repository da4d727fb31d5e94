"""``scangeo import lcf``: a Resonon or Specim drone pushbroom line (ENVI cube, ``.lcf``, ``.times``) as a project.

The shape of every importer (:mod:`scangeo.importers.writer`):

1. **read and check**: the cube's header against its data file (:class:`~scangeo.importers.envi.
   EnviCube`), the navigation log and the line times (:mod:`scangeo.importers.lcf_files`), the camera
   (a field of view over the cube's samples, or a look-angle table of as many pixels), the GCPs;
2. **find the conventions** (:mod:`scangeo.importers.lcf_conventions`): the time bases, the heading
   and the roll against the track, the altitude's datum, the knot spacing;
3. **write the project** atomically: ``nav/ID.csv`` in scangeo's conventions (roll negated, heights
   above the ellipsoid), ``nav/ID_lines.csv`` (the line times on the navigation's time base),
   ``sensor/look_angles.csv``, the DTM (given, a plane, or none), ground.csv and points.csv when given;
4. **record** every decision with its figures in ``import.json``.

Without GCPs the project is a direct georeferencing: ``scangeo run`` rectifies it and its report
calls the result unchecked.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj

from scangeo.errors import ArgumentError, ImportFileError, MissingFileError
from scangeo.importers.envi import EnviCube
from scangeo.importers.lcf_conventions import altitude_datum, attitude_checks, knot_spacing, time_base
from scangeo.importers.lcf_files import LineTimes, NavigationLog
from scangeo.importers.record import ImportRecord, ranges, rounded
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
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.progress import ProgressCallback, no_progress
from scangeo.textfile import read_text
from scangeo.trajectory.stream import GpsImuStream

#: The conventions applied, as written into import.json.
CONVENTIONS = {
    "roll": "scangeo roll = -lcf roll (lcf_spec: positive right wing up)",
    "pitch": "scangeo pitch = lcf pitch (positive nose up)",
    "heading": "scangeo heading = lcf heading (zero at due north, pi/2 at due east)",
    "time": "line time = .times - its first + the .lcf's first (on GPS seconds of the week)",
    "image_coordinates": "line = the cube's row, pixel = its sample, 0-based, pixel centres",
}


@dataclass
class LcfImport:
    """What ``scangeo import lcf`` wrote and decided (also in ``OUT/import.json``)."""

    folder: Path
    strip: str
    lines: int
    line_rate_hz: float
    record: ImportRecord
    control: int = 0
    check: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def warnings(self) -> list[str]:
        return self.record.warnings


def import_lcf(cube, out, *, lcf=None, times=None, fov_deg: float | None = None, look_angles=None,
               pixels_increase: str = "right", dtm=None, geoid: float | str | None = None, altitude: str = "auto",
               ground=None, points=None, crs: str | None = None, strip: str | None = None,
               knot_spacing_s: float | None = None, progress: ProgressCallback = no_progress) -> LcfImport:
    """Write a scangeo project from a drone pushbroom line: an ENVI cube, its ``.lcf`` and ``.times``.

    Parameters
    ----------
    cube : the cube's header (``.hdr``) or data file (``.bil``, ``.bip``, ``.bsq``, ...).
    out : the project folder to write; it must not exist or be empty.
    lcf, times : the navigation log and the line times; default: beside the cube (``X.lcf``,
        ``X.bil.times`` or ``X.times``).
    fov_deg : the camera's field of view (deg) over the cube's samples (a pinhole: the pixels' tangents
        evenly spaced, the edges at +-fov/2); or
    look_angles : a look-angle table (``pixel,along_deg,across_deg``, docs/formats.md) of the cube's
        samples.
    pixels_increase : ``"right"`` (pixel numbers grow to the right of the flight direction) or
        ``"left"``; with ``fov_deg`` only.
    dtm : a DTM raster, or a number: a plane at that orthometric height (m; over water, the sea
        surface). None: the DTM from the GCPs' heights, else none (the project says it needs one).
    geoid : the geoid undulation N (m) or a raster of N.
    altitude : ``"auto"`` (decided from the data, ``import.json``), ``"ellipsoidal"`` or ``"orthometric"``.
    ground, points : ground.csv and points.csv (docs/formats.md) of GCPs measured in the cube; the
        points' strip is the line's id.
    crs : the map CRS; default the UTM zone of the line.
    strip : the line's id; default the cube's name.
    knot_spacing_s : the spline's knot spacing (s); default decided from the attitude.
    progress : ``callback(done, total, message)``.

    Returns
    -------
    LcfImport : what was written and decided.

    Raises
    ------
    ImportFileError : a file cannot be imported (names the file, the line, what was expected).
    MissingFileError : a file is missing.
    ArgumentError : contradictory or missing arguments (the camera, the altitude's datum).
    ProjectFileError : ``out`` exists and is not empty.
    """
    out = check_out(out)
    if (fov_deg is None) == (look_angles is None):
        raise ArgumentError("give the camera as fov_deg (with the cube's samples as pixels) or as look_angles, "
                            "exactly one of them")
    if pixels_increase not in ("right", "left"):
        raise ArgumentError(f"pixels_increase {pixels_increase!r}: expected right or left")
    record = ImportRecord("lcf")
    progress(0, 4, "import: reading the cube's header, the .lcf and the .times")
    c = EnviCube.read(cube)
    lcf_path = Path(lcf) if lcf is not None else _beside(c, ".lcf", "navigation log")
    times_path = Path(times) if times is not None else _beside(c, ".times", "line times")
    nav = NavigationLog.read(lcf_path)
    line_times = LineTimes.read(times_path)
    for role, path in (("cube_header", c.header), ("cube", c.data), ("lcf", lcf_path), ("times", times_path)):
        record.source(role, path)
    if nav.set_aside:
        record.note(f"{len(nav.set_aside)} records of {lcf_path.name} flagged 0 (do not use) were set aside "
                    f"(lines {ranges(nav.set_aside)})")
    along, across, camera = _camera(c, fov_deg, look_angles, pixels_increase, record)
    strip_id = strip or _strip_id(c)
    timing = time_base(nav, line_times, c.lines, c.frame_rate_hz, record)
    progress(1, 4, "import: finding the conventions")
    speed = attitude_checks(nav, timing.nav_time, record)
    ifov = _centre_ifov(across)
    along_gsd = speed / timing.line_rate_hz
    crs_obj = _crs(crs, nav)
    control = _control(ground, points, strip_id, timing.lines, c.samples)
    choice = given_dtm(dtm) if dtm is not None else DtmChoice("none")
    if choice.kind == "none" and control is not None and len(control.ground):
        choice = DtmChoice("gcps", why="a surface through the GCPs' heights (no DTM given)")
    geoid_n, geoid_value = _geoid(geoid, nav)
    ground_h = _ground_height(choice, control, nav)
    datum, n = altitude_datum(altitude, nav, geoid_n, ground_h, along_gsd, ifov, record)
    h = nav.altitude + (n if datum == "orthometric" else 0.0)
    spacing = knot_spacing(timing.nav_time, nav.roll, nav.pitch, nav.heading, ifov, record, knot_spacing_s)
    stream = GpsImuStream(timing.nav_time, np.radians(nav.lat), np.radians(nav.lon), h, -nav.roll, nav.pitch,
                          nav.heading, source=str(lcf_path))
    sensor = ImportedSensor(camera, along, across, timing.line_rate_hz, source=record.decision("camera").choice,
                            bands=c.band_names, wavelengths_nm=_wavelengths(c))
    line = ImportedLine(strip_id, stream, timing.lines, sensor, line_times=timing.line_time[:timing.lines],
                        image=c.data.resolve(), control=control,
                        image_shape=(c.lines, c.samples, c.bands, c.dtype.str))
    agl = _height_above_ground(record, nav, n, ground_h, along_gsd, ifov)
    if choice.kind == "none":
        record.warn("no DTM and no GCPs: the project has no DTM and scangeo run stops at its check; give the DTM "
                    "(over water a plane at the sea surface: dtm = 0)")
    progress(2, 4, "import: writing the project")
    ground_ellipsoidal = (ground_h if ground_h is not None else float(np.median(nav.altitude)) - agl) + n
    k = len(nav) // 2
    plan = ProjectPlan(crs=_crs_text(crs_obj), crs_wkt=crs_obj.to_wkt(), geoid=geoid_value,
                       origin=(float(nav.lat[k]), float(nav.lon[k]), ground_ellipsoidal), knot_spacing_s=spacing,
                       dtm=choice, box=_box(nav, crs_obj, agl, across, nav.roll), tool="lcf",
                       comment=f"{c.data.name} ({camera})")
    record.extra.update(conventions=CONVENTIONS, strip=strip_id, cube={"samples": c.samples, "lines": c.lines,
                                                                       "bands": c.bands, "interleave": c.interleave,
                                                                       "data_type": c.dtype.name},
                        dtm=choice.why or choice.kind, records=len(nav), set_aside_lines=list(nav.set_aside))
    write_project(out, [line], plan, record)
    progress(4, 4, "import: done")
    roles = list(control.ground.role) if control is not None else []
    return LcfImport(out, strip_id, timing.lines, timing.line_rate_hz, record, roles.count("control"),
                     roles.count("check"), list(record.notes))


def _beside(c: EnviCube, suffix: str, what: str) -> Path:
    candidates = [c.data.with_name(c.data.name + suffix), c.data.with_suffix(suffix),
                  c.header.with_suffix("").with_suffix(suffix)]
    for p in candidates:
        if p.is_file():
            return p
    names = ", ".join(dict.fromkeys(p.name for p in candidates))
    raise MissingFileError(f"{c.data}: no {what} beside the cube (looked for {names}; give it)")


def _strip_id(c: EnviCube) -> str:
    name = c.data.name.split(".")[0]
    keep = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name)
    return keep or "line"


def _camera(c: EnviCube, fov_deg, look_angles, pixels_increase: str, record: ImportRecord
            ) -> tuple[np.ndarray, np.ndarray, str]:
    """(along, across) look angles (rad) of the cube's samples, and the camera's name."""
    n = c.samples
    if fov_deg is not None:
        fov = float(fov_deg)
        if not 0 < fov < 180:
            raise ArgumentError(f"fov_deg {fov_deg}: expected 0 < fov < 180 degrees")
        sign = 1.0 if pixels_increase == "right" else -1.0
        tangent = sign * (np.arange(n) - (n - 1) / 2) * 2 * math.tan(math.radians(fov) / 2) / n
        record.decide("camera", f"a field of view of {fov:g} deg over {n} pixels, numbers growing to the "
                      f"{pixels_increase}", "given: the pixels' tangents evenly spaced, the edges at +-fov/2",
                      {"fov_deg": fov, "pixels": n, "pixels_increase": pixels_increase})
        return np.zeros(n), np.arctan(tangent), f"{n} px, {fov:g} deg"
    path = Path(look_angles)
    if not path.is_file():
        raise MissingFileError(f"{path}: no such look-angle table")
    text = read_text(path, "a look-angle table: pixel,along_deg,across_deg", ImportFileError).splitlines()
    try:
        data = np.loadtxt(text, delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise ImportFileError(f"{path}: not a look-angle table pixel,along_deg,across_deg ({exc})") from None
    if data.shape[1] != 3 or not np.isfinite(data).all():
        raise ImportFileError(f"{path}: expected three finite columns pixel,along_deg,across_deg")
    if len(data) != n:
        raise ImportFileError(f"{path}: {len(data)} pixels, but the cube {c.header.name} has {n} samples (a camera "
                              "model of another pixel count?)")
    if not np.array_equal(data[:, 0], np.arange(n)):
        raise ImportFileError(f"{path}: the pixel column is not 0, 1, ..., {n - 1} in order")
    across = np.radians(data[:, 2])
    if not (np.all(np.diff(across) > 0) or np.all(np.diff(across) < 0)):
        raise ImportFileError(f"{path}: the across-track look angles are not monotonic over the pixels")
    record.decide("camera", f"the look-angle table {path.name}", "given", {"pixels": n,
                  "across_deg": [rounded(data[0, 2], 4), rounded(data[-1, 2], 4)]})
    return np.radians(data[:, 1]), across, path.stem


def _centre_ifov(across: np.ndarray) -> float:
    """The angle (rad) between neighbouring pixels at the centre of the line."""
    n = len(across)
    mid = slice(max(n // 2 - max(n // 20, 1), 0), min(n // 2 + max(n // 20, 1) + 1, n))
    return float(np.median(np.abs(np.diff(across[mid])))) if n > 1 else 0.0


def _wavelengths(c: EnviCube) -> tuple[float, ...]:
    units = c.keys.get("wavelength units", "nm").strip().lower()
    if not c.wavelengths or not all(w > 0 for w in c.wavelengths):
        return ()
    factor = {"nm": 1.0, "nanometers": 1.0, "micrometers": 1000.0, "um": 1000.0, "microns": 1000.0}.get(units)
    return tuple(w * factor for w in c.wavelengths) if factor else ()


def _crs(crs: str | None, nav: NavigationLog) -> pyproj.CRS:
    if crs is not None:
        try:
            return pyproj.CRS.from_user_input(crs)
        except pyproj.exceptions.CRSError as exc:
            raise ArgumentError(f"crs {crs!r}: not a CRS PROJ knows ({exc})") from None
    from pyproj.aoi import AreaOfInterest
    from pyproj.database import query_utm_crs_info

    lon, lat = float(np.median(nav.lon)), float(np.median(nav.lat))
    found = query_utm_crs_info(datum_name="WGS 84", area_of_interest=AreaOfInterest(lon, lat, lon, lat))
    if not found:
        raise ArgumentError(f"crs: no UTM zone found for {lat:.4f}, {lon:.4f}; give the map CRS")
    return pyproj.CRS.from_epsg(int(found[0].code))


def _crs_text(crs: pyproj.CRS) -> str:
    code = crs.to_epsg(min_confidence=90)
    return f"EPSG:{code}" if code else crs.to_wkt()


def _control(ground, points, strip_id: str, lines: int, pixels: int) -> Control | None:
    if ground is None and points is None:
        return None
    if ground is None or points is None:
        raise ArgumentError("ground and points: give both (ground.csv with the GCPs' coordinates, points.csv with "
                            "their measurements in the cube)")
    g, p = GroundPoints.read(ground), ImagePoints.read(points)
    for i in range(len(p)):
        where = f"{points} line {p.file_line[i]}"
        if str(p.strip[i]) != strip_id:
            raise ImportFileError(f"{where}: strip {p.strip[i]!r}, expected the line's id {strip_id!r}")
        if not (-0.5 <= p.line[i] <= lines - 0.5 and -0.5 <= p.pixel[i] <= pixels - 0.5):
            raise ImportFileError(f"{where}: line {p.line[i]:g}, pixel {p.pixel[i]:g} is outside the line's image "
                                  f"(lines 0..{lines - 1}, pixels 0..{pixels - 1})")
    return Control(g, p)


def _geoid(geoid, nav: NavigationLog) -> tuple[float | None, float | str]:
    """(N at the line, m or None, and what project.toml says)."""
    if geoid is None:
        return None, 0.0
    try:
        value = float(str(geoid))
    except ValueError:
        path = Path(geoid).resolve()
        if not path.is_file():
            raise MissingFileError(f"{geoid}: no such geoid raster (the geoid is a number of metres or a "
                                   "raster)") from None
        return _sample(path, float(np.median(nav.lon)), float(np.median(nav.lat))), str(path)
    return value, value


def _sample(path: Path, lon: float, lat: float) -> float:
    """A raster's value at a geodetic position (its first band, nearest cell)."""
    import rasterio

    try:
        with rasterio.open(path) as src:
            t = pyproj.Transformer.from_crs("EPSG:4326", src.crs, always_xy=True)
            x, y = t.transform(lon, lat)
            value = float(next(src.sample([(x, y)]))[0])
            nodata = src.nodata
    except (rasterio.errors.RasterioError, pyproj.exceptions.CRSError) as exc:
        raise ImportFileError(f"{path}: cannot read the raster ({exc})") from None
    if not math.isfinite(value) or (nodata is not None and value == nodata):
        raise ImportFileError(f"{path}: no value at {lat:.5f}, {lon:.5f} (the line's centre)")
    return value


def _ground_height(choice: DtmChoice, control: Control | None, nav: NavigationLog) -> float | None:
    """The ground's orthometric height under the line (m), or None when nothing says it."""
    if choice.kind == "plane":
        return choice.height_m
    if choice.kind == "given" and choice.path is not None:
        return _sample(choice.path, float(np.median(nav.lon)), float(np.median(nav.lat)))
    if control is not None and len(control.ground):
        return float(np.median(control.ground.xyz[:, 2]))
    return None


def _height_above_ground(record: ImportRecord, nav: NavigationLog, n: float, ground_h: float | None,
                         along_gsd: float, ifov: float) -> float:
    if ground_h is not None:
        return max(float(np.median(nav.altitude)) - (n if record.decision("altitude").choice.startswith(
            "above the ellipsoid") else 0.0) - ground_h, 1.0)
    return max(along_gsd / ifov if ifov > 0 else 50.0, 1.0)  # nominal: the height of square pixels


def _box(nav: NavigationLog, crs: pyproj.CRS, agl: float, across: np.ndarray, roll: np.ndarray
         ) -> tuple[float, float, float, float]:
    t = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    x, y = t.transform(nav.lon, nav.lat)
    reach = agl * math.tan(min(float(np.max(np.abs(across)) + np.max(np.abs(roll))) + 0.1, 1.4)) + 20.0
    return (float(np.min(x) - reach), float(np.min(y) - reach), float(np.max(x) + reach), float(np.max(y) + reach))


__all__ = ["CONVENTIONS", "LcfImport", "import_lcf"]
