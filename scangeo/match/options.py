"""Settings of automatic point measurement: a typed frozen dataclass, readable from a TOML table.

A ``[match]`` table (in a separate settings file given with ``--config``) holds the keys of
:class:`MatchOptions`, a settings dataclass of :mod:`scangeo.io.schema`: every key's type and range is
checked, and an error names the file and the key.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

from scangeo.errors import OptionsError
from scangeo.io.schema import Rule, check, read, setting

#: wavelength range of the default matching bands, nm: every reflective band, never thermal (averaging
#: the 10 reflective Daedalus bands halves the noise of 6 visible ones: 0.127 against 0.180 px true rms
#: on a small block with 25 DN noise, docs/match.md)
DEFAULT_BAND_RANGE_NM = (400.0, 2500.0)


@dataclass(frozen=True)
class MatchOptions:
    """How points are measured (docs/match.md; the ``[match]`` table of the settings file).

    Built in Python or read from a file, every field is checked the same way (:mod:`scangeo.io.schema`).

    Parameters
    ----------
    per_overlap : int
        Target number of tie points per overlap of two strips.
    per_cell : int
        Target number of points per cell; the overlap is cut into ``per_overlap / per_cell`` cells of
        equal area, so points spread evenly.
    control_per_strip : int
        Target number of control (and check) points per strip and reference.
    check_share : float
        Share of the control points held back as role ``check`` (every n-th point), in [0, 1).
    template_px : int
        Side of the matching template, chip cells (odd).
    search_px : int
        Search radius around the predicted position, chip cells (the DG orientation's relative error
        between strips must stay inside it).
    min_correlation : float
        Smallest accepted normalised cross-correlation peak.
    max_second_peak : float
        Largest accepted ratio of the second-best peak (away from the best) to the best.
    max_sigma_px : float
        Largest accepted least-squares matching sigma, chip cells.
    ransac_px : float
        Inlier threshold of the local affine consistency test, chip cells.
    neighbours : int
        Points per local affine fit of the consistency test.
    min_sigma_px : float
        Smallest ``sigma_px`` written for a measurement, image pixels.
    smooth_cells : float
        Gaussian sigma applied to every chip before matching, cells (0: none); damps aliasing of images
        sampled without an optical blur.
    bands : tuple of int
        1-based strip bands averaged into the matching image (empty: the project's bands between 400
        and 2500 nm, else all bands but a thermal one).
    reference_bands : tuple of int
        1-based bands of the reference orthoimage (empty: all, at most the first 3).
    resolution : float or None
        Chip cell size, map units (None: the strips' nadir ground pixel).
    id_prefix : str
        First letter(s) of matched point ids (``<prefix>T_`` ties, ``<prefix>C_`` control and check).
    seed : int
        Seed of the choice of check points.

    Raises
    ------
    OptionsError
        A field of the wrong type or out of range (``MatchOptions.template_px: expected an integer >= 7,
        odd (cell), found 8``).
    """

    schema_error: ClassVar[type[Exception]] = OptionsError

    per_overlap: int = setting(60, ge=1, unit="1", doc="target number of tie points per overlap")
    per_cell: int = setting(2, ge=1, unit="1", doc="target number of points per cell")
    control_per_strip: int = setting(30, ge=0, unit="1", doc="target control and check points per strip and reference")
    check_share: float = setting(0.3, ge=0, lt=1, unit="1", doc="share of the control points held back as check")
    template_px: int = setting(25, ge=7, rule=Rule(lambda v: v % 2 == 1, "odd"), unit="cell",
                               doc="side of the matching template")
    search_px: int = setting(16, ge=1, unit="cell", doc="search radius around the predicted position")
    min_correlation: float = setting(0.7, gt=-1, lt=1, unit="1", doc="smallest accepted correlation peak")
    max_second_peak: float = setting(0.99, gt=0, le=1, unit="1",
                                     doc="largest accepted second local maximum, as a share of the peak")
    max_sigma_px: float = setting(0.5, gt=0, unit="cell", doc="largest accepted least-squares matching sigma")
    ransac_px: float = setting(1.0, gt=0, unit="cell", doc="inlier threshold of the local affine consistency test")
    neighbours: int = setting(12, ge=4, unit="1", doc="matches per local affine fit")
    min_sigma_px: float = setting(0.1, gt=0, unit="px", doc="smallest sigma_px written for a measurement")
    smooth_cells: float = setting(1.0, ge=0, le=5, unit="cell", doc="Gaussian sigma applied to the chips")
    bands: tuple[int, ...] = setting((), ge=1, default_doc="bands of 400-2500 nm, never thermal",
                                     doc="1-based strip bands averaged into the matching image")
    reference_bands: tuple[int, ...] = setting((), ge=1, default_doc="the first 3",
                                               doc="1-based bands of the reference orthoimage")
    resolution: float | None = setting(None, gt=0, rule=Rule(math.isfinite, "finite"), unit="map unit",
                                       default_doc="nadir ground pixel",
                                       doc="chip cell size")
    id_prefix: str = setting("M", rule=Rule(lambda v: bool(v) and v.isalnum(), "letters or digits"),
                             doc="first letters of matched point ids")
    seed: int = setting(0, unit="1", doc="seed of the choice of check points")

    def __post_init__(self) -> None:
        check(self)

    @property
    def tie_prefix(self) -> str:
        """The start of matched tie point ids.

        Returns
        -------
        str
            ``id_prefix`` + ``T_``.
        """
        return f"{self.id_prefix}T_"

    @property
    def control_prefix(self) -> str:
        """The start of matched control and check point ids.

        Returns
        -------
        str
            ``id_prefix`` + ``C_``.
        """
        return f"{self.id_prefix}C_"

    def replace(self, **changes) -> MatchOptions:
        """These options with some fields changed (checked as when built).

        Parameters
        ----------
        **changes
            Field -> new value.

        Returns
        -------
        MatchOptions
            A new instance.
        """
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_dict(cls, table: dict, source: str = "match options") -> MatchOptions:
        """Options from a parsed ``[match]`` TOML table; every key checked (:mod:`scangeo.io.schema`).

        Parameters
        ----------
        table : dict
            The table's keys and values.
        source : str
            The file's name, for errors (``source [match.KEY]: expected ..., found ...``).

        Returns
        -------
        MatchOptions
            The options.

        Raises
        ------
        OptionsError
            An unknown key, or a value of the wrong type or out of range.
        """
        return read(cls, table, source, "match")
