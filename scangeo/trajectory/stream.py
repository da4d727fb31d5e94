"""GPS/IMU streams: as measured (geodetic, NED attitude) and converted to the project frame.

The attitude of a stream converted to the project frame is expressed as roll, pitch, heading of the
body relative to the *project NED frame* (north-east-down axes of P at its origin):
``R_PB = R_ENU_NED @ Rz(heading_P) Ry(pitch_P) Rx(roll_P)``. The conversion uses ``R_PL`` of every
sample exactly (``R_PB = R_PL(lat, lon) R_LB``), so meridian convergence and earth curvature are
carried into the angles; afterwards no position-dependent rotation is needed, which keeps the
orientation spline and its derivatives exact and cheap.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.errors import TrajectoryError
from scangeo.frames import ProjectFrame
from scangeo.rotation import R_ENU_NED, matrix_to_rph, rph_to_matrix


def check_times(time: np.ndarray, source: str, line_of=None) -> None:
    """Raise TrajectoryError unless ``time`` is finite and strictly increasing.

    ``line_of(i)`` maps a sample index to the file line (or record) named in the message.
    """
    describe = line_of or (lambda i: f"sample {i}")
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        raise TrajectoryError(f"{source} {describe(bad[0])}: time is not a number")
    steps = np.diff(time)
    back = np.flatnonzero(steps <= 0)
    if back.size:
        i = back[0] + 1
        kind = "repeats" if steps[back[0]] == 0 else "is before"
        raise TrajectoryError(
            f"{source} {describe(i)}: time {time[i]:.6f} {kind} the previous {time[i - 1]:.6f} "
            "(times must strictly increase)"
        )


@dataclass(frozen=True)
class GpsImuStream:
    """A GPS/IMU trajectory as measured.

    Read one with :func:`scangeo.trajectory.readers.read_trajectory` (CSV or Applanix SBET by its
    content), ``read_trajectory_csv`` or ``read_sbet``.

    Parameters
    ----------
    time : (n,) float array, seconds (the project's time base), strictly increasing.
    lat, lon : (n,) float arrays, radians, WGS84.
    h : (n,) float array, ellipsoidal height, metres.
    roll, pitch, heading : (n,) float arrays, radians; attitude of the body (x forward, y right,
        z down) in the local NED frame, ``R_LB = Rz(heading) Ry(pitch) Rx(roll)``.
    source : where it came from (used in messages).
    """

    time: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    heading: np.ndarray
    source: str = "<stream>"

    def __post_init__(self) -> None:
        n = len(self.time)
        for name in ("lat", "lon", "h", "roll", "pitch", "heading"):
            if len(getattr(self, name)) != n:
                raise TrajectoryError(
                    f"{self.source}: column {name} has {len(getattr(self, name))} values, time has {n}"
                )
        if n < 2:
            raise TrajectoryError(f"{self.source}: a trajectory needs at least 2 records, found {n}")
        check_times(np.asarray(self.time), self.source)

    def __len__(self) -> int:
        return len(self.time)

    @property
    def rate_hz(self) -> float:
        """Median sampling rate (Hz)."""
        return float(1.0 / np.median(np.diff(self.time)))

    def select(self, mask: np.ndarray) -> GpsImuStream:
        """The samples where ``mask`` is true."""
        time, lat, lon, h, roll, pitch, heading = (
            np.asarray(getattr(self, k))[mask] for k in ("time", "lat", "lon", "h", "roll", "pitch", "heading")
        )
        return GpsImuStream(time, lat, lon, h, roll, pitch, heading, source=self.source)

    def between(self, t0: float, t1: float) -> GpsImuStream:
        """The samples with t0 <= time <= t1."""
        return self.select((self.time >= t0) & (self.time <= t1))

    def R_LB(self) -> np.ndarray:
        """Body-to-navigation rotations (n, 3, 3)."""
        return rph_to_matrix(self.roll, self.pitch, self.heading)

    def to_project(self, frame: ProjectFrame) -> ProjectTrajectory:
        """This stream in the project frame (positions of the navigation reference point)."""
        p_P = frame.geodetic_to_project(self.lat, self.lon, self.h)
        R_PB = frame.R_PL(self.lat, self.lon) @ self.R_LB()
        return ProjectTrajectory.from_rotations(np.asarray(self.time, float), p_P, R_PB, self.source)

    @classmethod
    def from_project(cls, trajectory: ProjectTrajectory, frame: ProjectFrame) -> GpsImuStream:
        """The geodetic/NED stream of a project-frame trajectory (the inverse of ``to_project``)."""
        lat, lon, h = frame.project_to_geodetic(trajectory.p_P)
        R_LB = np.swapaxes(frame.R_PL(lat, lon), -1, -2) @ trajectory.R_PB()
        roll, pitch, heading = matrix_to_rph(R_LB)
        return cls(trajectory.time, lat, lon, h, roll, pitch, np.unwrap(heading), trajectory.source)


@dataclass(frozen=True)
class ProjectTrajectory:
    """Positions and attitude in the project frame.

    Parameters
    ----------
    time : (n,) seconds.
    p_P : (n, 3) metres, project frame: position of the navigation reference point.
    angles_P : (n, 3) radians: roll, pitch, heading of the body w.r.t. the project NED frame
        (heading unwrapped, continuous across +-pi).
    """

    time: np.ndarray
    p_P: np.ndarray
    angles_P: np.ndarray
    source: str = "<trajectory>"

    @classmethod
    def from_rotations(cls, time, p_P, R_PB, source="<trajectory>") -> ProjectTrajectory:
        roll, pitch, heading = matrix_to_rph(R_ENU_NED @ R_PB)
        angles = np.stack([roll, pitch, np.unwrap(heading)], axis=-1)
        return cls(np.asarray(time, float), np.asarray(p_P, float), angles, source)

    def R_PB(self) -> np.ndarray:
        """Body-to-project rotations (n, 3, 3)."""
        a = self.angles_P
        return R_ENU_NED @ rph_to_matrix(a[:, 0], a[:, 1], a[:, 2])

    def sensor_positions(self, lever_arm_B: np.ndarray) -> np.ndarray:
        """p_S = p_P + R_PB l_B (n, 3): positions of a point at lever arm l_B (body frame, m)."""
        return self.p_P + self.R_PB() @ np.asarray(lever_arm_B, float)
