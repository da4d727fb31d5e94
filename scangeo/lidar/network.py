"""Network design of a 1D strip adjustment: a block of parallel strips, cross strips, control areas.

A regular block: ``n_strips`` parallel strips flown north-south (x east, y north, metres), spaced
``swath * (1 - overlap)``, of length ``length``; ``n_cross`` east-west cross strips evenly spread
along the block. Tie areas sit in every side overlap every ``tie_spacing`` metres and at every
crossing of a cross strip with a parallel strip; a control area is seen by every strip covering it.
The precision of the strip offsets then follows from the configuration alone
(:func:`scangeo.lidar.strip_adjustment.offset_covariance`: the engine's selected inverse), and so do the
areas' redundancy numbers and minimal detectable blunders (:func:`area_reliability`, the engine's
reliability that the image block's planning, :mod:`scangeo.adjustment.planning`, reports too).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from scangeo.atomic import atomic_path
from scangeo.errors import OptionsError
from scangeo.io.schema import check, setting
from scangeo.lidar.strip_adjustment import ControlArea, Strip, TieArea, design_reliability, offset_covariance


@dataclass(frozen=True)
class BlockLayout:
    """A regular block (metres). Control positions are ``(x, y)`` pairs.

    Parameters
    ----------
    n_strips : int
        Number of parallel (north-south) strips, >= 1.
    n_cross : int
        Number of east-west cross strips, >= 0.
    length, swath : float
        Strip length and swath width, m.
    overlap : float
        Side overlap of neighbouring strips, a fraction in [0, 1).
    tie_spacing : float
        Spacing of the tie areas along an overlap, m.
    sigma_tie, sigma_control : float
        Standard deviation of a tie area's height difference and of a control area's height, m.

    Raises
    ------
    OptionsError
        A field out of range (``BlockLayout.sigma_tie: expected a number > 0 (m), found -0.03``).
    """

    schema_error: ClassVar[type[Exception]] = OptionsError

    n_strips: int = setting(21, unit="1", ge=1, doc="parallel strips")
    n_cross: int = setting(4, unit="1", ge=0, doc="cross strips")
    length: float = setting(20000.0, unit="m", gt=0, doc="strip length")
    swath: float = setting(1000.0, unit="m", gt=0, doc="swath width")
    overlap: float = setting(0.3, unit="1", ge=0, lt=1, doc="side overlap fraction")
    tie_spacing: float = setting(1000.0, unit="m", gt=0, doc="tie areas' spacing along an overlap")
    sigma_tie: float = setting(0.03, unit="m", gt=0, doc="tie area sigma")
    sigma_control: float = setting(0.03, unit="m", gt=0, doc="control area sigma")

    def __post_init__(self) -> None:
        check(self)

    @property
    def spacing(self) -> float:
        return self.swath * (1.0 - self.overlap)

    @property
    def width(self) -> float:
        return (self.n_strips - 1) * self.spacing

    def corner_controls(self) -> list[tuple[float, float]]:
        """Four control areas near the block corners (inside the outer strips)."""
        return [(x, y) for x in (0.0, self.width) for y in (0.0, self.length)]

    def ends_controls(self, every: int = 4) -> list[tuple[float, float]]:
        """Control areas at both strip ends of every ``every``-th strip (and of the last one)."""
        idx = sorted(set(range(0, self.n_strips, every)) | {self.n_strips - 1})
        return [(i * self.spacing, y) for i in idx for y in (0.0, self.length)]


def build_block(
    layout: BlockLayout, controls: list[tuple[float, float]]
) -> tuple[list[Strip], list[TieArea], list[ControlArea]]:
    """Strips, tie areas and control areas (observations zero) of a regular block (its layout checked
    itself: :class:`BlockLayout`)."""
    strips = [Strip(f"L{i + 1}", i * layout.spacing, layout.length / 2, 0.0) for i in range(layout.n_strips)]
    cross_y = (np.arange(layout.n_cross) + 0.5) * layout.length / max(layout.n_cross, 1)
    strips += [Strip(f"Q{k + 1}", layout.width / 2, float(y), np.pi / 2) for k, y in enumerate(cross_y)]
    ties: list[TieArea] = []
    n_along = max(int(round(layout.length / layout.tie_spacing)), 1)
    ys = (np.arange(n_along) + 0.5) * layout.length / n_along
    for i in range(layout.n_strips - 1):
        x = (i + 0.5) * layout.spacing
        ties += [TieArea(i, i + 1, x, float(y), sigma=layout.sigma_tie) for y in ys]
    for k, y in enumerate(cross_y):
        ties += [
            TieArea(layout.n_strips + k, i, i * layout.spacing, float(y), sigma=layout.sigma_tie)
            for i in range(layout.n_strips)
        ]
    ctl: list[ControlArea] = []
    for x, y in controls:
        for s, strip in enumerate(strips):
            u, v = strip.along_across(np.asarray(x), np.asarray(y))
            half_length = (layout.width if s >= layout.n_strips else layout.length) / 2
            if abs(v) <= layout.swath / 2 and abs(u) <= half_length + 1e-6:
                ctl.append(ControlArea(s, x, y, sigma=layout.sigma_control))
    return strips, ties, ctl


def offset_precision(layout: BlockLayout, controls: list[tuple[float, float]], tilts: bool = False) -> np.ndarray:
    """Standard deviation (m) of each strip offset (parallel strips first, then cross strips)."""
    strips, ties, ctl = build_block(layout, controls)
    return np.sqrt(offset_covariance(strips, ties, ctl, tilts=tilts)[:, 0, 0])


def area_reliability(layout: BlockLayout, controls: list[tuple[float, float]], tilts: bool = False) -> dict:
    """Redundancy numbers and MDBs (m) of the tie areas and of the control areas of a regular block.

    Returns ``{"tie areas": {"redundancy": (m,), "mdb_m": (m,)}, "control areas": {...}}`` (areas in the
    order of :func:`build_block`; an uncontrolled area has MDB inf).
    """
    strips, ties, ctl = build_block(layout, controls)
    rel = design_reliability(strips, ties, ctl, tilts=tilts)
    return {g.name: {"redundancy": r, "mdb_m": m} for g, r, m in zip(rel.groups, rel.redundancy, rel.mdb)}


def design_scenarios(layout: BlockLayout) -> dict[str, np.ndarray]:
    """Offset precision (m) of the parallel strips for the standard comparison of configurations."""
    no_cross = BlockLayout(**{**layout.__dict__, "n_cross": 0})
    return {
        f"{layout.n_strips} strips, no cross strips, 4 corner controls": offset_precision(
            no_cross, no_cross.corner_controls()
        )[: layout.n_strips],
        f"{layout.n_strips} strips, {layout.n_cross} cross strips, 4 corner controls": offset_precision(
            layout, layout.corner_controls()
        )[: layout.n_strips],
        f"{layout.n_strips} strips, {layout.n_cross} cross strips, "
        "controls at both ends of every 4th strip": offset_precision(
            layout, layout.ends_controls(4)
        )[: layout.n_strips],
    }


def plot_design(layout: BlockLayout, path: str) -> dict[str, np.ndarray]:
    """Plot the block layout and the offset precision per strip of :func:`design_scenarios` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenarios = design_scenarios(layout)
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [1, 1.4]})
    strips, ties, _ = build_block(layout, [])
    for s in strips[: layout.n_strips]:
        ax0.plot([s.x0, s.x0], [0, layout.length], color="0.6", lw=4, alpha=0.5)
    for s in strips[layout.n_strips :]:
        ax0.plot([0, layout.width], [s.y0, s.y0], color="tab:orange", lw=4, alpha=0.6)
    ax0.plot([t.x for t in ties], [t.y for t in ties], "k.", ms=2, label="tie areas")
    for xy, marker, label in (
        (layout.corner_controls(), "^", "corner controls"),
        (layout.ends_controls(4), "v", "end controls (every 4th strip)"),
    ):
        ax0.plot(*np.array(xy).T, marker, ms=8, mfc="none", label=label)
    ax0.set_xlabel("x (m)")
    ax0.set_ylabel("y (m)")
    ax0.set_title(f"{layout.n_strips} strips, {layout.n_cross} cross strips")
    ax0.legend(fontsize=7, loc="upper right")
    for name, sig in scenarios.items():
        ax1.plot(np.arange(1, layout.n_strips + 1), 100 * sig, "o-", ms=3, label=name)
    ax1.set_xlabel("strip")
    ax1.set_ylabel("sigma of strip offset (cm)")
    ax1.set_title(f"tie sigma {100 * layout.sigma_tie:g} cm, control sigma {100 * layout.sigma_control:g} cm")
    ax1.legend(fontsize=7)
    ax1.grid(alpha=0.3)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
    return scenarios
