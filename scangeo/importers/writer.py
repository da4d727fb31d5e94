"""The one writer of imported projects: checked in-memory lines in, a scangeo project folder out.

Every importer has the same shape (docs/architecture.md, "Importers"):

1. **read and check** its sources (each file's reader raises an error naming the file and line);
2. **find the conventions** from the data and apply them, recording each :class:`~scangeo.importers.
   record.Decision` with its figures, into one or more :class:`ImportedLine` (scangeo's conventions:
   a trajectory of ellipsoidal heights and NED attitudes, line times on the trajectory's time base,
   the camera's look angles);
3. **write the project** with :func:`write_project`: everything into a hidden folder that becomes
   OUT only when complete (:func:`scangeo.atomic.atomic_directory`), so a bad input leaves OUT as it
   was; a ``refine`` step may load the staged project to decide what needs its geometry (PARGE's
   offsets), then the project is written again;
4. **record** the decisions, warnings and notes in ``OUT/import.json``.

The writer takes several lines. Without flight lines in the plan they share one sensor and each has
its own trajectory (a one-sensor project: ``[sensor]``, strips with ``trajectory``). With
``ProjectPlan.flight_lines`` the project is a platform (docs/formats.md, "A platform"): every sensor
of the lines is a ``[[sensors]]`` entry, every flight line a ``[[flight_lines]]`` entry with its
trajectory, every line a strip naming its sensor and flight line, and the plan's relative mountings
``[[relative_mountings]]``.
"""
from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from scangeo.atomic import atomic_directory, write_csv, write_text
from scangeo.errors import ArgumentError, MissingFileError, ProjectFileError
from scangeo.importers.record import ImportRecord
from scangeo.importers.stand_in_dtm import write_gcp_dtm, write_plane_dtm
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project_schema import RelativeMountingKeys
from scangeo.trajectory.readers import write_trajectory_csv
from scangeo.trajectory.stream import GpsImuStream

#: The name project.toml gives the DTM of a line that has none yet (the file is not written).
MISSING_DTM = "dtm.tif"


@dataclass(frozen=True)
class ImportedSensor:
    """A pushbroom camera in scangeo's conventions.

    Parameters
    ----------
    name : the camera (for messages and comments).
    id : the sensor's id in a platform project (``[[sensors]]``); ignored in a one-sensor project.
    along, across : (pixels,) float arrays, radians: each pixel's along-track (positive forward) and
        across-track (positive to the right of the flight direction) look angle.
    line_rate_hz : lines per second.
    boresight_deg : roll, pitch, heading of the sensor in the body frame (scangeo's convention).
    source : where the look angles came from (written as a comment).
    """

    name: str
    along: np.ndarray
    across: np.ndarray
    line_rate_hz: float
    boresight_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    lever_arm_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    measurement_time: str = "scan_plane"
    bands: tuple[str, ...] = ()
    wavelengths_nm: tuple[float, ...] = ()
    source: str = ""
    id: str = ""

    @property
    def pixels(self) -> int:
        return len(self.across)


@dataclass(frozen=True)
class Control:
    """Ground control of a line: ground.csv's and points.csv's rows (the points' strip is the line's)."""

    ground: GroundPoints
    points: ImagePoints


@dataclass(frozen=True)
class ImportedLine:
    """One flight line, checked and in scangeo's conventions, ready to be written.

    ``stream``: the navigation (time base of the project, ellipsoidal heights, NED attitudes);
    ``first_line_time`` or ``line_times`` (s, the same time base); ``image``: the cube (absolute path)
    or None; ``image_shape``: its lines, samples, bands and numpy data type, when the line keeps
    fewer lines than the cube has (the project then reads the first ``lines`` through a VRT);
    ``flight_line``: in a platform project, the flight line it was recorded on (its ``stream`` is then
    not written: the flight line's trajectory is).
    """

    strip: str
    stream: GpsImuStream
    lines: int
    sensor: ImportedSensor
    first_line_time: float | None = None
    line_times: np.ndarray | None = None
    image: Path | None = None
    control: Control | None = None
    image_shape: tuple[int, int, int, str] | None = None
    flight_line: str | None = None


@dataclass(frozen=True)
class DtmChoice:
    """The project's DTM: ``given`` (a raster's path), ``plane`` (at ``height_m``), ``gcps`` (a surface
    through the control's heights) or ``none`` (project.toml names :data:`MISSING_DTM`, not written)."""

    kind: str
    path: Path | None = None
    height_m: float = 0.0
    why: str = ""


@dataclass(frozen=True)
class ProjectPlan:
    """What the project says besides its lines.

    ``crs``: the map CRS (text for project.toml); ``crs_wkt``: the same for rasters; ``geoid``: N in
    metres or a raster's path; ``origin``: latitude, longitude (deg), ellipsoidal height (m);
    ``box``: map xmin, ymin, xmax, ymax that a stand-in DTM must cover; ``variants``: the text of
    variants.toml (None: none, ``scangeo run`` writes its own); ``flight_lines``: a platform's
    flight lines, each its id and trajectory (empty: a one-sensor project); ``relative_mountings``:
    a platform's priors (``[[relative_mountings]]``).
    """

    crs: str
    crs_wkt: str
    geoid: float | str
    origin: tuple[float, float, float]
    knot_spacing_s: float
    dtm: DtmChoice
    box: tuple[float, float, float, float]
    tool: str
    comment: str = ""
    variants: str | None = None
    extra_files: dict[str, str] = field(default_factory=dict)
    flight_lines: tuple[tuple[str, GpsImuStream], ...] = ()
    relative_mountings: tuple[RelativeMountingKeys, ...] = ()


def check_out(out) -> Path:
    """OUT as a path; an error when it exists and is not an empty folder."""
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ProjectFileError(f"{out}: exists and is not an empty folder (the import writes a new project)")
    return out


def given_dtm(dtm) -> DtmChoice:
    """The DTM given to an import: a number is a plane at that orthometric height (m), anything else a raster's path."""
    try:
        height = float(str(dtm))
    except ValueError:
        path = Path(dtm).resolve()
        if not path.is_file():
            raise MissingFileError(f"{dtm}: no such DTM (a raster, or a number: a plane at that height)") from None
        return DtmChoice("given", path=path, why=f"{path} (given)")
    if not np.isfinite(height):
        raise ArgumentError(f"dtm {dtm}: expected a raster or a finite height in metres")
    return DtmChoice("plane", height_m=height, why=f"a plane at {height:g} m (given)")


RefineStep = Callable[[Path, list[ImportedLine], ProjectPlan], tuple[list[ImportedLine], ProjectPlan]]


def write_project(out, lines: Sequence[ImportedLine], plan: ProjectPlan, record: ImportRecord,
                  refine: RefineStep | None = None) -> tuple[list[ImportedLine], ProjectPlan]:
    """Write the project into the new folder ``out``, whole or not at all.

    Parameters
    ----------
    out : the project folder (must not exist or be empty: :func:`check_out`).
    lines : the lines: sharing one sensor, or (a platform: ``plan.flight_lines``) each naming its
        flight line, their sensors told apart by their ids.
    plan : the rest of the project.
    record : the import's record, written last as ``import.json``.
    refine : ``refine(staged_folder, lines, plan) -> (lines, plan)``: decisions that need the staged
        project (it may load it with :meth:`scangeo.io.project.Project.load`); the project is then
        written again with what it returns.

    Returns
    -------
    the lines and the plan as written (after ``refine``).
    """
    out = check_out(out)
    lines = list(lines)
    if not lines:
        raise ArgumentError("lines: expected at least one imported line")
    if plan.flight_lines:
        _platform(lines, plan)
    else:
        _one_sensor(lines)
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_directory(out) as tmp:
        _write_files(tmp, lines, plan)
        if refine is not None:
            lines, plan = refine(tmp, lines, plan)
            _write_files(tmp, lines, plan, dtm=False)
        record.extra.setdefault("folder", str(out))
        write_text(tmp / "import.json", record.to_json())
    return lines, plan


def _one_sensor(lines: list[ImportedLine]) -> None:
    first = lines[0].sensor
    for line in lines[1:]:
        s = line.sensor
        if (s.pixels != first.pixels or s.line_rate_hz != first.line_rate_hz
                or not np.array_equal(s.across, first.across) or not np.array_equal(s.along, first.along)):
            raise ArgumentError(f"line {line.strip}: another sensor than line {lines[0].strip}'s ({s.name}, "
                                f"{first.name}); a project of several sensors is not written yet")
    ids = [line.strip for line in lines]
    if len(set(ids)) != len(ids):
        raise ArgumentError(f"lines: the strip id {sorted(i for i in ids if ids.count(i) > 1)[0]!r} appears twice")


def _platform(lines: list[ImportedLine], plan: ProjectPlan) -> None:
    """A platform's lines: each on a flight line of the plan, one sensor per id, unique strip ids."""
    flight_lines = [f for f, _ in plan.flight_lines]
    if len(set(flight_lines)) != len(flight_lines):
        twice = sorted(f for f in flight_lines if flight_lines.count(f) > 1)[0]
        raise ArgumentError(f"plan.flight_lines: the id {twice!r} appears twice")
    sensors: dict[str, ImportedSensor] = {}
    for line in lines:
        if line.flight_line not in flight_lines:
            raise ArgumentError(f"line {line.strip}: flight line {line.flight_line!r} is not one of the plan's "
                                f"({', '.join(flight_lines)})")
        if not line.sensor.id:
            raise ArgumentError(f"line {line.strip}: a platform's sensor needs an id")
        first = sensors.setdefault(line.sensor.id, line.sensor)
        if first is not line.sensor and first != line.sensor:
            raise ArgumentError(f"line {line.strip}: sensor {line.sensor.id!r} differs from the one of an earlier line "
                                "of that id")
    ids = [line.strip for line in lines]
    if len(set(ids)) != len(ids):
        raise ArgumentError(f"lines: the strip id {sorted(i for i in ids if ids.count(i) > 1)[0]!r} appears twice")
    for prior in plan.relative_mountings:
        for name in (prior.sensor, prior.reference):
            if name not in sensors:
                raise ArgumentError(f"relative mounting {prior.sensor}:{prior.reference}: unknown sensor {name!r} "
                                    f"(sensors: {', '.join(sensors)})")


def platform_sensors(lines: Sequence[ImportedLine]) -> dict[str, ImportedSensor]:
    """The sensors of a platform's lines by id, in the order the lines name them."""
    sensors: dict[str, ImportedSensor] = {}
    for line in lines:
        sensors.setdefault(line.sensor.id, line.sensor)
    return sensors


def _look_angles_csv(path: Path, sensor: ImportedSensor) -> None:
    write_csv(path, ["pixel", "along_deg", "across_deg"],
              ([j, f"{np.degrees(a):.10f}", f"{np.degrees(c):.10f}"]
               for j, (a, c) in enumerate(zip(sensor.along, sensor.across))))


def _write_files(tmp: Path, lines: list[ImportedLine], plan: ProjectPlan, dtm: bool = True) -> None:
    (tmp / "nav").mkdir(exist_ok=True)
    (tmp / "sensor").mkdir(exist_ok=True)
    if plan.flight_lines:
        for sensor_id, sensor in platform_sensors(lines).items():
            _look_angles_csv(tmp / "sensor" / f"{sensor_id}.csv", sensor)
        for flight_line, stream in plan.flight_lines:
            write_trajectory_csv(tmp / "nav" / f"{flight_line}.csv", stream)
    else:
        _look_angles_csv(tmp / "sensor" / "look_angles.csv", lines[0].sensor)
    for line in lines:
        if _cut(line):
            (tmp / "images").mkdir(exist_ok=True)
            write_text(tmp / "images" / f"{line.strip}.vrt", first_lines_vrt(line))
        if not plan.flight_lines:
            write_trajectory_csv(tmp / "nav" / f"{line.strip}.csv", line.stream)
        if line.line_times is not None:
            write_csv(tmp / "nav" / f"{line.strip}_lines.csv", ["line", "time"],
                      ([k, f"{t:.6f}"] for k, t in enumerate(line.line_times)))
    _write_control(tmp, lines)
    if dtm:
        _write_dtm(tmp, lines, plan)
    write_text(tmp / "project.toml", project_toml(lines, plan))
    if plan.variants is not None:
        write_text(tmp / "variants.toml", plan.variants)
    for name, text in plan.extra_files.items():
        write_text(tmp / name, text)


def _write_control(tmp: Path, lines: list[ImportedLine]) -> None:
    with_control = [line.control for line in lines if line.control is not None]
    if not with_control:
        return
    ground = with_control[0].ground
    others = [c.ground for c in with_control[1:] if c.ground is not ground]
    if others:  # several lines' own GCPs (a platform's cameras): one list, each point once
        ground = _merged_ground([ground, *others])
    points = [c.points for c in with_control]
    ground.write(tmp / "ground.csv")
    ImagePoints(np.concatenate([p.point for p in points]), np.concatenate([p.strip for p in points]),
                np.concatenate([p.line for p in points]), np.concatenate([p.pixel for p in points]),
                np.concatenate([p.sigma_px for p in points]),
                np.arange(sum(len(p.point) for p in points))).write(tmp / "points.csv")


def _merged_ground(grounds: list[GroundPoints]) -> GroundPoints:
    """Several ground lists as one; a point id in two lists must have the same coordinates and role."""
    seen: dict[str, tuple[int, int]] = {}
    keep: list[tuple[int, int]] = []
    for g_index, g in enumerate(grounds):
        for k, point in enumerate(g.point):
            if point in seen:
                a, b = seen[point]
                first = grounds[a]
                if not (np.allclose(first.xyz[b], g.xyz[k]) and first.role[b] == g.role[k]):
                    raise ArgumentError(f"ground point {point!r}: two lines give it other coordinates or roles")
                continue
            seen[point] = (g_index, k)
            keep.append((g_index, k))

    def column(name: str) -> np.ndarray:
        return np.array([getattr(grounds[g], name)[k] for g, k in keep], dtype=getattr(grounds[0], name).dtype)

    return GroundPoints(column("point"), np.array([grounds[g].xyz[k] for g, k in keep]).reshape(-1, 3),
                        column("sigma_xy"), column("sigma_z"), column("role"), np.arange(len(keep)))


def dtm_name(choice: DtmChoice) -> str:
    """What project.toml's ``dtm`` says for a choice."""
    return {"given": str(choice.path), "plane": "dtm_plane.tif", "gcps": "dtm_from_gcps.tif",
            "none": MISSING_DTM}[choice.kind]


def _write_dtm(tmp: Path, lines: list[ImportedLine], plan: ProjectPlan) -> None:
    choice = plan.dtm
    if choice.kind == "plane":
        write_plane_dtm(tmp / dtm_name(choice), choice.height_m, plan.box, plan.crs_wkt, choice.why)
    elif choice.kind == "gcps":
        xyz = np.concatenate([line.control.ground.xyz for line in lines if line.control is not None])
        write_gcp_dtm(tmp / dtm_name(choice), xyz, plan.box, plan.crs_wkt)


def project_toml(lines: list[ImportedLine], plan: ProjectPlan) -> str:
    """The text of project.toml of the imported lines (a platform's when the plan has flight lines)."""
    geoid = (f"geoid_undulation_m = {plan.geoid:.4f}" if isinstance(plan.geoid, float)
             else f"geoid = {json.dumps(str(plan.geoid))}")
    dtm_comment = ("   # NOT WRITTEN: this line needs a DTM (give the import a DTM, or put one here)"
                   if plan.dtm.kind == "none" else f"   # {plan.dtm.why}" if plan.dtm.why else "")
    text = [f"# Imported by scangeo import {plan.tool}{': ' + plan.comment if plan.comment else ''}; "
            "decisions in import.json",
            "[project]",
            f"crs = {json.dumps(plan.crs)}",
            f"dtm = {json.dumps(dtm_name(plan.dtm))}{dtm_comment}",
            geoid,
            f"origin = [{plan.origin[0]:.9f}, {plan.origin[1]:.9f}, {plan.origin[2]:.3f}]",
            f"knot_spacing_s = {plan.knot_spacing_s!r}"]
    if plan.flight_lines:
        for sensor in platform_sensors(lines).values():
            text += ["", "[[sensors]]", f"id = {json.dumps(sensor.id)}",
                     *_sensor_keys(sensor, f"sensor/{sensor.id}.csv")]
        for prior in plan.relative_mountings:
            text += ["", "[[relative_mountings]]", f"sensor = {json.dumps(prior.sensor)}",
                     f"reference = {json.dumps(prior.reference)}"]
            for key in ("boresight_deg", "boresight_sigma_deg", "lever_arm_m", "lever_arm_sigma_m"):
                value = getattr(prior, key)
                if value is not None:
                    text.append(f"{key} = [{', '.join(f'{v:.9g}' for v in value)}]")
        for flight_line, _ in plan.flight_lines:
            text += ["", "[[flight_lines]]", f"id = {json.dumps(flight_line)}",
                     f'trajectory = "nav/{flight_line}.csv"']
    else:
        text += ["", "[sensor]", *_sensor_keys(lines[0].sensor, "sensor/look_angles.csv")]
    for line in lines:
        text += ["", "[[strips]]", f"id = {json.dumps(line.strip)}"]
        if plan.flight_lines:
            text += [f"sensor = {json.dumps(line.sensor.id)}", f"flight_line = {json.dumps(line.flight_line)}"]
        else:
            text.append(f'trajectory = "nav/{line.strip}.csv"')
        if line.line_times is not None:
            text.append(f'line_times = "nav/{line.strip}_lines.csv"')
        else:
            text.append(f"first_line_time = {line.first_line_time!r}")
        if line.image is not None and _cut(line):
            text.append(f'image = "images/{line.strip}.vrt"   # the first {line.lines} lines of {line.image}')
        elif line.image is not None:
            text.append(f"image = {json.dumps(str(line.image))}")
        text.append(f"lines = {line.lines}")
    return "\n".join(text) + "\n"


def _sensor_keys(sensor: ImportedSensor, look_angles: str) -> list[str]:
    """A pushbroom's keys of ``[sensor]`` or of a ``[[sensors]]`` entry (after its id)."""
    text = ['kind = "pushbroom"',
            f"pixels = {sensor.pixels}",
            f"line_rate_hz = {sensor.line_rate_hz!r}",
            f'look_angles = "{look_angles}"   # {sensor.source}' if sensor.source else f'look_angles = "{look_angles}"',
            f'measurement_time = "{sensor.measurement_time}"',
            f"boresight_deg = [{', '.join(f'{v:.6f}' for v in sensor.boresight_deg)}]",
            f"lever_arm_m = [{', '.join(f'{v:.4f}' for v in sensor.lever_arm_m)}]"]
    if sensor.bands:
        text.append(f"bands = [{', '.join(json.dumps(b) for b in sensor.bands)}]")
    if sensor.wavelengths_nm:
        text.append(f"wavelengths_nm = [{', '.join(f'{w:g}' for w in sensor.wavelengths_nm)}]")
    return text


def _cut(line: ImportedLine) -> bool:
    return line.image is not None and line.image_shape is not None and line.image_shape[0] > line.lines


#: numpy data types -> GDAL's names
_GDAL_TYPES = {"u1": "Byte", "i2": "Int16", "u2": "UInt16", "i4": "Int32", "u4": "UInt32", "i8": "Int64",
               "u8": "UInt64", "f4": "Float32", "f8": "Float64"}


def first_lines_vrt(line: ImportedLine) -> str:
    """A GDAL VRT of the first ``line.lines`` lines of the line's cube (every band, the same pixels)."""
    from xml.sax.saxutils import escape

    assert line.image is not None and line.image_shape is not None
    _, samples, bands, dtype = line.image_shape
    gdal_type = _GDAL_TYPES[np.dtype(dtype).str[1:]]
    rect = f'xOff="0" yOff="0" xSize="{samples}" ySize="{line.lines}"'
    names = line.sensor.bands if len(line.sensor.bands) == bands else ()
    out = [f'<VRTDataset rasterXSize="{samples}" rasterYSize="{line.lines}">']
    for b in range(1, bands + 1):
        out.append(f'  <VRTRasterBand dataType="{gdal_type}" band="{b}">')
        if names:
            out.append(f"    <Description>{escape(names[b - 1])}</Description>")
        out += ["    <SimpleSource>",
                f'      <SourceFilename relativeToVRT="0">{escape(str(line.image))}</SourceFilename>',
                f"      <SourceBand>{b}</SourceBand>", f"      <SrcRect {rect}/>", f"      <DstRect {rect}/>",
                "    </SimpleSource>", "  </VRTRasterBand>"]
    out.append("</VRTDataset>")
    return "\n".join(out) + "\n"


def with_boresight(lines: list[ImportedLine], boresight_deg: tuple[float, float, float]) -> list[ImportedLine]:
    """The lines with their sensor's boresight replaced."""
    return [replace(line, sensor=replace(line.sensor, boresight_deg=boresight_deg)) for line in lines]


__all__ = ["Control", "DtmChoice", "ImportedLine", "ImportedSensor", "MISSING_DTM", "ProjectPlan", "check_out",
           "dtm_name", "given_dtm", "platform_sensors", "project_toml", "with_boresight", "write_project"]
