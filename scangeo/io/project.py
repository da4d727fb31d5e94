"""The project folder: ``project.toml`` (docs/formats.md) and access to its DTM, strips and points."""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from scangeo.errors import ProjectFileError
from scangeo.frames import Geoid, MapFrame, ProjectFrame, parse_crs
from scangeo.io.toml_config import Table, load_toml
from scangeo.sensors.models import Pushbroom, Whiskbroom
from scangeo.sensors.strip import Mounting, StripGeometry
from scangeo.timing import LineTiming

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SensorConfig:
    """The [sensor] table."""

    kind: str
    model: Whiskbroom | Pushbroom
    mounting: Mounting
    line_rate: float
    bands: tuple[str, ...] = ()
    wavelengths_nm: tuple[float, ...] = ()

    @classmethod
    def from_table(cls, t: Table, root: Path) -> SensorConfig:
        kind = t.choice("kind", ("whiskbroom", "pushbroom"))
        pixels = t.get("pixels", int)
        line_rate = t.get("line_rate_hz", float)
        if kind == "whiskbroom":
            model = Whiskbroom(
                pixels=pixels, fov=np.radians(t.get("fov_deg", float)), line_rate=line_rate,
                scan_direction=t.get("scan_direction", int, 1),
                per_pixel_timing=t.get("per_pixel_timing", bool, True),
                index_error=np.radians(t.get("index_error_deg", float, 0.0)),
                scale_error=t.get("scale_error", float, 0.0),
            )
        else:
            table = t.get("look_angles", str, None)
            if table is not None:
                along, across = read_look_angles(root / table, pixels)
                model = Pushbroom(pixels=pixels, along=along, across=across)
            else:
                model = Pushbroom(
                    pixels=pixels, focal_length=t.get("focal_length_mm", float) / 1000.0,
                    pitch=t.get("pixel_pitch_um", float) / 1e6,
                    principal_point=t.get("principal_point_px", float, None),
                    k1=t.get("k1", float, 0.0), k2=t.get("k2", float, 0.0),
                    line_offset=t.get("line_offset_mm", float, 0.0) / 1000.0,
                )
        mounting = Mounting(
            lever_arm_B=np.array(t.vector("lever_arm_m", 3, [0.0, 0.0, 0.0])),
            boresight=np.radians(t.vector("boresight_deg", 3, [0.0, 0.0, 0.0])),
            time_offset=t.get("time_offset_s", float, 0.0),
        )
        bands = tuple(t.get("bands", list, []))
        wavelengths = tuple(float(w) for w in t.get("wavelengths_nm", list, []))
        t.finish()
        return cls(kind, model, mounting, line_rate, bands, wavelengths)


def read_look_angles(path: Path, pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """``pixel,along_deg,across_deg`` CSV -> (along, across) radians."""
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError) as exc:
        raise ProjectFileError(f"{path}: cannot read the look-angle table ({exc})") from exc
    if data.shape != (pixels, 3) or not np.array_equal(data[:, 0], np.arange(pixels)):
        raise ProjectFileError(f"{path}: expected rows pixel,along_deg,across_deg for pixels 0..{pixels - 1}")
    return np.radians(data[:, 1]), np.radians(data[:, 2])


@dataclass(frozen=True)
class StripConfig:
    """One [[strips]] entry."""

    id: str
    image: Path | None
    trajectory: Path
    first_line_time: float | None
    line_times: Path | None
    lines: int | None

    @classmethod
    def from_table(cls, t: Table, root: Path) -> StripConfig:
        sid = t.get("id", (str, int))
        image = t.get("image", str, None)
        first = t.get("first_line_time", float, None)
        table = t.get("line_times", str, None)
        if (first is None) == (table is None):
            raise ProjectFileError(f"{t.path} [strips id={sid}]: give exactly one of first_line_time and line_times")
        cfg = cls(str(sid), root / image if image else None, root / t.get("trajectory", str),
                  first, root / table if table else None, t.get("lines", int, None))
        t.finish()
        return cfg


@dataclass(frozen=True)
class Project:
    """A project folder read from ``project.toml``."""

    root: Path
    crs: str
    dtm_path: Path
    geoid: Geoid
    origin: tuple[float, float, float] | None
    sensor: SensorConfig
    strips: tuple[StripConfig, ...]
    knot_spacing: float = 0.2
    dtm_sigma: float = 1.5
    trajectory_crs: str | None = None
    extra: dict = field(default_factory=dict)

    @classmethod
    def load(cls, path) -> Project:
        """Read ``PATH/project.toml`` (or the file itself)."""
        path = Path(path)
        file = path / "project.toml" if path.is_dir() else path
        if not file.exists():
            raise ProjectFileError(f"{file}: no such project file")
        root = file.parent
        data = load_toml(file)
        for key in data:
            if key not in ("project", "sensor", "strips"):
                raise ProjectFileError(f"{file}: unknown table [{key}] (expected project, sensor, strips)")
        p = Table(data.get("project", {}), file, "project")
        crs = p.get("crs", str)
        parse_crs(crs, f"{file} [project] crs")
        dtm = root / p.get("dtm", str)
        geoid_file = p.get("geoid", str, None)
        undulation = p.get("geoid_undulation_m", float, None)
        if geoid_file and undulation is not None:
            raise ProjectFileError(f"{file} [project]: give geoid or geoid_undulation_m, not both")
        undulation = 0.0 if undulation is None else undulation
        geoid = Geoid.from_raster(root / geoid_file) if geoid_file else Geoid(undulation)
        origin = p.vector("origin", 3, None)
        knot_spacing = p.get("knot_spacing_s", float, 0.2)
        dtm_sigma = p.get("dtm_sigma_m", float, 1.5)
        traj_crs = p.get("trajectory_crs", str, None)
        if traj_crs is not None:
            parse_crs(traj_crs, f"{file} [project] trajectory_crs")
        p.finish()
        sensor = SensorConfig.from_table(Table(data.get("sensor", {}), file, "sensor"), root)
        raw_strips = data.get("strips", [])
        if not isinstance(raw_strips, list) or not raw_strips:
            raise ProjectFileError(f"{file}: expected at least one [[strips]] entry")
        strips = tuple(StripConfig.from_table(Table(s, file, f"strips #{i + 1}"), root) for i, s in enumerate(raw_strips))
        ids = [s.id for s in strips]
        dup = {i for i in ids if ids.count(i) > 1}
        if dup:
            raise ProjectFileError(f"{file}: strip id {sorted(dup)[0]!r} appears more than once")
        return cls(
            root, crs, dtm, geoid, tuple(origin) if origin else None, sensor, strips, knot_spacing, dtm_sigma, traj_crs
        )

    # --- frames and DTM -------------------------------------------------------------------------
    @cached_property
    def map_frame(self) -> MapFrame:
        """Map CRS <-> project frame; the origin is [project] origin or the DTM's centre."""
        if self.origin is not None:
            lat, lon, h = self.origin
            return MapFrame(self.crs, ProjectFrame.from_origin(lat, lon, h), self.geoid)
        import rasterio

        try:
            with rasterio.open(self.dtm_path) as src:
                b = src.bounds
                cx, cy = 0.5 * (b.left + b.right), 0.5 * (b.bottom + b.top)
                src_crs = src.crs.to_wkt() if src.crs else None
        except rasterio.errors.RasterioIOError as exc:
            raise ProjectFileError(f"{self.dtm_path}: cannot read the DTM ({exc})") from exc
        if src_crs is not None:
            import pyproj

            tr = pyproj.Transformer.from_crs(src_crs, self.crs, always_xy=True)
            cx, cy = tr.transform(cx, cy)
        return MapFrame.centred_on(self.crs, float(cx), float(cy), 0.0, self.geoid)

    @cached_property
    def dtm(self):
        from scangeo.dtm import DTM

        return DTM.open(self.dtm_path, self.map_frame)

    # --- strips ---------------------------------------------------------------------------------
    def strip(self, strip_id: str) -> StripConfig:
        for s in self.strips:
            if s.id == str(strip_id):
                return s
        raise ProjectFileError(
            f"{self.root / 'project.toml'}: no strip {strip_id!r} (strips: {', '.join(s.id for s in self.strips)})"
        )

    def stream(self, strip_id: str):
        """The strip's GPS/IMU stream as measured."""
        from scangeo.trajectory.checks import check_strip_trajectory, strip_times_of
        from scangeo.trajectory.readers import read_trajectory

        stream = read_trajectory(self.strip(strip_id).trajectory, crs=self.trajectory_crs or self.crs)
        check_strip_trajectory(stream, strip_times_of(self, strip_id))  # coverage, gaps: errors naming lines
        return stream

    def timing(self, strip_id: str) -> LineTiming:
        s = self.strip(strip_id)
        if s.line_times is not None:
            return LineTiming.from_table_file(s.line_times)
        return LineTiming(s.first_line_time, self.sensor.line_rate)

    def n_lines(self, strip_id: str) -> int:
        s = self.strip(strip_id)
        if s.lines is not None:
            return s.lines
        if s.line_times is not None:
            return len(self.timing(strip_id).table)
        if s.image is None:
            raise ProjectFileError(f"strip {strip_id}: give lines = N or an image to count them")
        import warnings

        import rasterio

        try:
            with warnings.catch_warnings():  # a raw scanner image has no georeferencing
                warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
                with rasterio.open(s.image) as src:
                    return int(src.height)
        except rasterio.errors.RasterioIOError as exc:
            raise ProjectFileError(f"{s.image}: cannot read the image ({exc})") from exc

    def geometry(self, strip_id: str, spline=None, mounting: Mounting | None = None, sensor=None) -> StripGeometry:
        """Strip geometry; by default direct georeferencing (the spline fitted to the GPS/IMU)."""
        from scangeo.trajectory.spline import OrientationSpline

        if spline is None:
            traj = self.stream(strip_id).to_project(self.map_frame.frame)
            spline = OrientationSpline.from_trajectory(traj, self.knot_spacing)
        return StripGeometry(
            sensor or self.sensor.model,
            spline,
            self.timing(strip_id),
            self.n_lines(strip_id),
            mounting or self.sensor.mounting,
            strip_id,
        )
