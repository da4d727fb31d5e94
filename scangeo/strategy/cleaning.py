"""Clean first: find the blunders among a project's measurements before anything decides with them.

:func:`clean` adjusts the whole block once, robustly, in a model flexible enough that a GPS/IMU drift
is not taken for blunders, and removes blunders by data snooping (Baarda's iterative w-test, the
engine's :class:`~scangeo.lsq.engine.SnoopingOptions`, with the separability check of
:mod:`scangeo.lsq.separability`):

* **the model**: every strip split into pieces of about ``piece_lines`` lines, each with a linear
  position correction (C0 at the joins: a piecewise-linear GPS/IMU drift with a kink every piece) and
  a constant attitude correction, the tie points carrying DTM heights, the coefficients regularised
  as in the default variants. A drift of the problem strip with kinks (the reference case: +-20 m in
  height) is followed to within the noise, so its residuals are not blunders; a 10-40 px blunder of
  one measurement is not followed by a piece that holds dozens of measurements;
* **the check points** enter as control points: their measurements and coordinates are tested too
  (a blunder there would otherwise spoil the comparison's figures unseen). Cleaning only decides what
  is set aside; the variants later adjusted never use check points;
* **the method**: data snooping at the critical value 3.29 (alpha0 = 0.1 %), several units of
  distinct points per round. A blunder the adjustment cannot attribute to one measurement (a tie point
  in two strips, a control point measured once) removes every measurement of its point, reported as
  not separable.

What it removes is written to ``PROJECT/results/cleaning/rejected.csv`` (:mod:`scangeo.io.rejected`)
and ``cleaning.json``; every later adjustment sets those measurements aside (``read_measurements``),
until ``scangeo clean PROJECT --restore`` (:func:`restore`) deletes the files. Measured and argued in
docs/adjustment.md ("Cleaning").
"""
from __future__ import annotations

import json
import logging
import math
import shutil
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import ClassVar

import numpy as np

from scangeo.adjustment.block import Block, adjust_block, build_block
from scangeo.adjustment.ground import DtmHeights, GroundControl
from scangeo.adjustment.image import ImageObservations
from scangeo.adjustment.results import read_measurements
from scangeo.adjustment.variants import StripModels, Variant
from scangeo.atomic import write_text
from scangeo.errors import OptionsError
from scangeo.io.points import GroundPoints
from scangeo.io.project import Project
from scangeo.io.rejected import CLEANING_DIR, RejectedMeasurement, rejected_path, write_rejected
from scangeo.io.schema import check, setting
from scangeo.lsq.engine import Adjustment
from scangeo.lsq.reliability import delta0
from scangeo.lsq.statistics import MIN_REDUNDANCY
from scangeo.progress import ProgressCallback, no_progress, scaled

log = logging.getLogger(__name__)

METHODS = ("snooping",)


@dataclass(frozen=True)
class CleaningOptions:
    """How :func:`clean` adjusts and tests (module docstring; the ``[clean]`` table of the settings file).

    Built in Python or read from a file, every field is checked the same way (:mod:`scangeo.io.schema`).

    Parameters
    ----------
    method : str
        How blunders are found: ``snooping`` (Baarda's iterative w-test).
    piece_lines : float
        Length of the pieces every strip's GPS/IMU model is split into, image lines.
    min_pieces : int
        A strip is split into at least this many pieces (a short strip's drift still gets kinks: one
        700-line piece over a 600-line strip is as stiff as P1).
    position_degree : int
        Degree of each piece's position correction (1: piecewise linear).
    critical_value : float
        Critical value of Baarda's |w| (3.29: alpha0 = 0.1 %, two-sided).
    per_round : int
        Units of distinct points removed per re-solution.
    max_fraction : float
        At most this share of the image measurements is removed (a stop for a hopeless project: more
        blunders than that say the model or the sigmas are wrong, not the points).
    dtm_heights : bool
        Tie points carry DTM heights (without them a blunder across track in one ray of a tie point
        seen in two strips moves only the point's height: undetectable).
    dtm_sigma_factor : float
        The DTM heights' sigma is the project's times this (above 1: the DTM's own errors trip the test
        less often; measured in docs/adjustment.md).
    dtm_height_points : tuple of str
        Glob patterns of the tie points on open terrain (DTM heights).
    check_as_control : bool
        Test the check points too (as control points of the cleaning adjustment).
    constant_sigma_m : float
        Sigma of the pseudo-observation "= 0" of every piece's constant position terms, metres.

    Raises
    ------
    OptionsError
        A field of the wrong type or out of range (``CleaningOptions.piece_lines: expected a number > 0
        (line), found 0``).
    """

    schema_error: ClassVar[type[Exception]] = OptionsError

    method: str = setting("snooping", choices=METHODS, doc="how blunders are found")
    piece_lines: float = setting(700.0, gt=0, unit="line", doc="length of the pieces of the flexible model")
    min_pieces: int = setting(3, ge=1, unit="1", doc="a strip is split into at least this many pieces")
    position_degree: int = setting(1, ge=0, le=10, unit="1", doc="degree of each piece's position correction")
    critical_value: float = setting(3.29, gt=0, unit="1", doc="critical value of Baarda's |w| (3.29: alpha0 = 0.1 %)")
    per_round: int = setting(4, ge=1, unit="1", doc="units of distinct points removed per re-solution")
    max_fraction: float = setting(0.2, gt=0, le=1, unit="1",
                                  doc="at most this share of the image measurements is removed")
    dtm_heights: bool = setting(True, doc="tie points carry DTM heights")
    dtm_sigma_factor: float = setting(1.0, gt=0, unit="1", doc="the DTM heights' sigma is the project's times this")
    dtm_height_points: tuple[str, ...] = setting(("*",), doc="glob patterns of the tie points on open terrain")
    check_as_control: bool = setting(True, doc="test the check points too (as control points)")
    constant_sigma_m: float = setting(5.0, gt=0, doc="pseudo-observation of the constant terms of the pieces")

    def __post_init__(self) -> None:
        check(self)


@dataclass(frozen=True)
class Cleaning:
    """The result of :func:`clean`: what was set aside, and the cleaning adjustment's figures.

    Parameters
    ----------
    project : str
        The project folder.
    rejected : tuple of RejectedMeasurement
        Every measurement set aside: kind (image or ground), point, strip, w, MDB, separability, reason.
    sigma0_before, sigma0_after : float
        sigma0 of the cleaning adjustment's first solution and after the snooping.
    model : str
        The flexible model in words.
    n_image, n_ground : int
        Image measurements and ground points in the cleaning adjustment.
    options : CleaningOptions
        The options used.
    dtm_rejected : tuple of str
        Tie points whose DTM height alone was rejected (not set aside; named for the user).
    notes : tuple of str
        Remarks (the snooping stopped at its limit, ...).
    mdb : dict
        MDB of every image measurement of the cleaning adjustment, pixels, by ``(point, strip)``.
    """

    project: str
    rejected: tuple[RejectedMeasurement, ...]
    sigma0_before: float
    sigma0_after: float
    model: str
    n_image: int
    n_ground: int
    options: CleaningOptions = field(default_factory=CleaningOptions)
    #: DTM heights the snooping rejected alone (tie points off open terrain, or the DTM's own error): not set
    #: aside (later variants choose their DTM heights themselves), named here
    dtm_rejected: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    #: MDB (pixels) of every image measurement of the cleaning adjustment, ``(point, strip) -> MDB``, kept
    #: and rejected (not written; a measurement absent here was not in the adjustment: MDB infinite)
    mdb: dict[tuple[str, str], float] = field(default_factory=dict, repr=False, compare=False)

    @property
    def rejected_keys(self) -> frozenset[tuple[str, str]]:
        """The measurements set aside.

        Returns
        -------
        frozenset of (str, str)
            ``(point, strip)`` of every rejected measurement (strip ``""``: the point's ground.csv
            coordinates).
        """
        return frozenset(r.key for r in self.rejected)

    @property
    def not_separable(self) -> list[str]:
        """The points removed whole because the blunder could not be attributed to one measurement.

        Returns
        -------
        list of str
            Point ids, sorted.
        """
        return sorted({r.point for r in self.rejected if not r.separable})

    def as_dict(self) -> dict:
        """What ``cleaning.json`` holds.

        Returns
        -------
        dict
            JSON-able: sigma0 before and after, the counts, every measurement set aside with w and MDB.
        """
        def num(x: float) -> float | str | None:
            return None if math.isnan(x) else ("inf" if math.isinf(x) else round(float(x), 4))

        return {"project": self.project, "method": self.options.method, "model": self.model,
                "options": asdict(self.options), "sigma0_before": num(self.sigma0_before),
                "sigma0_after": num(self.sigma0_after),
                "measurements": {"image": self.n_image, "ground": self.n_ground},
                "rejected": {"image": sum(r.kind == "image" for r in self.rejected),
                             "ground": sum(r.kind == "ground" for r in self.rejected),
                             "not_separable_points": self.not_separable},
                "dtm_heights_rejected": list(self.dtm_rejected), "notes": list(self.notes),
                "measurements_rejected": [{**dict(zip(("kind", "point", "strip"), r.row()[:3])),
                                           "w": num(r.w), "mdb": num(r.mdb), "separable": r.separable,
                                           "reason": r.reason} for r in self.rejected]}


def cleaning_variant(project: Project, options: CleaningOptions) -> Variant:
    """The flexible model of the cleaning adjustment (module docstring); on a platform the models are the
    flight lines': each split in the lines of its first image strip."""
    strips = []
    firsts = {s.flight_line: s for s in reversed(project.image_strips)}
    for s in project.image_strips:
        if firsts[s.flight_line] is not s:
            continue
        n = project.n_lines(s.id)
        k = max(options.min_pieces, round(n / options.piece_lines))
        breaks = tuple(float(round(n * i / k)) for i in range(1, k))
        strips.append(StripModels(s.id, position_degree=options.position_degree, breaks_lines=breaks))
    return Variant("cleaning", "S", f"every strip split into pieces of about {options.piece_lines:g} lines "
                   f"(at least {options.min_pieces}), "
                   f"position degree {options.position_degree} per piece"
                   + ("; DTM heights" if options.dtm_heights else "")
                   + (f" (sigma x {options.dtm_sigma_factor:g})" if options.dtm_sigma_factor != 1.0 else ""),
                   strips=tuple(strips), dtm_heights=options.dtm_heights,
                   dtm_height_points=tuple(options.dtm_height_points),
                   constant_sigma_m=options.constant_sigma_m, snooping=True, critical_value=options.critical_value,
                   rejections_per_round=options.per_round, independent_rejections=False)


def _checks_as_control(ground: GroundPoints) -> GroundPoints:
    role = np.where(ground.role == "check", "control", ground.role).astype(object)
    return replace(ground, role=role)


def _rejected(block: Block, adj: Adjustment, ground: GroundPoints
              ) -> tuple[list[RejectedMeasurement], list[str], dict[tuple[str, str], float]]:
    """Every measurement the snooping removed, with its w and MDB, the DTM heights it rejected, and the
    MDB of every image measurement. The MDBs are those of the final solution, the cleaned set's:
    ``sigma delta0 / sqrt(r)`` for a row in the adjustment, ``sigma delta0 sqrt(1 + h)`` for a row
    outside it with leverage ``h`` (its redundancy number were it put back: ``1 / (1 + h)``)."""
    sol, stats = adj.solution, adj.statistics
    h = stats.leverages
    d0 = delta0()
    why = {(r.group, r.id): (r.w, r.separable, r.note) for r in adj.rejections}
    why_point = {r.id: (r.w, r.separable, r.note) for r in adj.rejections}  # the point's other measurements
    given = {str(p): i for i, p in enumerate(ground.point)}
    out: list[RejectedMeasurement] = []
    dtm: list[str] = []
    mdb: dict[tuple[str, str], float] = {}
    for g, act, sl in zip(sol.groups, sol.active, sol.system.row_slices):
        if not isinstance(g, (ImageObservations, GroundControl, DtmHeights)):
            continue
        ids = np.asarray(g.ids).astype(str)
        hg = np.maximum(h[sl], 0.0)
        red = 1.0 - hg
        mdb_rows = np.asarray(g.sigma, float) * d0 * np.where(
            act, 1.0 / np.sqrt(np.where(red >= MIN_REDUNDANCY, red, np.nan)), np.sqrt(1.0 + hg))
        mdb_rows = np.where(np.isnan(mdb_rows), math.inf, mdb_rows)
        if isinstance(g, ImageObservations):
            per_unit = np.full(len(g.points), -math.inf)
            np.maximum.at(per_unit, g.row_unit, mdb_rows)
            mdb.update({(str(p), g.strip): float(m) for p, m in zip(g.points, per_unit)})
        for unit in np.unique(g.row_unit[~act]) if not act.all() else ():
            rows = np.flatnonzero(g.row_unit == unit)
            pid = str(ids[rows[0]])
            w, separable, note = why.get((g.name, pid)) or why_point.get(pid, (math.nan, False, "with its point"))
            unit_mdb = float(np.max(mdb_rows[rows]))
            if isinstance(g, ImageObservations):
                k = int(unit)
                out.append(RejectedMeasurement("image", pid, g.strip, float(g.line[k]), float(g.pixel[k]),
                                               w=w, mdb=unit_mdb, separable=separable, reason=note))
            elif isinstance(g, GroundControl):
                x, y, z = (float(c) for c in ground.xyz[given[pid]])
                out.append(RejectedMeasurement("ground", pid, "", xyz=(x, y, z), w=w, mdb=unit_mdb,
                                               separable=separable, reason=note))
            else:
                dtm.append(pid)
    removed = {r.point for r in out}   # a point removed whole loses its DTM height with it: not named again
    return out, sorted(set(dtm) - removed), mdb


def clean(project: Project | Path | str, options: CleaningOptions | None = None,
          progress: ProgressCallback = no_progress) -> Cleaning:
    """Find the project's blunders by a robust adjustment and set them aside (docs/adjustment.md, "Cleaning").

    Writes ``PROJECT/results/cleaning/rejected.csv`` and ``cleaning.json``; every later adjustment
    leaves those measurements out until :func:`restore` removes the folder. The measurements are read as
    the project's files give them (a previous cleaning's set-aside is ignored: cleaning starts afresh
    and replaces it).

    Parameters
    ----------
    project : str, Path or Project
        The project folder (or its project.toml), or a loaded project.
    options : CleaningOptions, optional
        How the block is adjusted and tested (default ``CleaningOptions()``; a project's ``[clean]``
        table: ``read_settings(project).clean``).
    progress : callable
        ``progress(done, total, message)``.

    Returns
    -------
    Cleaning
        Every measurement set aside (with w, MDB and separability), sigma0 before and after.

    Raises
    ------
    ProjectFileError
        A malformed project file, points.csv or ground.csv.
    AdjustmentError
        The flexible model cannot be set up or solved.
    """
    options = options or CleaningOptions()
    project = Project.from_user_input(project)
    points, ground = read_measurements(project, set_aside=False)
    variant = cleaning_variant(project, options)
    cleaning_ground = _checks_as_control(ground) if options.check_as_control else ground
    progress(0.0, 1.0, "cleaning: setting up the flexible model")
    block = build_block(project, variant, points, cleaning_ground)
    for g in block.groups:
        if isinstance(g, DtmHeights) and options.dtm_sigma_factor != 1.0:
            g.sigma = g.sigma * options.dtm_sigma_factor
    n_image = sum(g.n_rows // 2 for g in block.groups if isinstance(g, ImageObservations))
    max_rejections = max(1, int(options.max_fraction * n_image))
    # sigma0 before the cleaning is that of the adjustment's first solution, before snooping removed anything
    adj = adjust_block(block, snooping=True, callback=scaled(progress, 0.05, 1.0), max_rejections=max_rejections)
    rejected, dtm, mdb = _rejected(block, adj, cleaning_ground)
    notes = list(block.notes)
    if len(adj.rejections) >= max_rejections:
        notes.append(f"data snooping stopped at {max_rejections} rejections ({100 * options.max_fraction:g} "
                     "% of the image measurements): the model, the sigmas or the data need a look")
    n_ground = sum(len(g.points) for g in block.groups if isinstance(g, GroundControl))
    result = Cleaning(str(project.root), tuple(rejected), adj.sigma0_first,
                      float(adj.statistics.sigma0), variant.description, n_image, n_ground,
                      options, tuple(dtm), tuple(notes), mdb)
    write_cleaning(result)
    progress(1.0, 1.0, f"cleaning: {len(rejected)} measurements set aside")
    log.info("cleaning: sigma0 %.2f -> %.2f, %d measurements set aside", result.sigma0_before, result.sigma0_after,
             len(rejected))
    return result


def write_cleaning(cleaning: Cleaning) -> list[Path]:
    """``rejected.csv`` and ``cleaning.json`` in ``PROJECT/results/cleaning/``."""
    folder = Path(cleaning.project) / CLEANING_DIR
    folder.mkdir(parents=True, exist_ok=True)
    return [write_rejected(rejected_path(cleaning.project), list(cleaning.rejected)),
            write_text(folder / "cleaning.json", json.dumps(cleaning.as_dict(), indent=1) + "\n")]


def restore(project_root) -> bool:
    """Bring every set-aside measurement back: delete ``PROJECT/results/cleaning/``; False when there was none."""
    folder = Path(project_root) / CLEANING_DIR
    if not folder.exists():
        return False
    shutil.rmtree(folder)
    return True


def summary_lines(cleaning: Cleaning) -> list[str]:
    """The cleaning for the terminal: sigma0 before and after, and every measurement set aside."""
    n_image = sum(r.kind == "image" for r in cleaning.rejected)
    n_ground = len(cleaning.rejected) - n_image
    lines = [f"cleaning ({cleaning.model}): sigma0 {cleaning.sigma0_before:.2f} -> {cleaning.sigma0_after:.2f}; "
             f"set aside: {n_image} of {cleaning.n_image} image measurements, {n_ground} of {cleaning.n_ground} "
             "points' ground coordinates"]
    for r in cleaning.rejected:
        where = f"strip {r.strip} line {r.line:.1f} pixel {r.pixel:.1f}" if r.kind == "image" else "ground.csv"
        lines.append(f"  {r.point:>8} {where}: w {r.w:.1f}, MDB {r.mdb:.2g}"
                     + ("" if r.separable else f" ({r.reason})"))
    if cleaning.dtm_rejected:
        lines.append(f"  DTM heights rejected (not on open terrain?): {', '.join(cleaning.dtm_rejected)}")
    lines += [f"  note: {n}" for n in cleaning.notes]
    return lines


__all__ = ["Cleaning", "CleaningOptions", "clean", "cleaning_variant", "restore", "summary_lines", "write_cleaning"]
