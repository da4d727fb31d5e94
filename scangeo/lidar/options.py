"""The patch search's settings: the ``[adjustment]`` table of a laser project.toml, every key typed
(:mod:`scangeo.io.schema`; docs/formats.md "Laser projects" is generated from it).

What is adjusted (the GPS/IMU models, their degrees and priors, the calibration unknowns, data
snooping) is a variant's (``variants.toml``, :class:`scangeo.adjustment.variants.Variant`); these
settings are the project's: how patches are found, in which mode, with how many workers."""

from __future__ import annotations

from dataclasses import dataclass, replace

from scangeo.errors import LidarError, ProjectFileError
from scangeo.io.schema import read, setting
from scangeo.lidar.patches import PatchOptions
from scangeo.lidar.search import METHODS

MODES = ("auto", "trajectory", "points")
#: Keys that are a variant's (variants.toml), not the project's: the error names where they went.
VARIANT_KEYS = ("models", "breaks", "position_degree", "attitude_degree", "calibrate", "coefficient_sigma_m",
                "coefficient_sigma_deg", "constant_sigma_m", "constant_sigma_deg", "snooping", "critical_value")


@dataclass(frozen=True)
class LaserOptions:
    """The patch search of a laser project (``[adjustment]`` in project.toml; lengths in metres)."""

    mode: str = setting("auto", choices=MODES, doc="trajectory (GPS/IMU corrections), points (trajectory-free) "
                        "or auto (trajectory when every strip has one)")
    patch_search: str = setting("rows", choices=METHODS, doc="rows: row buffer of scan lines and seeded second "
                                "pass (Kager 2004); grid: cells of one fixed grid")
    patch_size: float = setting(6.0, gt=0, unit="m", doc="patch size (row-buffer window, grid cell)")
    min_patch_points: int = setting(13, ge=4, unit="1", doc="returns a patch keeps after snooping, at least")
    max_patch_sigma: float = setting(0.05, gt=0, unit="m", doc="a posteriori sigma of a patch's plane, at most")
    max_patch_outliers: float = setting(0.2, ge=0, le=1, unit="1",
                                        doc="share of a patch's returns data snooping may remove, at most")
    max_patch_slope_deg: float = setting(60.0, gt=0, le=90, doc="slope of a patch (roofs), at most")
    max_angle_deg: float = setting(5.0, gt=0, doc="homologous patches: angle between the normals, at most")
    max_offset: float = setting(1.0, gt=0, unit="m", doc="homologous patches: distance along the normal, at most")
    thin_cell: float = setting(40.0, gt=0, unit="m", doc="one tie patch per exposition class per square of this size")
    workers: int = setting(1, ge=1, unit="1", doc="strips searched for patches at once (processes)")
    scheduler: str | None = setting(None, default_doc="none",
                                    doc="address of a Dask scheduler: the patch search runs there, a task per strip")

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise LidarError(f"mode must be one of {', '.join(MODES)}, not {self.mode!r}")

    @property
    def patches(self) -> PatchOptions:
        return PatchOptions(
            self.patch_size,
            self.min_patch_points,
            self.max_patch_sigma,
            max_rejected=self.max_patch_outliers,
            max_angle_deg=self.max_angle_deg,
            max_offset=self.max_offset,
            thin_cell=self.thin_cell,
            max_slope_deg=self.max_patch_slope_deg,
        )

    @classmethod
    def from_table(cls, table: dict, where: str, **overrides) -> LaserOptions:
        """The ``[adjustment]`` table (every key checked; errors ``FILE [adjustment.key]: ...``), then
        ``overrides`` (None: keep)."""
        moved = [k for k in table if k in VARIANT_KEYS]
        if moved:
            raise ProjectFileError(f"{where} [adjustment.{moved[0]}]: a key of the variants (variants.toml "
                                   "[variants.NAME], docs/formats.md), not of the project")
        options = read(cls, table, where, "adjustment")
        return replace(options, **{k: v for k, v in overrides.items() if v is not None})
