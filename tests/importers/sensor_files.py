"""The files drone pushbrooms and PARGE users hand to scangeo, written for the tests.

``write_cube``: a raw ENVI cube and its header (Resonon's ``X.bil`` + ``X.bil.hdr``, or ``X.img`` +
``X.hdr`` as PARGE's); ``write_lcf`` / ``write_times``: a navigation log and line times as
lcf_spec.txt describes them, written from a trajectory in scangeo's conventions by the
specification's own words (roll positive right wing up, heading from north, altitude as given,
system times on their own clocks). ``lcf_line_of_project``: a simulated scangeo project's strip in
these formats. Written apart from the importer, so that a convention flipped in one shows.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

GPS_WEEK_S = 604800.0
ENVI_CODES = {"u1": 1, "i2": 2, "i4": 3, "f4": 4, "f8": 5, "u2": 12, "u4": 13}


def write_cube(path, cube: np.ndarray, interleave: str = "bil", header: str | None = None,
               extra: dict[str, str] | None = None) -> Path:
    """A ``(lines, samples, bands)`` array as a raw ENVI cube; the header is ``header`` (default: the data
    file's name + ``.hdr``). Returns the data file."""
    path = Path(path)
    lines, samples, bands = cube.shape
    dtype = cube.dtype.newbyteorder("<")
    text = ["ENVI", f"samples = {samples}", f"lines = {lines}", f"bands = {bands}", "header offset = 0",
            "file type = ENVI Standard", f"data type = {ENVI_CODES[dtype.str[1:]]}", f"interleave = {interleave}",
            "byte order = 0", *(f"{k} = {v}" for k, v in (extra or {}).items())]
    path.with_name(header or path.name + ".hdr").write_text("\n".join(text) + "\n")
    order = {"bil": (0, 2, 1), "bip": (0, 1, 2), "bsq": (2, 0, 1)}[interleave]
    np.ascontiguousarray(np.transpose(cube, order), dtype=dtype).tofile(path)
    return path


def write_lcf(path, time_s, lat_deg, lon_deg, altitude_m, roll_rad, pitch_rad, heading_rad, gps_week: int = 2215,
              columns: int = 11) -> Path:
    """An ``.lcf``: ``time_s`` are GPS seconds of ``gps_week``, written as GPS seconds since the epoch;
    ``roll_rad`` is scangeo's (right wing down), written as lcf_spec's (right wing up)."""
    time = gps_week * GPS_WEEK_S + np.asarray(time_s, float)
    rows = []
    for t, la, lo, a, r, p, h in zip(time, lat_deg, lon_deg, altitude_m, roll_rad, pitch_rad, heading_rad):
        row = [f"{t:.6f}", repr(-float(r)), repr(float(p)), repr(float(np.mod(h, 2 * np.pi))), repr(float(lo)),
               repr(float(la)), repr(float(a)), "0", "0", "5"] + ["7"] * (columns - 10)
        rows.append("\t".join(row))
    Path(path).write_text("\n".join(rows) + "\n")
    return Path(path)


def write_times(path, line_times_s, clock_start_s: float = 876.386137) -> Path:
    """A ``.times``: the line times on the camera computer's clock, which reads ``clock_start_s`` at line 0."""
    t = np.asarray(line_times_s, float)
    Path(path).write_text("".join(f"{v:.6f}\n" for v in t - t[0] + clock_start_s))
    return Path(path)


def lcf_line_of_project(project_root, strip: str, out_folder, clock_start_s: float = 876.386137) -> dict[str, Path]:
    """The strip of a simulated project as a drone line's files: ``X.bil`` (+ ``.bil.hdr``) from its image,
    ``X.lcf`` from its measured trajectory (heights above the ellipsoid), ``X.bil.times`` from its line times.
    Returns the paths (``cube``, ``lcf``, ``times``)."""
    import rasterio

    from scangeo.io.project import Project
    from scangeo.trajectory.readers import read_trajectory_csv

    project = Project.load(project_root)
    out = Path(out_folder)
    out.mkdir(parents=True, exist_ok=True)
    s = read_trajectory_csv(project.strip(strip).trajectory)
    lines = project.n_lines(strip)
    line_times = project.timing(strip).time_of_line(np.arange(lines, dtype=float))
    # the specification: the first record is taken with the first line; the simulation's navigation runs before it
    keep = s.time >= line_times[0] - 1e-9
    t = s.time[keep]
    shift = line_times[0] - t[0]
    if abs(shift) > 1e-6:  # the simulation's records must include the first line's time (run_in_s x rate whole)
        raise ValueError(f"no navigation record at the first line's time (the nearest {shift:.6f} s after it)")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)  # a raw scanner image
        with rasterio.open(project.strip(strip).image) as src:
            image = np.moveaxis(src.read(), 0, -1)
    cube = write_cube(out / f"line{strip}.bil", image)
    lcf = write_lcf(out / f"line{strip}.lcf", t, np.degrees(s.lat[keep]), np.degrees(s.lon[keep]), s.h[keep],
                    s.roll[keep], s.pitch[keep], s.heading[keep])
    times = write_times(out / f"line{strip}.bil.times", line_times, clock_start_s)
    return {"cube": cube, "lcf": lcf, "times": times}


def synthetic_line(folder, *, samples: int = 60, lines: int = 300, bands: int = 2, altitude_m: float = 50.0,
                   heading_rad: float = np.pi / 2, roll_rad: float = 0.0, pitch_rad: float = 0.0,
                   speed_mps: float = 4.0, nav_rate_hz: float = 200.0, line_rate_hz: float = 100.0,
                   lat_deg: float = 67.2156, lon_deg: float = 15.005, start_s: float = 487934.235,
                   clock_start_s: float = 876.386137, extra_s: float = 0.2) -> dict[str, Path]:
    """A level drone line in lcf files: ``line.bil`` (+ ``.bil.hdr``), ``line.lcf``, ``line.bil.times``.

    It flies ``speed_mps`` along ``heading_rad`` (lcf_spec's heading) at ``altitude_m`` with the constant
    lcf attitude ``roll_rad`` (lcf_spec's: positive right wing up) and ``pitch_rad``; the navigation
    starts with the first line and runs ``extra_s`` beyond the last. The cube's band 1 holds each
    cell's line, band 2 its pixel.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    t_lines = np.arange(lines) / line_rate_hz
    t_nav = np.arange(int(np.ceil((t_lines[-1] + extra_s) * nav_rate_hz)) + 1) / nav_rate_hz
    import pyproj

    n = len(t_nav)
    lon, lat, _ = pyproj.Geod(ellps="WGS84").fwd(np.full(n, lon_deg), np.full(n, lat_deg),
                                                  np.full(n, np.degrees(heading_rad)), speed_mps * t_nav)
    write_lcf(folder / "line.lcf", start_s + t_nav, lat, lon, np.full(n, altitude_m), np.full(n, -roll_rad),
              np.full(n, pitch_rad), np.full(n, heading_rad))  # write_lcf takes scangeo's roll
    write_times(folder / "line.bil.times", start_s + t_lines, clock_start_s)
    cube = np.zeros((lines, samples, bands), np.uint16)
    cube[:, :, 0] = np.arange(lines)[:, None]
    if bands > 1:
        cube[:, :, 1] = np.arange(samples)[None, :]
    write_cube(folder / "line.bil", cube)
    return {"cube": folder / "line.bil", "lcf": folder / "line.lcf", "times": folder / "line.bil.times"}
