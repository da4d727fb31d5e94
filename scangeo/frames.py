"""Frames: the project frame P (local ENU), the map CRS, geodetic coordinates, ``R_PL``.

* Geodetic coordinates are on the WGS84 ellipsoid (the GPS's), latitude/longitude in radians here
  (degrees only at the edges), ellipsoidal height ``h`` in metres.
* The project frame P is the east-north-up tangent frame at an origin near the block centre: a
  Cartesian frame, metres. Conversions geodetic <-> ECEF <-> P are exact closed forms.
* The map CRS is any pyproj CRS for horizontal coordinates with orthometric heights ``H``;
  ``h = H + N`` with the geoid undulation ``N`` (a constant or a raster).
* ``R_PL(lat, lon)`` rotates vectors of the local north-east-down navigation frame L at a point into P:
  it carries meridian convergence and earth curvature exactly.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj

from scangeo.errors import CRSError, InputFileError
from scangeo.grid import RasterGrid

WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)

#: The geographic 2D CRS of the project frame's ellipsoid (lon, lat order with always_xy).
GEOGRAPHIC_CRS = pyproj.CRS.from_epsg(4326)


def parse_crs(crs, where: str = "CRS") -> pyproj.CRS:
    """A pyproj CRS of a user's input (EPSG code, WKT, PROJ string, pyproj.CRS).

    ``where`` names the file and key for the message, e.g. ``project.toml [project] crs``; a CRS
    PROJ does not know raises :class:`~scangeo.errors.CRSError` instead of pyproj's own error.
    """
    if isinstance(crs, pyproj.CRS):
        return crs
    try:
        return pyproj.CRS.from_user_input(crs)
    except (pyproj.exceptions.CRSError, TypeError, ValueError) as exc:
        text = str(crs) if len(str(crs)) <= 80 else str(crs)[:77] + "..."
        raise CRSError(f"{where}: {text!r} is not a coordinate reference system PROJ knows "
                       "(expected e.g. EPSG:32633, a WKT or a PROJ string)") from exc


def geodetic_to_ecef(lat, lon, h) -> np.ndarray:
    """ECEF (n, 3) metres of geodetic lat, lon (rad) and ellipsoidal height h (m) on WGS84."""
    lat = np.asarray(lat, dtype=float)
    lon = np.asarray(lon, dtype=float)
    h = np.asarray(h, dtype=float)
    sl, cl = np.sin(lat), np.cos(lat)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * sl * sl)
    return np.stack(
        [(n + h) * cl * np.cos(lon), (n + h) * cl * np.sin(lon), (n * (1.0 - WGS84_E2) + h) * sl], axis=-1
    )


def ecef_to_geodetic(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geodetic lat, lon (rad), h (m) of ECEF points (n, 3); iterated to 1e-13 rad."""
    xyz = np.asarray(xyz, dtype=float)
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1.0 - WGS84_E2))
    for _ in range(6):
        sl = np.sin(lat)
        n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * sl * sl)
        h = np.where(np.abs(np.cos(lat)) > 1e-9, p / np.cos(lat) - n, np.abs(z) - n * (1 - WGS84_E2))
        lat = np.arctan2(z, p * (1.0 - WGS84_E2 * n / (n + h)))
    sl = np.sin(lat)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * sl * sl)
    h = np.where(np.abs(np.cos(lat)) > 1e-9, p / np.cos(lat) - n, np.abs(z) - n * (1 - WGS84_E2))
    return lat, lon, h


def R_ecef_ned(lat, lon) -> np.ndarray:
    """Rotation (..., 3, 3) from the north-east-down frame at (lat, lon) (rad) to ECEF."""
    lat = np.asarray(lat, dtype=float)
    lon = np.asarray(lon, dtype=float)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    north = np.stack([-sl * co, -sl * so, cl], -1)
    east = np.stack([-so, co, np.zeros_like(lat)], -1)
    down = np.stack([-cl * co, -cl * so, -sl], -1)
    return np.stack([north, east, down], -1)


def R_ecef_enu(lat, lon) -> np.ndarray:
    """Rotation (..., 3, 3) from the east-north-up frame at (lat, lon) (rad) to ECEF."""
    R = R_ecef_ned(lat, lon)
    return np.stack([R[..., 1], R[..., 0], -R[..., 2]], -1)


@dataclass(frozen=True)
class ProjectFrame:
    """The project frame P: east-north-up tangent frame at a geodetic origin on WGS84.

    Parameters
    ----------
    lat0, lon0 : origin latitude and longitude, radians.
    h0 : origin ellipsoidal height, metres.
    """

    lat0: float
    lon0: float
    h0: float = 0.0
    ecef0: np.ndarray = field(init=False, repr=False, compare=False)
    R_ecef_P: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "ecef0", geodetic_to_ecef(self.lat0, self.lon0, self.h0))
        object.__setattr__(self, "R_ecef_P", R_ecef_enu(self.lat0, self.lon0))

    @classmethod
    def from_origin(cls, lat_deg: float, lon_deg: float, h: float = 0.0) -> ProjectFrame:
        """A frame at an origin given in degrees (latitude, longitude) and metres (ellipsoidal)."""
        return cls(np.radians(lat_deg), np.radians(lon_deg), float(h))

    def geodetic_to_project(self, lat, lon, h) -> np.ndarray:
        """p_P (n, 3) metres of geodetic lat, lon (rad), h (m)."""
        return (geodetic_to_ecef(lat, lon, h) - self.ecef0) @ self.R_ecef_P

    def project_to_geodetic(self, p_P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Geodetic lat, lon (rad), h (m) of project-frame points p_P (n, 3)."""
        return ecef_to_geodetic(np.asarray(p_P, dtype=float) @ self.R_ecef_P.T + self.ecef0)

    def R_PL(self, lat, lon) -> np.ndarray:
        """Rotation (..., 3, 3) from the navigation frame L (NED) at (lat, lon) (rad) into P."""
        return self.R_ecef_P.T @ R_ecef_ned(lat, lon)

    def to_dict(self) -> dict:
        return {"lat0_deg": float(np.degrees(self.lat0)), "lon0_deg": float(np.degrees(self.lon0)), "h0": self.h0}


class Geoid:
    """Geoid undulation N (metres, ellipsoidal minus orthometric height): a constant or a raster.

    A raster is sampled bilinearly at the point's geographic position transformed into its CRS
    (geographic geoid grids such as EGM2008 in EPSG:4326 work as they are).
    """

    def __init__(self, constant: float = 0.0, grid: RasterGrid | None = None, path: str | None = None):
        self.constant = float(constant)
        self.grid = grid
        self.path = path
        self._to_grid = None
        if grid is not None:
            grid_crs = pyproj.CRS.from_user_input(grid.crs) if grid.crs is not None else GEOGRAPHIC_CRS
            self._to_grid = pyproj.Transformer.from_crs(GEOGRAPHIC_CRS, grid_crs, always_xy=True)

    @classmethod
    def from_raster(cls, path: str | Path) -> Geoid:
        import rasterio

        try:
            with rasterio.open(path) as src:
                values = src.read(1, masked=True).astype(float).filled(np.nan)
                grid = RasterGrid(values, src.transform, src.crs.to_wkt() if src.crs else None)
        except rasterio.errors.RasterioIOError as exc:
            raise InputFileError(f"{path}: cannot read the geoid raster ({exc})") from exc
        return cls(grid=grid, path=str(path))

    def undulation(self, lat, lon) -> np.ndarray:
        """N (m) at geodetic lat, lon (rad); NaN outside a raster geoid."""
        lat = np.asarray(lat, dtype=float)
        if self.grid is None:
            return np.full(lat.shape, self.constant)
        assert self._to_grid is not None  # set together with self.grid
        gx, gy = self._to_grid.transform(np.degrees(lon), np.degrees(lat))
        return self.grid.sample(np.asarray(gx), np.asarray(gy))


class MapFrame:
    """Map CRS (horizontal, any pyproj CRS) with orthometric heights <-> project frame P.

    Parameters
    ----------
    crs : the map CRS (EPSG code, WKT, PROJ string, pyproj.CRS). For a compound CRS its horizontal
        part is used and heights are taken as orthometric.
    frame : the project frame.
    geoid : the geoid undulation (default: 0, heights are ellipsoidal).
    """

    def __init__(self, crs, frame: ProjectFrame, geoid: Geoid | None = None) -> None:
        crs = parse_crs(crs)
        if crs.is_compound:
            crs = crs.sub_crs_list[0]
        self.crs = crs
        self.frame = frame
        self.geoid = geoid or Geoid(0.0)
        self._to_geo = pyproj.Transformer.from_crs(crs, GEOGRAPHIC_CRS, always_xy=True)
        self._exact_inverse = crs.geodetic_crs is not None and crs.geodetic_crs.datum == GEOGRAPHIC_CRS.datum

    @classmethod
    def centred_on(cls, crs, x: float, y: float, H: float = 0.0, geoid: Geoid | None = None) -> MapFrame:
        """A map frame whose project origin lies at the map point (x, y, H)."""
        tmp = cls(crs, ProjectFrame(0.0, 0.0, 0.0), geoid)
        lat, lon = tmp.map_to_geodetic_2d(np.array([x]), np.array([y]))
        n = tmp.geoid.undulation(lat, lon)
        return cls(crs, ProjectFrame(float(lat[0]), float(lon[0]), float(H + np.nan_to_num(n[0]))), geoid)

    def map_to_geodetic_2d(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Geodetic lat, lon (rad) of map points."""
        lon, lat = self._to_geo.transform(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        return np.radians(lat), np.radians(lon)

    def geodetic_to_map_2d(self, lat, lon) -> tuple[np.ndarray, np.ndarray]:
        """Map x, y of geodetic lat, lon (rad)."""
        lon_deg, lat_deg = np.degrees(lon), np.degrees(lat)
        x, y = self._to_geo.transform(lon_deg, lat_deg, direction="INVERSE")
        x, y = np.asarray(x), np.asarray(y)
        if self._exact_inverse:
            return x, y
        # A datum shift done in 2D is not exactly invertible by PROJ (about 1 mm for MGI): one
        # fixed-point step makes geodetic -> map the exact inverse of map -> geodetic.
        lo2, la2 = self._to_geo.transform(x, y)
        x2, y2 = self._to_geo.transform(lo2, la2, direction="INVERSE")
        return 2 * x - np.asarray(x2), 2 * y - np.asarray(y2)

    def map_to_project(self, x, y, H) -> np.ndarray:
        """p_P (n, 3) of map points (x, y in the map CRS, H orthometric metres)."""
        lat, lon = self.map_to_geodetic_2d(x, y)
        h = np.asarray(H, dtype=float) + self.geoid.undulation(lat, lon)
        return self.frame.geodetic_to_project(lat, lon, h)

    def project_to_map(self, p_P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Map x, y and orthometric H of project-frame points p_P (n, 3)."""
        lat, lon, h = self.frame.project_to_geodetic(p_P)
        x, y = self.geodetic_to_map_2d(lat, lon)
        return x, y, h - self.geoid.undulation(lat, lon)
