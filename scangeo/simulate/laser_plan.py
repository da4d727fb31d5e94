"""Flight plans of a simulated laser block: strips, missions, altitudes, the true trajectory.

Without missions: ``strips`` parallel north-south strips (alternating direction) at ``height`` and one
east-west cross strip, all in mission ``"1"``. With missions (``mission_strips``, the montafon
preset): each mission flies its parallel strips and its cross strips in turn, every strip
``clearance`` above the highest ground within two nominal half swaths of its track, climbing and
descending with the terrain at most ``MAX_CLIMB`` (a helicopter's profile: the cross strips climb
the valley sides, the parallel strips along the valley stay nearly level); strips end at the
elliptic project ``limits``, so the outer parallel strips are short and miss the outer cross strips.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scangeo.simulate.laser_config import LaserBlockConfig
from scangeo.simulate.laser_scene import LaserScene, Valley

#: steepest climb or descent of a strip's flight profile (tangent; about 25 deg)
MAX_CLIMB = 0.47


@dataclass
class StripPlan:
    id: str
    start: np.ndarray  # (2,) project x, y
    heading: float  # rad, clockwise from north
    t0: float
    duration: float
    altitude: float  # m, project frame (the highest of the profile)
    mission: str = "1"
    profile: np.ndarray | None = None  # (2, n): along-track distance (m) and altitude; None: level

    def height_at(self, s: np.ndarray) -> np.ndarray:
        """Altitude (m) at along-track distances ``s``."""
        if self.profile is None:
            return np.full(np.shape(s), self.altitude)
        return np.interp(s, self.profile[0], self.profile[1])

    def track(self, speed: float, step: float = 25.0) -> np.ndarray:
        """(n, 2) points along the track every ``step`` metres."""
        s = np.arange(0.0, self.duration * speed + step, step)
        return self.start + s[:, None] * np.array([np.sin(self.heading), np.cos(self.heading)])


def valley_of(cfg: LaserBlockConfig) -> Valley | None:
    if not cfg.valley:
        return None
    floor, top, half, slope_deg = cfg.valley
    return Valley(floor, top, half, float(np.tan(np.radians(slope_deg))), cfg.valley_ripple,
                  meander=cfg.valley_meander)


def block_half_extent(cfg: LaserBlockConfig) -> tuple[float, float]:
    """Half extents (x, y) of the flown area (m, project frame)."""
    if not cfg.mission_strips:
        half = 0.5 * cfg.strip_length
        return half, half
    width = max((n - 1) * s for n, s in zip(cfg.mission_strips, cfg.mission_spacing))
    return 0.5 * width, 0.5 * cfg.strip_length


def inside_limits(cfg: LaserBlockConfig, x, y, margin: float = 0.0):
    """Whether points lie inside the project limits (and the flown area), ``margin`` metres in."""
    hx, hy = block_half_extent(cfg)
    ok = (np.abs(x) < hx - margin) & (np.abs(y) < hy - margin)
    if cfg.limits:
        a, b = cfg.limits[0] - margin, cfg.limits[1] - margin
        ok &= (np.asarray(x) / a) ** 2 + (np.asarray(y) / b) ** 2 < 1.0
    return ok


def _chord(cfg: LaserBlockConfig, across: float, half: float, semi: tuple[float, float]) -> float:
    """Half length of a line ``across`` from the centre, clipped at the elliptic limits."""
    if not cfg.limits:
        return half
    a, b = semi
    return float(min(half, b * np.sqrt(max(0.0, 1.0 - (across / a) ** 2))))


def _profile(scene: LaserScene, start: np.ndarray, end: np.ndarray, clearance: float, fov_deg: float) -> np.ndarray:
    """(2, n) along-track distance and altitude: ``clearance`` above the highest ground within two
    nominal half swaths across and as far along, the upper envelope with climbs of at most ``MAX_CLIMB``."""
    length = float(np.hypot(*(end - start)))
    s = np.linspace(0.0, length, max(2, int(length / 25.0) + 1))
    d = (end - start) / max(length, 1e-9)
    side = np.array([d[1], -d[0]])
    reach = 2.0 * clearance * np.tan(np.radians(fov_deg / 2))
    offsets = np.linspace(-reach, reach, 9)
    pts = start + s[:, None, None] * d + offsets[None, :, None] * side
    g = scene.ground(pts[..., 0], pts[..., 1]).max(axis=1)
    near = np.abs(s[:, None] - s[None, :]) <= reach
    g = np.where(near, g[None, :], -np.inf).max(axis=1)  # as far along as across
    z = (g[None, :] - MAX_CLIMB * np.abs(s[:, None] - s[None, :])).max(axis=1) + clearance
    return np.vstack([s, z])


def plans(cfg: LaserBlockConfig, scene: LaserScene) -> list[StripPlan]:
    if not cfg.mission_strips:
        return _single(cfg)
    out: list[StripPlan] = []
    t = cfg.time_start
    hx, hy = block_half_extent(cfg)
    semi = (cfg.limits[0], cfg.limits[1]) if cfg.limits else (hx, hy)
    for m, (n, n_cross) in enumerate(zip(cfg.mission_strips, cfg.mission_cross_strips)):
        name, spacing, clearance = chr(ord("A") + m), cfg.mission_spacing[m], cfg.mission_clearance[m]
        lines = []
        for k in range(n):
            x = (k - 0.5 * (n - 1)) * spacing
            half = _chord(cfg, x, hy, semi)
            a, b = np.array([x, -half]), np.array([x, half])
            lines.append((a, b) if k % 2 == 0 else (b, a))
        for k in range(n_cross):
            y = (k + 0.5 - 0.5 * n_cross) * (2.0 * hy / n_cross)
            half = _chord(cfg, y, hx, semi[::-1])
            a, b = np.array([-half, y]), np.array([half, y])
            lines.append((a, b) if k % 2 == 0 else (b, a))
        for a, b in lines:
            length = float(np.hypot(*(b - a)))
            if length < 4.0 * cfg.speed:
                continue  # outside the limits: not flown
            heading = float(np.arctan2(b[0] - a[0], b[1] - a[1]))
            profile = _profile(scene, a, b, clearance, cfg.fov_deg)
            out.append(StripPlan(str(len(out) + 1), a, heading, t, length / cfg.speed, float(profile[1].max()),
                                 name, profile))
            t += length / cfg.speed + 60.0
        t += 3600.0  # the next mission is another flight
    return out


def _single(cfg: LaserBlockConfig) -> list[StripPlan]:
    out, t = [], cfg.time_start
    dur = cfg.strip_length / cfg.speed
    half = 0.5 * cfg.strip_length
    for k in range(cfg.strips):
        x = (k - 0.5 * (cfg.strips - 1)) * cfg.strip_spacing
        north = k % 2 == 0
        out.append(StripPlan(str(k + 1), np.array([x, -half if north else half]), 0.0 if north else np.pi, t, dur,
                             cfg.height))
        t += dur + 60.0
    if cfg.cross_strip:
        out.append(StripPlan(str(cfg.strips + 1), np.array([-half, 0.0]), 0.5 * np.pi, t, dur, cfg.height))
    return out


def triangle(t: np.ndarray, rate: float) -> np.ndarray:
    """Oscillating-mirror scan angle pattern in [-1, 1]: +1 (right edge) -> -1 -> +1 per period."""
    phase = (t * rate) % 1.0
    return 4.0 * np.abs(phase - 0.5) - 1.0


def true_trajectory(plan: StripPlan, cfg: LaserBlockConfig, t: np.ndarray, phase: np.ndarray):
    """True positions (project frame) and attitude (roll, pitch, heading; rad) at times ``t``."""
    s = cfg.speed * (t - plan.t0)
    d = np.array([np.sin(plan.heading), np.cos(plan.heading)])
    pos = np.column_stack([plan.start[0] + s * d[0], plan.start[1] + s * d[1], plan.height_at(s)])
    w = np.radians(cfg.attitude_wobble_deg)
    tt = t - plan.t0
    ang = np.column_stack(
        [
            w[0] * np.sin(2 * np.pi * tt / 7.0 + phase[0]),
            w[1] * np.sin(2 * np.pi * tt / 11.0 + phase[1]),
            plan.heading + w[2] * np.sin(2 * np.pi * tt / 13.0 + phase[2]),
        ]
    )
    return pos, ang
