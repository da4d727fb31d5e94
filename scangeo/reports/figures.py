"""The plots of the report (matplotlib, Agg; each returned as PNG bytes).

* :func:`residual_map`: check-point residual vectors over a strip's footprint, variants side by side;
* :func:`rms_chart`: check-point rms across track per strip and variant;
* :func:`correction_plot`: the applied corrections of a strip over time, per variant;
* :func:`height_correction_plot`: a strip's Z corrections with the GPS/IMU height's deviation from
  the mean flight height (and, on a simulated project, the injected height error);
* :func:`tracks_map`, :func:`gpsimu_plot`: the GPS/IMU of the strips (map, flight direction;
  positions and angles over time).
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from scangeo.reports.corrections import Series
from scangeo.reports.residual_vectors import ResidualVectors

DPI = 100
_CYCLE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22"]


def colour(i: int) -> str:
    return _CYCLE[i % len(_CYCLE)]


def png(fig: Figure) -> bytes:
    """The figure as PNG bytes."""
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
    return buf.getvalue()


def nice(x: float) -> float:
    """1, 2 or 5 times a power of ten, not above x (x > 0)."""
    e = 10.0 ** math.floor(math.log10(x))
    return max(m for m in (1.0, 2.0, 5.0) if m * e <= x * (1 + 1e-9)) * e


@dataclass(frozen=True)
class StripFrame:
    """A strip's own map axes: ``origin`` (map x, y) and ``u`` the unit flight direction (map axes).

    Strip coordinates: ``s`` along the flight direction and ``v`` to its left (m): a rotation of the
    map, so a plot of (s, v) is the strip seen from above with the flight running to the right.
    """

    origin: np.ndarray
    u: np.ndarray
    footprint: np.ndarray

    def to_strip(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        dx, dy = np.asarray(x) - self.origin[0], np.asarray(y) - self.origin[1]
        return dx * self.u[0] + dy * self.u[1], -dx * self.u[1] + dy * self.u[0]

    def rotate(self, dx, dy) -> tuple[np.ndarray, np.ndarray]:
        return dx * self.u[0] + dy * self.u[1], -dx * self.u[1] + dy * self.u[0]


def residual_map(frame: StripFrame, vectors: list[ResidualVectors], titles: list[str], strip_id: str) -> bytes:
    """Residual vectors (ground error at the check points) over the footprint, one panel per variant.

    Drawn in the strip's own axes (flight to the right). All panels share one exaggeration, chosen
    so that the 95th percentile of the arrows is about a third of the swath.
    """
    fs, fv = frame.to_strip(frame.footprint[:, 0], frame.footprint[:, 1])
    swath = float(np.ptp(fv)) or 1.0
    lengths = np.concatenate([np.hypot(v.dx_m, v.dy_m) for v in vectors])
    lengths = lengths[np.isfinite(lengths)]
    p95 = max(float(np.percentile(lengths, 95)) if lengths.size else 1.0, 1e-3)
    exaggeration = nice(swath / 3.0 / p95)
    key_m = nice(p95)
    fig = Figure(figsize=(12, 0.6 + 2.6 * len(vectors)))
    for k, (v, title) in enumerate(zip(vectors, titles)):
        ax = fig.add_subplot(len(vectors), 1, k + 1)
        ax.fill(fs / 1e3, fv / 1e3, color="#e8e8e8", ec="#999999", lw=0.8)
        s, w = frame.to_strip(v.x, v.y)
        ds, dw = frame.rotate(v.dx_m, v.dy_m)
        ok = np.isfinite(ds) & np.isfinite(dw)
        ax.plot(s / 1e3, w / 1e3, "k.", ms=3)
        if ok.any():
            q = ax.quiver(s[ok] / 1e3, w[ok] / 1e3, ds[ok] * exaggeration / 1e3, dw[ok] * exaggeration / 1e3,
                          angles="xy", scale_units="xy", scale=1.0, width=0.0025,
                          color=np.where(v.flagged[ok], "#d62728", "#1f4e9c"))
            # the key in the empty band below the footprint (the y limits leave 0.4 swath there), clear of the
            # title however narrow the panel (a short strip drawn at equal scale)
            ax.quiverkey(q, 0.97, 0.07, key_m * exaggeration / 1e3, f"{key_m:g} m (x{exaggeration:g})",
                         labelpos="W", coordinates="axes", fontproperties={"size": 8})
        ax.set_title(title, fontsize=9, loc="left")
        ax.set_aspect("equal")
        ax.set_ylim((fv.min() - 0.4 * swath) / 1e3, (fv.max() + 0.4 * swath) / 1e3)
        ax.tick_params(labelsize=7)
        ax.set_ylabel("left of track (km)", fontsize=8)
        ax.grid(alpha=0.25)
    fig.axes[-1].set_xlabel("along the flight direction (km)", fontsize=8)
    fig.suptitle(f"strip {strip_id}: check-point residual vectors on the ground, flight to the right (red: flagged)",
                 fontsize=10)
    fig.tight_layout()
    return png(fig)


def rms_chart(strips: list[str], variants: list[str], across: dict[str, list[float | None]],
              reference: str, colours: dict[str, str] | None = None) -> bytes:
    """Grouped bars: check-point rms across track (px) per strip, one bar per variant."""
    fig = Figure(figsize=(9, 3.6))
    ax = fig.add_subplot(1, 1, 1)
    width = 0.8 / max(len(variants), 1)
    for i, name in enumerate(variants):
        vals = [np.nan if a is None else a for a in across[name]]
        ax.bar(np.arange(len(strips)) + (i - (len(variants) - 1) / 2) * width, vals, width * 0.95,
               label=name + (" (ref.)" if name == reference else ""), color=(colours or {}).get(name, colour(i)))
    ax.set_xticks(np.arange(len(strips)), [f"strip {s}" for s in strips])
    ax.set_ylabel("rms across track (px)")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8, ncol=min(len(variants), 7), loc="upper center", bbox_to_anchor=(0.5, -0.12))
    ax.set_title("check points: rms across track per strip and variant", fontsize=10)
    return png(fig)


_COMPONENTS = (("x", "m"), ("y", "m"), ("z", "m"), ("roll", "deg"), ("pitch", "deg"), ("heading", "deg"))


def correction_plot(strip_id: str, series: dict[str, Series], breaks: list[float],
                    colours: dict[str, str] | None = None) -> bytes:
    """The applied correction (adjusted - measured) of a strip over time: 6 panels, a line per variant."""
    fig = Figure(figsize=(11, 5.5))
    for c, (name, unit) in enumerate(_COMPONENTS):
        ax = fig.add_subplot(2, 3, c + 1)
        for i, (variant, s) in enumerate(series.items()):
            v = s.values[:, c] if c < 3 else np.degrees(s.values[:, c])
            ax.plot(s.time, v, lw=1.0, color=(colours or {}).get(variant, colour(i)), label=variant)
        for b in breaks:
            ax.axvline(b, color="k", ls=":", lw=0.8)
        ax.set_title(f"{name} ({unit})", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        if c >= 3:
            ax.set_xlabel("time since the first line (s)", fontsize=8)
    fig.axes[0].legend(fontsize=7, ncol=2)
    fig.suptitle(f"strip {strip_id}: correction of the GPS/IMU (adjusted - measured; dotted: breaks)", fontsize=10)
    fig.tight_layout()
    return png(fig)


def height_correction_plot(strip_id: str, series: dict[str, Series], height: Series, truth: Series | None,
                           breaks: list[float], colours: dict[str, str] | None = None) -> bytes:
    """Z correction of the variants together with the GPS/IMU height's deviation from its mean."""
    fig = Figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 1, 1)
    h = height.values[:, 2]
    ax.plot(height.time, h - h.mean(), color="#bbbbbb", lw=2.5,
            label=f"GPS/IMU height - mean flight height ({h.mean():.0f} m)")
    if truth is not None:
        ax.plot(
            truth.time, -truth.values[:, 2], color="k", lw=1.0, ls="--", label="- injected GPS height error (truth)"
        )
    for i, (variant, s) in enumerate(series.items()):
        ax.plot(
            s.time,
            s.values[:, 2],
            lw=1.3,
            color=(colours or {}).get(variant, colour(i)),
            label=f"Z correction {variant}",
        )
    for b in breaks:
        ax.axvline(b, color="k", ls=":", lw=0.8)
    ax.set_xlabel("time since the first line (s)")
    ax.set_ylabel("m")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    ax.set_title(f"problem strip {strip_id}: Z corrections and the GPS/IMU height", fontsize=10)
    return png(fig)


def tracks_map(tracks: dict[str, Series], footprints: dict[str, np.ndarray]) -> bytes:
    """Map of the strips: footprints, GPS/IMU tracks over the image, flight direction arrows."""
    fig = Figure(figsize=(7, 7))
    ax = fig.add_subplot(1, 1, 1)
    for i, (sid, s) in enumerate(tracks.items()):
        x, y = s.values[:, 0], s.values[:, 1]
        if sid in footprints:
            f = footprints[sid]
            ax.fill(f[:, 0], f[:, 1], color=colour(i), alpha=0.12, ec=colour(i), lw=0.6)
        ax.plot(x, y, color=colour(i), lw=1.2)
        m = len(x) // 2
        ax.annotate(
            "",
            xy=(x[m + 1], y[m + 1]),
            xytext=(x[m - 25 if m > 25 else 0], y[m - 25 if m > 25 else 0]),
            arrowprops=dict(arrowstyle="-|>", color=colour(i), lw=1.5, mutation_scale=18),
        )
        ax.text(x[0], y[0], f" {sid} start", fontsize=8, color=colour(i))
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=7)
    ax.set_xlabel("map x (m)")
    ax.set_ylabel("map y (m)")
    ax.grid(alpha=0.3)
    ax.set_title("strips: footprints, GPS/IMU tracks and flight direction", fontsize=10)
    return png(fig)


def gpsimu_plot(strip_id: str, s: Series, direction: str) -> bytes:
    """GPS/IMU of a strip over the image: across-track offset, height, roll/pitch, heading."""
    fig = Figure(figsize=(11, 5.2))
    t, v = s.time, s.values
    xy = v[:, :2] - v[0, :2]
    u = xy[-1] / max(np.linalg.norm(xy[-1]), 1e-9)
    right = np.array([u[1], -u[0]])  # to the right of the flight direction
    offset = xy @ right
    panels = [
        ("offset right of the straight line (m)", [(offset - np.polyval(np.polyfit(t, offset, 1), t), "across")]),
        ("ellipsoidal height h (m)", [(v[:, 2], "h")]),
        ("roll, pitch (deg)", [(v[:, 3], "roll"), (v[:, 4], "pitch")]),
        ("heading (deg)", [(v[:, 5], "heading")]),
    ]
    for k, (title, lines) in enumerate(panels):
        ax = fig.add_subplot(2, 2, k + 1)
        for j, (vals, label) in enumerate(lines):
            ax.plot(t, vals, lw=0.9, color=colour(j), label=label)
        if len(lines) > 1:
            ax.legend(fontsize=7)
        ax.set_title(title, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        if k >= 2:
            ax.set_xlabel("time since the first line (s)", fontsize=8)
    fig.suptitle(f"strip {strip_id}: GPS/IMU as measured, flying {direction}", fontsize=10)
    fig.tight_layout()
    return png(fig)


__all__ = [
    "StripFrame",
    "correction_plot",
    "gpsimu_plot",
    "height_correction_plot",
    "nice",
    "png",
    "residual_map",
    "rms_chart",
    "tracks_map",
]
