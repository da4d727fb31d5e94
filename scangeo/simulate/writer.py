"""Writing a simulated block: the project folder (docs/formats.md) and its truth/ folder.

Project: ``project.toml``, ``dtm.tif`` (true terrain + DTM error), ``nav/<id>.csv`` (GPS/IMU as
measured), ``images/<id>.tif`` (or ``.bsq`` + ``.hdr``), ``points.csv``, ``ground.csv``.
Truth: ``truth/trajectory_<id>.csv`` (true navigation trajectory at the GPS/IMU epochs),
``truth/errors_<id>.csv`` (every injected error term over time), ``truth/errors.json`` (drawn
constants, problem strip, breaks, boresight error), ``truth/points.csv`` (true ground coordinates,
kind, land cover), ``truth/measurements.csv`` (true and measured image coordinates, blunder flags),
``truth/terrain.tif``, ``truth/dtm_error.tif``, ``truth/ortho.tif`` (all bands on the output grid),
``truth/scenario.json`` (configuration, seed, flight plan).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from scangeo.atomic import atomic_path, write_csv, write_text
from scangeo.grid import RasterGrid
from scangeo.simulate.gpsimu_errors import StripErrors
from scangeo.simulate.points import ROLE_OF_KIND, PointSet
from scangeo.simulate.scene import BANDS

CSV_FLOAT = "{:.4f}"


def write_raster(path: Path, grid: RasterGrid, dtype: str = "float32", nodata: float | None = -9999.0,
                 description: str = "") -> None:
    """A single-band georeferenced GeoTIFF (tiled, compressed) of a RasterGrid, atomically."""
    import rasterio
    from rasterio.windows import Window

    rows, cols = grid.values.shape
    profile = dict(driver="GTiff", width=cols, height=rows, count=1, dtype=dtype, crs=grid.crs,
                   transform=grid.transform, nodata=nodata, tiled=True, blockxsize=256, blockysize=256,
                   compress="deflate")
    with atomic_path(path) as tmp, rasterio.open(tmp, "w", **profile) as dst:
        # in bands of tile rows: whole-raster copies were 0.25 GB at once for a 96-strip block's terrain
        for r0 in range(0, rows, 256):
            values = grid.values[r0:r0 + 256]
            if nodata is not None:
                values = np.where(np.isfinite(values), values, nodata)
            dst.write(values.astype(dtype), 1, window=Window(0, r0, cols, values.shape[0]))
        if description:
            dst.set_band_description(1, description)


def project_toml(*, crs: str, origin_deg: tuple[float, float, float], geoid_undulation_m: float, dtm_sigma_m: float,
                 sensor, strips: list[dict], sensors: tuple = (), relative_mountings: tuple[dict, ...] = (),
                 flight_lines: tuple[dict, ...] = ()) -> str:
    """The text of project.toml (docs/formats.md): one ``[sensor]``, or a platform's ``[[sensors]]`` (``sensor``
    None) with its ``[[relative_mountings]]`` and ``[[flight_lines]]``."""
    lines = [
        "# written by scangeo simulate: a simulated block (its truth is in truth/)",
        "[project]",
        f"crs = {json.dumps(crs)}",
        'dtm = "dtm.tif"',
        f"geoid_undulation_m = {geoid_undulation_m!r}",
        f"origin = [{origin_deg[0]!r}, {origin_deg[1]!r}, {origin_deg[2]!r}]",
        f"dtm_sigma_m = {dtm_sigma_m!r}",
        "",
    ]
    if sensor is not None:
        lines += ["[sensor]", *_sensor_keys(sensor, "look_angles.csv")]
    for s in sensors:
        lines += ["[[sensors]]", f"id = {json.dumps(s.id)}", *_sensor_keys(s, f"sensors/{s.id}.csv"), ""]
    for r in relative_mountings:
        lines += ["[[relative_mountings]]", *(f"{k} = {_toml(v)}" for k, v in r.items()), ""]
    for f in flight_lines:
        lines += ["[[flight_lines]]", f"id = {json.dumps(f['id'])}", f"trajectory = {json.dumps(f['trajectory'])}", ""]
    if sensors:
        lines.pop()
    for s in strips:
        lines += ["", "[[strips]]", f'id = "{s["id"]}"']
        lines += [f'{k} = "{s[k]}"' for k in ("sensor", "flight_line", "image", "las") if k in s]
        lines += [f'trajectory = "{s["trajectory"]}"'] if "trajectory" in s else []
        lines += [f"first_line_time = {s['first_line_time']!r}", f"lines = {s['lines']}"] if "lines" in s else []
        lines += [f"point_source_id = {s['point_source_id']}"] if "point_source_id" in s else []
    return "\n".join(lines) + "\n"


def _sensor_keys(sensor, look_angles: str) -> list[str]:
    """The keys of a sensor table in project.toml: a line scanner's (with its bands) or a laser's."""
    bore = f"boresight_deg = [{', '.join(repr(float(v)) for v in sensor.boresight_deg)}]"
    lever = f"lever_arm_m = [{', '.join(repr(float(v)) for v in sensor.lever_arm_m)}]"
    if sensor.kind == "laser":
        return ['kind = "laser"', f"fov_deg = {sensor.fov_deg!r}", f"pulse_rate_hz = {sensor.pulse_rate_hz!r}",
                f"scan_rate_hz = {sensor.scan_rate_hz!r}", f"range_sigma_m = {sensor.range_sigma_m!r}", bore, lever]
    chosen = [BANDS[k - 1] for k in getattr(sensor, "bands", ())] or list(BANDS)
    names = ", ".join(f'"{b[0]}"' for b in chosen)
    centres = ", ".join(f"{500.0 * (b[1] + b[2]):g}" for b in chosen)  # nm: (lo + hi) / 2 * 1000
    return [
        f'kind = "{sensor.kind}"',
        f"pixels = {sensor.pixels}",
        *([f"fov_deg = {sensor.fov_deg!r}"] if sensor.kind == "whiskbroom" else [f'look_angles = "{look_angles}"']),
        f"line_rate_hz = {sensor.line_rate_hz!r}",
        *([f"per_pixel_timing = {'true' if sensor.pixel_timing else 'false'}"] if sensor.kind == "whiskbroom" else []),
        bore,
        lever,
        f"bands = [{names}]",
        f"wavelengths_nm = [{centres}]",
    ]


def _toml(value) -> str:
    """A TOML value: a string, a number or a list of numbers."""
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(repr(float(v)) for v in value) + "]"
    return repr(float(value))


def write_look_angles(path: Path, table: np.ndarray) -> None:
    """A pushbroom's look-angle table ``pixel,along_deg,across_deg`` (docs/formats.md)."""
    write_csv(path, ["pixel", "along_deg", "across_deg"],
              [(int(p), f"{a:.9f}", f"{c:.9f}") for p, a, c in table])


def write_points(
    root: Path,
    points: PointSet,
    strip_ids: list[str],
    sigma_px: float,
    given_xyz: np.ndarray,
    sigmas: dict[str, tuple[float, float]],
) -> None:
    """points.csv, ground.csv and truth/points.csv, truth/measurements.csv."""
    rows = [
        (points.id[i], strip_ids[k], f"{ln:.4f}", f"{p:.4f}", f"{sigma_px:g}")
        for i, k, ln, p in zip(points.m_point, points.m_strip, points.line, points.pixel)
    ]
    write_csv(root / "points.csv", ["point", "strip", "line", "pixel", "sigma_px"], rows)
    ground = []
    for i, kind in enumerate(points.kind):
        role = ROLE_OF_KIND[kind]
        if role == "tie":
            continue
        sxy, sz = sigmas[role]
        ground.append((points.id[i], *(CSV_FLOAT.format(v) for v in given_xyz[i]), f"{sxy:g}", f"{sz:g}", role))
    write_csv(root / "ground.csv", ["point", "x", "y", "z", "sigma_xy", "sigma_z", "role"], ground)
    truth = [
        (
            points.id[i],
            points.kind[i],
            ROLE_OF_KIND[points.kind[i]],
            *(CSV_FLOAT.format(v) for v in (points.x[i], points.y[i], points.z[i], *given_xyz[i], *points.p_P[i])),
            int(points.land_class[i]),
        )
        for i in range(len(points.id))
    ]
    write_csv(
        root / "truth" / "points.csv",
        ["point", "kind", "role", "x", "y", "z", "x_given", "y_given", "z_given", "x_P", "y_P", "z_P", "land_class"],
        truth,
    )
    meas = [
        (points.id[i], strip_ids[k], f"{lt:.6f}", f"{pt:.6f}", f"{ln:.4f}", f"{p:.4f}", int(b))
        for i, k, lt, pt, ln, p, b in zip(
            points.m_point,
            points.m_strip,
            points.line_true,
            points.pixel_true,
            points.line,
            points.pixel,
            points.blunder,
        )
    ]
    write_csv(
        root / "truth" / "measurements.csv",
        ["point", "strip", "line_true", "pixel_true", "line", "pixel", "blunder"],
        meas,
    )


def write_errors(path: Path, errors: StripErrors) -> None:
    """truth/errors_<id>.csv: every error term over time (positions m in P; attitude degrees)."""
    header = ["time"]
    columns = [errors.time[:, None]]
    for term, values in errors.position.items():
        header += [f"{term}_{c}_m" for c in "xyz"]
        columns.append(values)
    for term, values in errors.attitude.items():
        header += [f"{term}_{c}_deg" for c in ("roll", "pitch", "heading")]
        columns.append(np.degrees(values))
    header += ["total_x_m", "total_y_m", "total_z_m", "total_roll_deg", "total_pitch_deg", "total_heading_deg"]
    columns += [errors.position_total, np.degrees(errors.attitude_total)]
    data = np.hstack(columns)
    with atomic_path(path) as tmp:
        np.savetxt(tmp, data, delimiter=",", header=",".join(header), comments="",
                   fmt=["%.6f"] + ["%.6g"] * (data.shape[1] - 1))


def write_json(path: Path, data: dict) -> None:
    write_text(path, json.dumps(data, indent=2, default=_jsonable) + "\n")


def _jsonable(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
