"""``orientation.json`` <-> :class:`~scangeo.orientation.document.Orientation`: the JSON document
(schema ``scangeo.orientation/1`` of a one-sensor project, ``scangeo.orientation/2`` of a platform of
several sensors; docs/formats.md) of an orientation and back, with errors that name the file and the key.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from scangeo.errors import OrientationFileError, ScangeoError
from scangeo.frames import ProjectFrame
from scangeo.orientation.document import (
    PLATFORM_SCHEMA,
    SCHEMA,
    MapReference,
    Orientation,
    SensorModel,
    SensorSetup,
    StripOrientation,
)
from scangeo.orientation.models import GpsImuModel
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.sensors.strip import Mounting
from scangeo.timing import LineTiming
from scangeo.trajectory.spline import COMPONENTS, OrientationSpline

T = TypeVar("T")


def _num(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def _sensor_dict(sensor: SensorModel) -> dict[str, Any]:
    if isinstance(sensor, Whiskbroom):
        return {"kind": "whiskbroom", "pixels": sensor.pixels, "fov": sensor.fov, "line_rate": sensor.line_rate,
                "scan_direction": sensor.scan_direction, "per_pixel_timing": sensor.per_pixel_timing,
                "index_error": sensor.index_error, "scale_error": sensor.scale_error}
    calibration = {name: float(getattr(sensor, name)) for name in sensor.calibration_names}
    if sensor.is_pinhole:
        return {"kind": "pushbroom_pinhole", "pixels": sensor.pixels, "focal_length": sensor.focal_length,
                "pitch": sensor.pitch, "principal_point": sensor.principal_point, "k1": sensor.k1, "k2": sensor.k2,
                "line_offset": sensor.line_offset, **calibration}
    return {"kind": "pushbroom_table", "pixels": sensor.pixels, "along": np.asarray(sensor.along, float).tolist(),
            "across": np.asarray(sensor.across, float).tolist(), **calibration}


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


def _mounting_dict(m: Mounting) -> dict[str, Any]:
    return {"lever_arm": np.asarray(m.lever_arm_B, float).tolist(),
            "boresight": np.asarray(m.boresight, float).tolist(), "time_offset": float(m.time_offset)}


def _strip_dict(s: StripOrientation, platform: bool) -> dict[str, Any]:
    out: dict[str, Any] = {"id": s.id}
    if platform:
        out.update(sensor=s.sensor, flight_line=s.flight_line or s.id)
    out.update(lines=s.lines, timing=_timing_dict(s.timing),
               spline={"t0": s.spline.t0, "spacing": s.spline.spacing, "components": list(COMPONENTS),
                       "coefficients": s.spline.coef.tolist()})
    return out


def orientation_dict(doc: Orientation) -> dict[str, Any]:
    """The JSON document of an orientation (schema :data:`SCHEMA`; a platform's :data:`PLATFORM_SCHEMA`)."""
    ref = doc.reference
    geoid = {"raster": ref.geoid_file} if ref.geoid_file else {"undulation_m": ref.geoid_undulation_m or 0.0}
    platform = doc.is_platform
    out: dict[str, Any] = {
        "schema": PLATFORM_SCHEMA if platform else SCHEMA,
        "variant": doc.variant,
        "adjusted": doc.adjusted,
        "sigma0": _num(doc.sigma0),
        "units": {"length": "m", "angle": "rad", "time": "s"},
        "frame": {"project_frame": {"lat0": ref.frame.lat0, "lon0": ref.frame.lon0, "h0": ref.frame.h0},
                  "map_crs": ref.crs, "geoid": geoid},
    }
    if platform:
        out["sensors"] = [{"id": sid, "sensor": _sensor_dict(setup.model), "mounting": _mounting_dict(setup.mounting),
                           "calibrated": list(setup.calibrated)} for sid, setup in doc.sensors.items()]
    else:
        out["sensor"] = _sensor_dict(doc.sensor)
        out["mounting"] = _mounting_dict(doc.mounting)
    out.update({
        "calibrated": list(doc.calibrated),
        "strips": [_strip_dict(s, platform) for s in doc.strips.values()],
        "gpsimu_models": [_model_dict(m, doc.coefficients.get(m.id, np.zeros(m.size))) for m in doc.models],
        "breaks": {sid: doc.breaks(sid) for sid in doc.strips if doc.breaks(sid)},
    })
    return out


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
    kind = r.get(node, "kind", where, str)
    n = r.get(node, "pixels", where, int)
    if kind == "whiskbroom":
        values = {k: r.get(node, k, where, float) for k in ("fov", "line_rate", "index_error", "scale_error")}
        return Whiskbroom(n, scan_direction=r.get(node, "scan_direction", where, int),
                          per_pixel_timing=r.get(node, "per_pixel_timing", where, bool), **values)
    # a pushbroom's calibration (absent from files written before it existed: none)
    calibration = {k: r.get(node, k, where, float, 0.0) for k in ("across_offset", "across_scale", "along_offset")}
    if kind == "pushbroom_pinhole":
        values = {k: r.get(node, k, where, float)
                  for k in ("focal_length", "pitch", "principal_point", "k1", "k2", "line_offset")}
        return Pushbroom(n, **values, **calibration)
    if kind == "pushbroom_table":
        along, across = (r.array(node, k, where, (n,)) for k in ("along", "across"))
        return Pushbroom(n, along=along, across=across, **calibration)
    raise r.fail(f"{where}.kind", f"unknown sensor kind {kind!r} (expected whiskbroom, pushbroom_pinhole or "
                                "pushbroom_table)")


def _read_mounting(r: _Reader, node: Any, where: str) -> Mounting:
    return Mounting(r.array(node, "lever_arm", where, (3,)), r.array(node, "boresight", where, (3,)),
                    r.get(node, "time_offset", where, float))


def _read_strip(r: _Reader, node: Any, where: str) -> StripOrientation:
    sid = r.get(node, "id", where, str)
    sensor = r.get(node, "sensor", where, str, "")
    line = r.get(node, "flight_line", where, str, "")
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
    return StripOrientation(sid, r.get(node, "lines", where, int), timing, spline, sensor,
                            "" if line == sid else line)


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
    if schema not in (SCHEMA, PLATFORM_SCHEMA):
        raise r.fail("schema", f"schema {schema!r} is not one this scangeo reads ({SCHEMA!r}, {PLATFORM_SCHEMA!r})")
    try:
        frame_node = r.get(data, "frame", "", dict)
        pf = r.get(frame_node, "project_frame", "frame", dict)
        geoid = r.get(frame_node, "geoid", "frame", dict)
        reference = MapReference(
            ProjectFrame(*(r.get(pf, k, "frame.project_frame", float) for k in ("lat0", "lon0", "h0"))),
            r.get(frame_node, "map_crs", "frame", str),
            r.get(geoid, "undulation_m", "frame.geoid", float, None), r.get(geoid, "raster", "frame.geoid", str, None))
        calibrated = tuple(r.get(data, "calibrated", "", list))
        if schema == SCHEMA:
            sensors = {"": SensorSetup(_checked(r, "sensor", _read_sensor, r.get(data, "sensor", "", dict)),
                                       _read_mounting(r, r.get(data, "mounting", "", dict), "mounting"), calibrated)}
        else:
            sensors = {}
            for k, node in enumerate(r.get(data, "sensors", "", list)):
                where = f"sensors[{k}]"
                sensors[r.get(node, "id", where, str)] = SensorSetup(
                    _checked(r, f"{where}.sensor", _read_sensor, r.get(node, "sensor", where, dict)),
                    _read_mounting(r, r.get(node, "mounting", where, dict), f"{where}.mounting"),
                    tuple(r.get(node, "calibrated", where, list, [])))
        strips = {}
        for k, node in enumerate(r.get(data, "strips", "", list)):
            s = _checked(r, f"strips[{k}]", _read_strip, node)
            strips[s.id] = s
        models, coefficients = [], {}
        for k, node in enumerate(r.get(data, "gpsimu_models", "", list)):
            m, c = _checked(r, f"gpsimu_models[{k}]", _read_model, node)
            models.append(m)
            coefficients[m.id] = c
        for k, so in enumerate(strips.values()):
            if so.sensor not in sensors:
                raise r.fail(f"strips[{k}].sensor", f"{so.sensor!r} is not one of the sensors ({', '.join(sensors)})")
        return Orientation(
            r.get(data, "variant", "", str), r.get(data, "adjusted", "", bool), sensors, strips, reference,
            tuple(models), coefficients, calibrated, r.get(data, "sigma0", "", (float, type(None))),
            Path(path) if path is not None else None)
    except OrientationFileError:
        raise
    except ScangeoError as exc:  # a value the models refuse (degrees, spans, sensor parameters)
        raise OrientationFileError(f"{r.path}: {exc}") from exc


__all__ = ["orientation_dict", "orientation_from_dict"]
