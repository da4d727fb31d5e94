"""Figures of a simulated block (matplotlib): one strip's image with its points, and its GPS/IMU errors.

``strip_figure(project_dir, strip_id, path)`` reads only the written files (project, images, truth/),
so it shows what a user gets on disk.
"""
from __future__ import annotations

import csv
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from scangeo.atomic import atomic_path
from scangeo.trajectory import read_trajectory_csv

KIND_STYLE = {"E": ("^", "gold", "control"), "B": ("s", "orange", "break band"), "K": ("o", "white", "check"),
              "H": ("D", "deepskyblue", "height"), "T": ("+", "red", "tie")}


def _false_colour(path: Path, step: int) -> np.ndarray:
    import rasterio

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(path) as src:
            rgb = src.read([7, 5, 3], out_shape=(3, src.height // step, src.width // step)).astype(float)
    rgb = np.moveaxis(rgb, 0, -1)
    lo, hi = np.percentile(rgb, 1, axis=(0, 1)), np.percentile(rgb, 99, axis=(0, 1))
    return np.clip((rgb - lo) / np.maximum(hi - lo, 1.0), 0.0, 1.0)


def strip_figure(project_dir: str | Path, strip_id: str, path: str | Path, step: int = 4) -> Path:
    """Write a PNG: the strip's image (false colour NIR/red/green, every ``step``-th pixel) with its
    measured points, and its injected GPS/IMU errors over time (position m, attitude deg, and the
    measured height's deviation from the mean flight height)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    root = Path(project_dir)
    info = json.loads((root / "truth" / "errors.json").read_text())
    errors = np.genfromtxt(root / "truth" / f"errors_{strip_id}.csv", delimiter=",", names=True)
    measured = read_trajectory_csv(root / "nav" / f"{strip_id}.csv")
    true = read_trajectory_csv(root / "truth" / f"trajectory_{strip_id}.csv")
    with open(root / "truth" / "points.csv", newline="") as f:
        kinds = {r["point"]: r["kind"] for r in csv.DictReader(f)}
    with open(root / "points.csv", newline="") as f:
        pts = [r for r in csv.DictReader(f) if r["strip"] == strip_id]
    scenario = json.loads((root / "truth" / "scenario.json").read_text())
    plan = next(s for s in scenario["strips"] if s["strip_id"] == strip_id)
    t_line = plan["first_line_time"] + np.arange(plan["lines"]) / scenario["config"]["sensor"]["line_rate_hz"]

    image_path = next((root / "images").glob(f"{strip_id}.*"))
    rgb = _false_colour(image_path, step)
    fig = plt.figure(figsize=(13, 9), constrained_layout=True)
    grid = fig.add_gridspec(4, 3)
    ax_img = fig.add_subplot(grid[:, 0])
    ax_img.imshow(rgb, extent=(-0.5, rgb.shape[1] * step - 0.5, rgb.shape[0] * step - 0.5, -0.5), aspect="auto",
                  interpolation="nearest")
    for kind, (marker, colour, label) in KIND_STYLE.items():
        sel = [r for r in pts if kinds.get(r["point"]) == kind]
        if sel:
            style: dict[str, Any] = dict(c=colour) if marker == "+" else dict(facecolors="none", edgecolors=colour)
            ax_img.scatter([float(r["pixel"]) for r in sel], [float(r["line"]) for r in sel], marker=marker,
                           s=18, linewidths=1.0, label=label, **style)
    ax_img.set_xlabel("pixel")
    ax_img.set_ylabel("line")
    ax_img.set_title(f"strip {strip_id}: bands 7/5/3 (NIR/red/green)")
    ax_img.legend(loc="lower left", fontsize=7, framealpha=0.7)

    lines_axis = (errors["time"] - plan["first_line_time"]) * scenario["config"]["sensor"]["line_rate_hz"]
    breaks = info["breaks_lines"] if info.get("problem_strip") == strip_id else []
    panels = [
        ("GPS position error (m)", [("total_x_m", "east"), ("total_y_m", "north"), ("total_z_m", "up")]),
        ("IMU attitude error (deg)", [("total_roll_deg", "roll"), ("total_pitch_deg", "pitch"),
                                      ("total_heading_deg", "heading")]),
        ("error terms, up (m)", [("shift_z_m", "datum shift"), ("drift_z_m", "drift"),
                                 ("excursion_z_m", "excursion"), ("height_wander_z_m", "wander"),
                                 ("random_walk_z_m", "random walk")]),
    ]
    for row, (title, series) in enumerate(panels):
        ax = fig.add_subplot(grid[row, 1:])
        for name, label in series:
            ax.plot(lines_axis, errors[name], lw=0.8, label=label)
        ax.set_ylabel(title, fontsize=8)
        ax.legend(fontsize=7, ncol=len(series), loc="upper left")
        for b in breaks:
            ax.axvline(b, color="k", ls=":", lw=0.8)
        ax.grid(alpha=0.3)
    ax = fig.add_subplot(grid[3, 1:])
    in_strip = (measured.time >= t_line[0]) & (measured.time <= t_line[-1])
    mean_h = measured.h[in_strip].mean()
    ax.plot(lines_axis, measured.h - mean_h, lw=0.8, label="GPS/IMU (measured)")
    ax.plot(lines_axis, true.h - mean_h, lw=0.8, label="true flight")
    for b in breaks:
        ax.axvline(b, color="k", ls=":", lw=0.8)
    ax.set_ylabel("height - mean flight height (m)", fontsize=8)
    ax.set_xlabel("image line (dotted: breaks of the problem strip)" if breaks else "image line")
    ax.legend(fontsize=7, loc="upper left")
    ax.grid(alpha=0.3)
    fig.suptitle(f"{scenario['config']['block']['name']}: strip {strip_id}, injected GPS/IMU errors over time")
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90)
    plt.close(fig)
    return path
