"""Consistency of real laser returns with their trajectory: recompute every return from trajectory,
boresight, scan angle and range (leeward sample: SBET + LAS + boresight/lever arm config).

The laser equation of gadomski/leeward (which these files come from), in its own frames:

    p_body = R_BS (rho cos(theta), 0, rho sin(theta)) - l_B
    p_ECEF = p_nav_ECEF + R_ECEF_NED(lat, lon) R_LB(roll, pitch, heading) p_body

with ``R_BS = Rz(yaw) Ry(pitch) Rx(roll)`` of the boresight angles (radians, as leeward reads its
config), ``R_LB = Rz(heading) Ry(pitch) Rx(roll)`` of the SBET attitude interpolated linearly at the
return's GPS time, the return's scan angle ``theta`` (LAS scan angle rank, whole degrees) and the
range ``rho = |p_body + l_B|`` taken from the given return. LAS z is used as ellipsoidal height
(as leeward does). The recomputed-minus-given differences measure how consistent the sample is;
a fit of small boresight rotations (body frame) and a scan-angle index/scale shows what explains
them.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, get_args

import numpy as np
import pyproj
from scipy.optimize import least_squares

from scangeo.errors import ArgumentError, InputFileError
from scangeo.frames import R_ecef_ned, geodetic_to_ecef
from scangeo.io.toml_config import load_toml
from scangeo.lidar.las_header import check_las_file
from scangeo.lidar.lasio import laspy_errors
from scangeo.rotation import rph_to_matrix, unwrap_heading
from scangeo.trajectory.readers import read_sbet_records

log = logging.getLogger(__name__)

#: Which heading the SBET's heading field gives: ``platform`` (the field as it is, as leeward and PDAL
#: read it) or ``true`` (platform heading minus the wander angle).
Heading = Literal["platform", "true"]


def _check_heading(heading: str) -> None:
    if heading not in get_args(Heading):
        raise ArgumentError("{heading}: expected one of " + ", ".join(get_args(Heading)), heading=heading)

@dataclass(frozen=True)
class LeewardConfig:
    """Boresight roll, pitch, yaw (rad), lever arm (m, body), UTM zone of the points."""

    boresight: tuple[float, float, float]
    lever_arm: tuple[float, float, float]
    utm_zone: int


def read_leeward_config(path: str | Path) -> LeewardConfig:
    """The leeward config.toml (boresight in radians, as leeward's code reads it)."""
    path = Path(path)
    data = load_toml(path)
    try:
        b = data["boresight"]
        return LeewardConfig(
            (float(b["roll"]), float(b["pitch"]), float(b["yaw"])),
            (float(data["lever_arm"][0]), float(data["lever_arm"][1]), float(data["lever_arm"][2])),
            int(data["utm_zone"]),
        )
    except (KeyError, ValueError, TypeError) as exc:
        raise InputFileError(f"{path}: expected utm_zone, lever_arm and [boresight] roll/pitch/yaw ({exc!r})") from exc


@dataclass(frozen=True)
class Returns:
    """Laser returns in ECEF with the trajectory interpolated at their times."""

    p_ecef: np.ndarray  # (n, 3) given returns, m
    nav_ecef: np.ndarray  # (n, 3) navigation point, m
    R_ecef_body: np.ndarray  # (n, 3, 3)
    scan_angle: np.ndarray  # (n,) rad (LAS scan angle rank)
    lat: np.ndarray
    lon: np.ndarray


def load_returns(sbet: str | Path, las: str | Path, utm_zone: int, heading: Heading = "platform") -> Returns:
    """Read the SBET and the LAS and interpolate the trajectory at each return's GPS time.

    ``heading``: ``"platform"`` uses the SBET heading field as the true heading (leeward, PDAL);
    ``"true"`` uses platform heading minus wander angle.
    """
    _check_heading(heading)
    import laspy  # start-up cost: laspy and its LAZ backend load when a LAS file is read

    nav = read_sbet_records(sbet)
    check_las_file(las)
    try:
        cloud = laspy.read(str(las))
    except laspy_errors() as exc:
        raise InputFileError(f"{las}: cannot read as LAS/LAZ; truncated or corrupted? ({exc})") from exc
    if "gps_time" not in cloud.point_format.dimension_names:
        raise InputFileError(f"{las}: point format {cloud.point_format.id} has no GPS time (needed for every return)")
    if len(cloud.points) == 0:
        raise InputFileError(f"{las}: no returns")
    t = np.asarray(cloud.gps_time, dtype=float)
    if t.min() < nav["time"][0] or t.max() > nav["time"][-1]:
        raise InputFileError(
            f"{las}: GPS times {t.min():.3f}..{t.max():.3f} s outside the SBET's "
            f"{nav['time'][0]:.3f}..{nav['time'][-1]:.3f} s"
        )
    interp = {k: np.interp(t, nav["time"], nav[k]) for k in ("lat", "lon", "alt", "roll", "pitch")}
    hdg = unwrap_heading(nav["platform_heading"] - (nav["wander"] if heading == "true" else 0.0))
    to_geo = pyproj.Transformer.from_crs(32600 + utm_zone, 4326, always_xy=True)
    lon, lat = to_geo.transform(np.asarray(cloud.x), np.asarray(cloud.y))
    p = geodetic_to_ecef(np.radians(lat), np.radians(lon), np.asarray(cloud.z, dtype=float))
    R = R_ecef_ned(interp["lat"], interp["lon"]) @ rph_to_matrix(
        interp["roll"], interp["pitch"], np.interp(t, nav["time"], hdg)
    )
    return Returns(
        p,
        geodetic_to_ecef(interp["lat"], interp["lon"], interp["alt"]),
        R,
        np.radians(np.asarray(cloud.scan_angle_rank, dtype=float)),
        interp["lat"],
        interp["lon"],
    )


def _recompute_body(r: Returns, config: LeewardConfig, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Given and recomputed returns in the body frame for corrections
    ``params = (d_roll, d_pitch, d_yaw, index, scale)`` (rad, rad, rad, rad, -)."""
    lever = np.asarray(config.lever_arm)
    body = np.einsum("nji,nj->ni", r.R_ecef_body, r.p_ecef - r.nav_ecef)
    rho = np.linalg.norm(body + lever, axis=1)
    theta = r.scan_angle * (1.0 + params[4]) + params[3]
    scan = np.c_[rho * np.cos(theta), np.zeros_like(rho), rho * np.sin(theta)]
    R_BS = rph_to_matrix(*params[:3]) @ rph_to_matrix(*config.boresight)
    return body, scan @ R_BS.T - lever


def _rms(d: np.ndarray) -> list[float]:
    return [float(v) for v in np.sqrt(np.mean(d**2, axis=0))]


def consistency(sbet: str | Path, las: str | Path, system: str | Path, heading: Heading = "platform") -> dict:
    """Recompute every return and report how consistent the sample is.

    Parameters
    ----------
    sbet : str or Path
        The Applanix SBET trajectory (.out).
    las : str or Path
        LAS/LAZ returns with GPS time and scan angle.
    system : str or Path
        The scanner system's leeward config.toml (boresight in radians, lever arm in metres, UTM zone).
    heading : {"platform", "true"}
        ``platform``: the SBET's heading field as the heading; ``true``: that minus the wander angle.

    Returns
    -------
    dict
        JSON-ready: number of returns, mean range (m), rms of recomputed minus given in east/north/up
        (m) with the configured boresight, the rms to expect from the whole-degree scan angles alone,
        and the fitted corrections (deg) with the rms after the fit.

    Raises
    ------
    InputFileError
        A file that cannot be read.
    ArgumentError
        ``heading`` not one of the two.
    """
    _check_heading(heading)
    config = read_leeward_config(system)
    r = load_returns(sbet, las, config.utm_zone, heading)
    x0 = np.zeros(5)

    def enu_diff(params: np.ndarray) -> np.ndarray:
        body, rec = _recompute_body(r, config, params)
        d_ecef = np.einsum("nij,nj->ni", r.R_ecef_body, rec - body)
        d_ned = np.einsum("nji,nj->ni", R_ecef_ned(r.lat, r.lon), d_ecef)
        return np.c_[d_ned[:, 1], d_ned[:, 0], -d_ned[:, 2]]

    before = enu_diff(x0)

    def full(q: np.ndarray) -> np.ndarray:
        # the scan-angle index is a rotation about (nearly) the same axis as the boresight roll:
        # fitting both is singular, so the index stays zero and the roll absorbs it
        return np.array([q[0], q[1], q[2], 0.0, q[3]])

    fit = least_squares(lambda q: enu_diff(full(q)).ravel(), np.zeros(4), x_scale=1e-3)
    after = enu_diff(full(fit.x))
    body, _ = _recompute_body(r, config, x0)
    rho = np.linalg.norm(body + np.asarray(config.lever_arm), axis=1)
    quantisation = float(np.sqrt(np.mean((rho * np.radians(1.0) / np.sqrt(12.0)) ** 2)))
    names = ("boresight_roll", "boresight_pitch", "boresight_yaw")
    log.info("leeward consistency: rms before %s, after %s", _rms(before), _rms(after))
    return {
        "returns": int(len(rho)),
        "heading": heading,
        "mean_range_m": float(rho.mean()),
        "rms_enu_m": _rms(before),
        "rms_3d_m": float(np.sqrt(np.mean(np.sum(before**2, axis=1)))),
        "expected_rms_from_whole_degree_scan_angles_m": quantisation,
        "fit_deg": {n: float(np.degrees(v)) for n, v in zip(names, fit.x[:3])},
        "fit_scan_scale": float(fit.x[3]),
        "fit_rms_enu_m": _rms(after),
        "fit_rms_3d_m": float(np.sqrt(np.mean(np.sum(after**2, axis=1)))),
    }
