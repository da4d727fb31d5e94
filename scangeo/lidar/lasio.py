"""LAS/LAZ strips: streamed reading of coordinates and GPS time, and corrected copies.

Reading goes chunk by chunk (``laspy.open(...).chunk_iterator``) and keeps only x, y, z and GPS
time (float64) of the strip's returns (``point_source_id`` selects one flight line of a file that
holds several). A file without GPS time, or whose CRS differs from the project's, is an error naming
the file. The header is checked against the file before laspy reads it (``las_header``: counts,
offsets and lengths within the file), so a corrupted header is an error naming the field, not a
long loop or a huge allocation. Corrected copies keep the point format, header, CRS and extra
dimensions; only the coordinates change; they are written through ``scangeo.atomic`` (a temporary
name renamed when complete), so an interrupted run leaves no file under a final name.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyproj

from scangeo.atomic import atomic_path
from scangeo.errors import InputFileError
from scangeo.lidar.las_header import check_las_file

log = logging.getLogger(__name__)

CHUNK = 1_000_000


@dataclass
class StripCloud:
    """The returns of one strip: map coordinates (n, 3) and GPS times (n,)."""

    id: str
    xyz: np.ndarray
    time: np.ndarray

    @property
    def size(self) -> int:
        return int(self.time.size)


def _open(path: Path):
    """laspy's reader of a file whose header was checked against the file first (las_header)."""
    import laspy  # start-up cost: laspy and its LAZ backend load when a LAS file is read

    check_las_file(path)
    try:
        return laspy.open(str(path))
    except laspy_errors() as exc:
        raise InputFileError(f"{path}: cannot read as LAS/LAZ ({exc})") from exc


def laspy_errors() -> tuple[type[Exception], ...]:
    """What laspy and its LAZ back-end raise for a file they cannot read (both imported lazily)."""
    import laspy  # start-up cost: laspy and its LAZ backend load when a LAS file is read

    errors: tuple[type[Exception], ...] = (OSError, ValueError, EOFError, laspy.errors.LaspyException)
    try:
        import lazrs  # optional LAZ backend
    except ImportError:
        return errors
    return (*errors, lazrs.LazrsError)


def bounds(path: Path) -> tuple[float, float, float, float]:
    with _open(path) as f:
        h = f.header
        return float(h.mins[0]), float(h.mins[1]), float(h.maxs[0]), float(h.maxs[1])


def check_header(path: Path, header, crs) -> None:
    """GPS time present; the CRS, when the file has one, equal to the project's."""
    if "gps_time" not in header.point_format.dimension_names:
        raise InputFileError(
            f"{path}: point format {header.point_format.id} has no GPS time; "
            "the laser adjustment needs the GPS time of every return"
        )
    try:
        file_crs = header.parse_crs()
    except Exception as exc:  # laspy raises several kinds for broken VLRs
        raise InputFileError(f"{path}: cannot parse the CRS in the header ({exc})") from exc
    if file_crs is not None and crs is not None:
        want = pyproj.CRS.from_user_input(crs)
        got = file_crs.sub_crs_list[0] if file_crs.is_compound else file_crs
        if not got.equals(want, ignore_axis_order=True):
            raise InputFileError(
                f"{path}: CRS {got.name} differs from the project's {want.name}; reproject the "
                "strip (e.g. pdal translate with filters.reprojection) or set [project] crs"
            )


def scan_angle(chunk) -> np.ndarray:
    """Scan angles (rad) of a chunk of returns: ``scan_angle`` (0.006 deg steps) of point formats 6-10,
    ``scan_angle_rank`` (whole degrees) of formats 0-5."""
    names = chunk.point_format.dimension_names
    if "scan_angle" in names:
        return np.radians(0.006 * np.asarray(chunk.scan_angle, float))
    return np.radians(np.asarray(chunk.scan_angle_rank, float))


def _records(files, point_source_id: int | None, crs, chunk_size: int):
    """laspy's chunks of a strip's returns (only ``point_source_id``'s when given), file by file."""
    for path in map(Path, files):
        with _open(path) as f:
            check_header(path, f.header, crs)
            try:
                for chunk in f.chunk_iterator(chunk_size):
                    if point_source_id is not None:
                        chunk = chunk[np.asarray(chunk.point_source_id) == point_source_id]
                    if len(chunk):
                        yield chunk
            except laspy_errors() as exc:
                raise InputFileError(f"{path}: cannot read the returns; truncated or corrupted? ({exc})") from exc


def _xyz(chunk) -> np.ndarray:
    return np.column_stack([np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z)])


def iter_returns(files, point_source_id: int | None = None, crs=None, chunk_size: int = CHUNK):
    """Chunks ``(xyz (n, 3), GPS time (n,), scan angle (n,) rad)`` of a strip's returns, file by file.

    Holds one chunk of ``chunk_size`` returns at a time (the row buffer and pass 2 stream through them).
    """
    for chunk in _records(files, point_source_id, crs, chunk_size):
        yield _xyz(chunk), np.asarray(chunk.gps_time, float), scan_angle(chunk)


def read_strip(strip_id: str, files, point_source_id: int | None = None, crs=None) -> StripCloud:
    """Coordinates and GPS times of a strip's returns from one or more LAS/LAZ files, in chunks."""
    xyz, t = [], []
    for part, time, _ in iter_returns(files, point_source_id, crs):
        xyz.append(part)
        t.append(time)
    if not t:
        which = "" if point_source_id is None else f" with point_source_id {point_source_id}"
        raise InputFileError(f"{', '.join(map(str, files))}: no returns{which} for strip {strip_id}")
    return StripCloud(strip_id, np.concatenate(xyz), np.concatenate(t))


def write_corrected(
    files, point_source_id: int | None, out: Path, correct: Callable[[np.ndarray, np.ndarray], np.ndarray]
) -> int:
    """Write the strip's returns to ``out`` with coordinates ``correct(xyz, t)``; returns the count.

    The first input file's header (point format, version, scales, VLRs with the CRS, extra
    dimensions) is kept; bounds and counts are updated by the writer.
    """
    import laspy  # start-up cost: laspy and its LAZ backend load when a LAS file is read

    out = Path(out)
    count = 0
    files = list(map(Path, files))
    with _open(files[0]) as first:
        header = first.header
    with atomic_path(out) as tmp:
        with laspy.open(str(tmp), mode="w", header=header, do_compress=out.suffix.lower() == ".laz") as writer:
            for chunk in _records(files, point_source_id, None, CHUNK):
                new = correct(_xyz(chunk), np.asarray(chunk.gps_time, float))
                chunk.x, chunk.y, chunk.z = new[:, 0], new[:, 1], new[:, 2]
                writer.write_points(chunk)
                count += len(chunk)
    log.info("wrote %s (%d returns)", out, count)
    return count
