"""Interpolation error of the orientation spline against the real 200 Hz trajectory.

Run: python tests/benchmarks/spline_accuracy.py

The PDAL sample trajectory (73 s, 200 Hz, UTM 15N, a turn with roll to -18 deg) is converted to the
project frame and fitted by least squares with knot spacings 0.04, 0.2 and 1 s. Errors at every
200 Hz sample (fit residuals) and, held out, at the samples left out of a fit to every 4th one
(the 50 Hz a typical GPS/IMU gives): position (3D, mm) and attitude (per angle, microradians).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from scangeo.frames import ProjectFrame
from scangeo.trajectory import OrientationSpline, read_trajectory

PATH = Path(__file__).resolve().parents[3] / "shared/data/trajectory/sbet_047_IGS08-UTM15N-Ellipsoid-trim.txt"


def errors(spline, traj, mask):
    v = spline.evaluate(traj.time[mask])
    dp = np.linalg.norm(v[:, :3] - traj.p_P[mask], axis=1) * 1000.0
    da = np.abs(v[:, 3:] - traj.angles_P[mask]) * 1e6
    return dp, da


def main() -> None:
    stream = read_trajectory(PATH, crs="EPSG:32615")
    mid = len(stream) // 2
    frame = ProjectFrame(stream.lat[mid], stream.lon[mid], stream.h[mid])
    traj = stream.to_project(frame)
    inner = (traj.time > traj.time[0] + 1) & (traj.time < traj.time[-1] - 1)
    print(f"{len(stream)} samples, {stream.rate_hz:.0f} Hz, {traj.time[-1] - traj.time[0]:.1f} s")
    print(
        "| knot spacing | fit: position rms / max (mm) | fit: roll, pitch, heading rms (urad) "
        "| fit: attitude max (urad) "
        "| 50 Hz held out: position rms / max (mm) | held out: attitude rms / max (urad) |"
    )
    print("|---|---|---|---|---|---|")
    every4 = np.zeros(len(traj.time), bool)
    every4[::4] = True
    for spacing in (0.04, 0.2, 1.0):
        fit = OrientationSpline.from_trajectory(traj, spacing)
        dp, da = errors(fit, traj, inner)
        sub = type(traj)(traj.time[every4], traj.p_P[every4], traj.angles_P[every4])
        held = OrientationSpline.from_trajectory(sub, spacing, t_range=(traj.time[0], traj.time[-1]))
        hp, ha = errors(held, traj, inner & ~every4)
        print(
            f"| {spacing:g} s | {np.sqrt(np.mean(dp**2)):.1f} / {dp.max():.1f} | "
            f"{', '.join(f'{x:.1f}' for x in np.sqrt(np.mean(da**2, axis=0)))} | {da.max():.0f} | "
            f"{np.sqrt(np.mean(hp**2)):.1f} / {hp.max():.1f} | {np.sqrt(np.mean(ha**2)):.1f} / {ha.max():.0f} |"
        )


if __name__ == "__main__":
    main()
