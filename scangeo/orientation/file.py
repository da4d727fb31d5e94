"""The orientation of a variant as a file: ``PROJECT/results/NAME/orientation.json``.

Everything the strip geometry of a variant is built from, in SI units and radians (schema
``scangeo.orientation/1``, docs/formats.md): per strip the orientation spline (t0, spacing,
coefficients), line timing and number of lines; the sensor model with its calibration (scan index
and scale), the mounting (lever arm, boresight, time offset); the GPS/IMU models with their
correction functions, coefficients and breaks; the project frame, map CRS and geoid. ``scangeo
adjust`` writes it for every variant; other tools can read or write it.

:class:`Orientation` holds one such document and :meth:`Orientation.geometry` is the one place
where an adjusted strip geometry is built: the adjustment's own check points, rectification,
locate, matching, the reports and the true-error table all go through it (an adjustment result
makes its :class:`Orientation` with ``VariantResult.orientation``; a results folder gives it with
:func:`load_orientation`).
"""
from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from scangeo.atomic import write_text
from scangeo.errors import OrientationFileError, ScangeoError
from scangeo.frames import ProjectFrame
from scangeo.io.project import Project
from scangeo.orientation.models import GpsImuModel, ModelSet
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.sensors.strip import Mounting, StripGeometry
from scangeo.timing import LineTiming
from scangeo.trajectory.spline import COMPONENTS, OrientationSpline

#: the schema this version writes and reads
SCHEMA = "scangeo.orientation/1"
FILE_NAME = "orientation.json"
#: the variant name of direct georeferencing (the GPS/IMU as measured; needs no results folder)
DIRECT = "DG"

SensorModel = Whiskbroom | Pushbroom
T = TypeVar("T")


@dataclass(frozen=True)
class StripOrientation:
    """One strip: its orientation spline (navigation reference point, project frame), line timing
    and number of image lines."""

    id: str
    lines: int
    timing: LineTiming
    spline: OrientationSpline


@dataclass(frozen=True)
class MapReference:
    """The project frame P (east-north-up at a geodetic origin on WGS84), the map CRS (WKT) and
    the geoid that relates the map's orthometric heights to ellipsoidal ones."""

    frame: ProjectFrame
    crs: str
    geoid_undulation_m: float | None = None
    geoid_file: str | None = None


@dataclass(frozen=True)
class Orientation:
    """The orientation of a variant: what ``orientation.json`` holds (see the module doc).

    ``coefficients`` maps a GPS/IMU model id to its coefficients (in the order of
    ``GpsImuModel.names()``; metres and radians); ``calibrated`` names the calibration values
    the adjustment estimated (the others are the project's). ``path`` is the file it was read
    from (None when built in memory).
    """

    variant: str
    adjusted: bool
    sensor: SensorModel
    mounting: Mounting
    strips: Mapping[str, StripOrientation]
    reference: MapReference
    models: tuple[GpsImuModel, ...] = ()
    coefficients: dict[str, np.ndarray] = field(default_factory=dict)
    calibrated: tuple[str, ...] = ()
    sigma0: float | None = None
    path: Path | None = None

    def strip(self, strip_id: str) -> StripOrientation:
        try:
            return self.strips[strip_id]
        except KeyError:
            where = self.path or f"the orientation of {self.variant}"
            raise OrientationFileError(
                f"{where}: no strip {strip_id!r} (strips: {', '.join(self.strips)})") from None

    def geometry(self, strip_id: str) -> StripGeometry:
        """The strip's geometry: spline, timing, lines, sensor with its calibration, mounting."""
        s = self.strip(strip_id)
        return StripGeometry(self.sensor, s.spline, s.timing, s.lines, self.mounting, strip_id)

    def breaks(self, strip_id: str) -> list[float]:
        """Break epochs (s) of the strip's split GPS/IMU models: where a sub-model follows another."""
        return sorted(m.t_start for m in self.models if m.follows is not None and strip_id in m.strips)

    def correction(self, strip_id: str, t: np.ndarray, p_gps: np.ndarray) -> np.ndarray:
        """The correction function c(t) (n, 6: m, rad) of the strip's GPS/IMU models at times t
        (``p_gps`` the GPS positions there, for models with a rigid rotation); the orientation is
        the GPS/IMU plus it."""
        coefficients = {m.key: self.coefficients[m.id] for m in self.models}
        return ModelSet(list(self.models)).correction(strip_id, t, p_gps, coefficients)


def strip_geometries(doc: Orientation) -> dict[str, StripGeometry]:
    """The geometry of every strip of an orientation."""
    return {sid: doc.geometry(sid) for sid in doc.strips}


# --- building it ----------------------------------------------------------------------------------
def map_reference(project: Project) -> MapReference:
    mf = project.map_frame
    return MapReference(mf.frame, mf.crs.to_wkt(), None if project.geoid.path else project.geoid.constant,
                        project.geoid.path)


class _DirectStrips(Mapping[str, StripOrientation]):
    """The strips of direct georeferencing, each fitted to its GPS/IMU when first asked for (a
    worker rectifying one strip reads one trajectory)."""

    def __init__(self, project: Project) -> None:
        self.project = project
        self.ids = [s.id for s in project.strips]
        self.cache: dict[str, StripOrientation] = {}

    def __getitem__(self, strip_id: str) -> StripOrientation:
        if strip_id not in self.ids:
            raise KeyError(strip_id)
        if strip_id not in self.cache:
            g = self.project.geometry(strip_id)
            self.cache[strip_id] = StripOrientation(strip_id, g.n_lines, g.timing, g.spline)
        return self.cache[strip_id]

    def __iter__(self) -> Iterator[str]:
        return iter(self.ids)

    def __len__(self) -> int:
        return len(self.ids)


def direct_orientation(project: Project) -> Orientation:
    """Direct georeferencing: per strip the spline fitted to the GPS/IMU as measured (when first
    used), the project's sensor and mounting."""
    return Orientation(DIRECT, False, project.sensor.model, project.sensor.mounting, _DirectStrips(project),
                       map_reference(project))


def results_folder(project: Project, variant: str) -> Path:
    return project.root / "results" / variant


def load_orientation(project: Project, variant: str | os.PathLike[str]) -> Orientation:
    """The orientation of ``variant``: ``results/NAME/orientation.json`` when it exists, direct
    georeferencing for ``DG`` without one; any other variant without one is an error.

    ``variant`` may also be an explicit path (a :class:`~pathlib.Path`, or a string naming a ``.json``
    file or holding a path separator): an orientation file, or a folder that holds
    ``orientation.json``. It must have been written for the project's frame.
    """
    if isinstance(variant, os.PathLike) or variant.endswith(".json") or "/" in variant or os.sep in variant:
        path = Path(variant)
        path = path / FILE_NAME if path.is_dir() else path
        if not path.is_file():
            raise OrientationFileError(f"{path}: no orientation file there")
        doc = read_orientation(path)
        _check_frame(doc, project)
        return doc
    path = results_folder(project, variant) / FILE_NAME
    if path.exists():
        doc = read_orientation(path)
        _check_frame(doc, project)
        return doc
    if variant.upper() == DIRECT:
        return direct_orientation(project)
    folder = path.parent
    older = folder.is_dir() and any(folder.glob("spline_*.json"))
    raise OrientationFileError(
        f"{path}: no orientation for variant {variant!r} "
        + ("(the folder was written by an older scangeo: run 'scangeo adjust' again)" if older else
           f"(run 'scangeo adjust {project.root} --variant {variant}' first, or use --variant {DIRECT})")
    )


def _check_frame(doc: Orientation, project: Project) -> None:
    """The splines are in the project frame the file names: it must be the project's."""
    f, g = doc.reference.frame, project.map_frame.frame
    if abs(f.lat0 - g.lat0) > 1e-12 or abs(f.lon0 - g.lon0) > 1e-12 or abs(f.h0 - g.h0) > 1e-6:
        raise OrientationFileError(
            f"{doc.path} [frame.project_frame]: written for the project frame at {f.to_dict()}, the project's is "
            f"at {g.to_dict()} (its origin or DTM changed since the adjustment: run 'scangeo adjust' again)")


def load_adjusted_geometry(project: Project, variant: str | os.PathLike[str], strip_id: str) -> StripGeometry:
    """The geometry of a strip with the orientation of ``variant`` (see :func:`load_orientation`)."""
    return load_orientation(project, variant).geometry(strip_id)


# --- the file -------------------------------------------------------------------------------------
def _num(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def _sensor_dict(sensor: SensorModel) -> dict[str, Any]:
    if isinstance(sensor, Whiskbroom):
        return {"kind": "whiskbroom", "pixels": sensor.pixels, "fov": sensor.fov, "line_rate": sensor.line_rate,
                "scan_direction": sensor.scan_direction, "per_pixel_timing": sensor.per_pixel_timing,
                "index_error": sensor.index_error, "scale_error": sensor.scale_error}
    if sensor.is_pinhole:
        return {"kind": "pushbroom_pinhole", "pixels": sensor.pixels, "focal_length": sensor.focal_length,
                "pitch": sensor.pitch, "principal_point": sensor.principal_point, "k1": sensor.k1, "k2": sensor.k2,
                "line_offset": sensor.line_offset}
    return {"kind": "pushbroom_table", "pixels": sensor.pixels, "along": np.asarray(sensor.along, float).tolist(),
            "across": np.asarray(sensor.across, float).tolist()}


def _timing_dict(timing: LineTiming) -> dict[str, Any]:
    if timing.table is not None:
        return {"line_times": np.asarray(timing.table, float).tolist()}
    return {"first_line_time": timing.first_line_time, "line_rate": timing.line_rate}


def _model_dict(m: GpsImuModel, coefficients: np.ndarray) -> dict[str, Any]:
    return {
        "id": m.id, "strips": list(m.strips), "t_start": m.t_start, "t_end": m.t_end,
        "position_degree": m.position_degree, "attitude_degree": m.attitude_degree, "rotation": m.rotation,
        "centre": np.asarray(m.centre, float).tolist(), "follows": m.follows,
        "windows": {s: [_num(lo), _num(hi)] for s, (lo, hi) in m.windows.items()},
        "names": m.names(), "coefficients": np.asarray(coefficients, float).tolist(),
    }


def orientation_dict(doc: Orientation) -> dict[str, Any]:
    """The JSON document of an orientation (schema :data:`SCHEMA`)."""
    ref = doc.reference
    geoid = {"raster": ref.geoid_file} if ref.geoid_file else {"undulation_m": ref.geoid_undulation_m or 0.0}
    return {
        "schema": SCHEMA,
        "variant": doc.variant,
        "adjusted": doc.adjusted,
        "sigma0": _num(doc.sigma0),
        "units": {"length": "m", "angle": "rad", "time": "s"},
        "frame": {"project_frame": {"lat0": ref.frame.lat0, "lon0": ref.frame.lon0, "h0": ref.frame.h0},
                  "map_crs": ref.crs, "geoid": geoid},
        "sensor": _sensor_dict(doc.sensor),
        "mounting": {"lever_arm": np.asarray(doc.mounting.lever_arm_B, float).tolist(),
                     "boresight": np.asarray(doc.mounting.boresight, float).tolist(),
                     "time_offset": float(doc.mounting.time_offset)},
        "calibrated": list(doc.calibrated),
        "strips": [
            {"id": s.id, "lines": s.lines, "timing": _timing_dict(s.timing),
             "spline": {"t0": s.spline.t0, "spacing": s.spline.spacing, "components": list(COMPONENTS),
                        "coefficients": s.spline.coef.tolist()}}
            for s in doc.strips.values()
        ],
        "gpsimu_models": [_model_dict(m, doc.coefficients.get(m.id, np.zeros(m.size))) for m in doc.models],
        "breaks": {sid: doc.breaks(sid) for sid in doc.strips if doc.breaks(sid)},
    }


def write_orientation(doc: Orientation, path: str | Path) -> Path:
    """Write ``doc`` to ``path`` (a temporary name, then renamed); returns the path."""
    path = Path(path)
    write_text(path, json.dumps(orientation_dict(doc), indent=1))
    return path


def read_orientation(path: str | Path) -> Orientation:
    """Read an ``orientation.json``; errors name the file and the key."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError as exc:
        raise OrientationFileError(f"{path}: no such file") from exc
    except OSError as exc:
        raise OrientationFileError(f"{path}: cannot read ({exc})") from exc
    except json.JSONDecodeError as exc:
        raise OrientationFileError(f"{path} line {exc.lineno}: not JSON ({exc.msg})") from exc
    return orientation_from_dict(data, path)


class _Reader:
    """Typed access to the keys of a JSON document, errors naming the file and the key path."""

    def __init__(self, path: Path | str) -> None:
        self.path = path

    def fail(self, key: str, text: str) -> OrientationFileError:
        return OrientationFileError(f"{self.path} [{key}]: {text}")

    def get(self, node: Any, key: str, where: str, kind: type | tuple[type, ...], default: Any = ...) -> Any:
        name = f"{where}.{key}" if where else key
        if not isinstance(node, dict):
            raise self.fail(where or "(top)", "expected an object")
        if key not in node:
            if default is not ...:
                return default
            raise self.fail(name, "missing")
        value = node[key]
        if kind in (float, (float, type(None))) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or (isinstance(value, bool) and kind is not bool):
            expected = kind.__name__ if isinstance(kind, type) else " or ".join(k.__name__ for k in kind)
            raise self.fail(name, f"expected {expected}, got {type(value).__name__} {value!r:.40}")
        return value

    def array(self, node: Any, key: str, where: str, shape: tuple[int | None, ...]) -> np.ndarray:
        value = self.get(node, key, where, list)
        name = f"{where}.{key}" if where else key
        try:
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError) as exc:
            raise self.fail(name, f"expected numbers ({exc})") from exc
        if a.ndim != len(shape) or any(n is not None and n != m for n, m in zip(shape, a.shape)):
            want = " x ".join("n" if n is None else str(n) for n in shape)
            raise self.fail(name, f"expected an array of shape {want}, got {a.shape}")
        if not np.isfinite(a).all():
            raise self.fail(name, "values must be finite numbers")
        return a


def _read_sensor(r: _Reader, node: Any, where: str = "sensor") -> SensorModel:
    kind = r.get(node, "kind", "sensor", str)
    n = r.get(node, "pixels", "sensor", int)
    if kind == "whiskbroom":
        values = {k: r.get(node, k, "sensor", float) for k in ("fov", "line_rate", "index_error", "scale_error")}
        return Whiskbroom(n, scan_direction=r.get(node, "scan_direction", "sensor", int),
                          per_pixel_timing=r.get(node, "per_pixel_timing", "sensor", bool), **values)
    if kind == "pushbroom_pinhole":
        values = {k: r.get(node, k, "sensor", float)
                  for k in ("focal_length", "pitch", "principal_point", "k1", "k2", "line_offset")}
        return Pushbroom(n, **values)
    if kind == "pushbroom_table":
        along, across = (r.array(node, k, "sensor", (n,)) for k in ("along", "across"))
        return Pushbroom(n, along=along, across=across)
    raise r.fail("sensor.kind", f"unknown sensor kind {kind!r} (expected whiskbroom, pushbroom_pinhole or "
                                "pushbroom_table)")


def _read_strip(r: _Reader, node: Any, where: str) -> StripOrientation:
    sid = r.get(node, "id", where, str)
    timing_node = r.get(node, "timing", where, dict)
    if "line_times" in timing_node:
        table = r.array(timing_node, "line_times", f"{where}.timing", (None,))
        timing = LineTiming(float(table[0]), 1.0 / float(np.median(np.diff(table))), table)
    else:
        timing = LineTiming(r.get(timing_node, "first_line_time", f"{where}.timing", float),
                            r.get(timing_node, "line_rate", f"{where}.timing", float))
    sp = r.get(node, "spline", where, dict)
    at = f"{where}.spline"
    spline = OrientationSpline(r.get(sp, "t0", at, float), r.get(sp, "spacing", at, float),
                               r.array(sp, "coefficients", at, (None, 6)))
    return StripOrientation(sid, r.get(node, "lines", where, int), timing, spline)


def _read_model(r: _Reader, node: Any, where: str) -> tuple[GpsImuModel, np.ndarray]:
    windows = {}
    for sid, span in r.get(node, "windows", where, dict).items():
        if not (isinstance(span, list) and len(span) == 2
                and all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in span)):
            raise r.fail(f"{where}.windows.{sid}", f"expected [start, end] (numbers; null: unbounded), got {span!r}")
        windows[sid] = (-np.inf if span[0] is None else float(span[0]), np.inf if span[1] is None else float(span[1]))
    strips = r.get(node, "strips", where, list)
    if not all(isinstance(sid, str) for sid in strips):
        raise r.fail(f"{where}.strips", "expected strip ids (strings)")
    model = GpsImuModel(
        r.get(node, "id", where, str), tuple(strips), r.get(node, "t_start", where, float),
        r.get(node, "t_end", where, float), r.get(node, "position_degree", where, int),
        r.get(node, "attitude_degree", where, int), r.get(node, "rotation", where, bool),
        r.array(node, "centre", where, (3,)), r.get(node, "follows", where, (str, type(None))), windows)
    return model, r.array(node, "coefficients", where, (model.size,))


def _checked(r: _Reader, where: str, read: Callable[[_Reader, Any, str], T], node: Any) -> T:
    """``read(r, node, where)``, a value the models refuse named by ``where``."""
    try:
        return read(r, node, where)
    except OrientationFileError:
        raise
    except ScangeoError as exc:
        raise r.fail(where, str(exc)) from exc


def orientation_from_dict(data: Any, path: Path | str | None = None) -> Orientation:
    """An :class:`Orientation` from its JSON document; errors name ``path`` and the key."""
    r = _Reader(path or "orientation document")
    schema = r.get(data, "schema", "", str)
    if schema != SCHEMA:
        raise r.fail("schema", f"schema {schema!r} is not the one this scangeo reads ({SCHEMA!r})")
    try:
        frame_node = r.get(data, "frame", "", dict)
        pf = r.get(frame_node, "project_frame", "frame", dict)
        geoid = r.get(frame_node, "geoid", "frame", dict)
        reference = MapReference(
            ProjectFrame(*(r.get(pf, k, "frame.project_frame", float) for k in ("lat0", "lon0", "h0"))),
            r.get(frame_node, "map_crs", "frame", str),
            r.get(geoid, "undulation_m", "frame.geoid", float, None), r.get(geoid, "raster", "frame.geoid", str, None))
        mount = r.get(data, "mounting", "", dict)
        mounting = Mounting(r.array(mount, "lever_arm", "mounting", (3,)),
                            r.array(mount, "boresight", "mounting", (3,)),
                            r.get(mount, "time_offset", "mounting", float))
        strips = {}
        for k, node in enumerate(r.get(data, "strips", "", list)):
            s = _checked(r, f"strips[{k}]", _read_strip, node)
            strips[s.id] = s
        models, coefficients = [], {}
        for k, node in enumerate(r.get(data, "gpsimu_models", "", list)):
            m, c = _checked(r, f"gpsimu_models[{k}]", _read_model, node)
            models.append(m)
            coefficients[m.id] = c
        return Orientation(
            r.get(data, "variant", "", str), r.get(data, "adjusted", "", bool),
            _checked(r, "sensor", _read_sensor, r.get(data, "sensor", "", dict)),
            mounting, strips, reference, tuple(models), coefficients,
            tuple(r.get(data, "calibrated", "", list)), r.get(data, "sigma0", "", (float, type(None))),
            Path(path) if path is not None else None)
    except OrientationFileError:
        raise
    except ScangeoError as exc:  # a value the models refuse (degrees, spans, sensor parameters)
        raise OrientationFileError(f"{r.path}: {exc}") from exc


__all__ = ["SCHEMA", "FILE_NAME", "DIRECT", "Orientation", "StripOrientation", "MapReference", "strip_geometries",
           "direct_orientation", "load_orientation", "load_adjusted_geometry", "read_orientation",
           "write_orientation", "orientation_dict", "orientation_from_dict", "map_reference", "results_folder"]
