"""Options of ``scangeo lidar adjust``: the ``[adjustment]`` table of a laser project.toml, every key
typed (:mod:`scangeo.io.schema`; docs/formats.md "Laser projects" is generated from it)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from scangeo.errors import LidarError
from scangeo.io.schema import read, setting
from scangeo.lidar.patches import PatchOptions
from scangeo.lidar.search import METHODS

MODES = ("auto", "trajectory", "points")
MODELS = ("strip", "mission", "block")
CALIBRATE = ("boresight", "lever_arm", "range_offset", "scan_index")


@dataclass(frozen=True)
class LaserOptions:
    """Options of ``scangeo lidar adjust`` (``[adjustment]`` in project.toml; lengths in metres)."""

    mode: str = setting("auto", choices=MODES, doc="trajectory (GPS/IMU corrections), points (trajectory-free) "
                        "or auto (trajectory when every strip has one)")
    patch_search: str = setting("rows", choices=METHODS, doc="rows: row buffer of scan lines and seeded second "
                                "pass (Kager 2004); grid: cells of one fixed grid (issue 16)")
    patch_size: float = setting(6.0, gt=0, unit="m", doc="patch size (row-buffer window, grid cell)")
    min_patch_points: int = setting(13, ge=4, unit="1", doc="returns a patch keeps after snooping, at least")
    max_patch_sigma: float = setting(0.05, gt=0, unit="m", doc="a posteriori sigma of a patch's plane, at most")
    max_patch_outliers: float = setting(0.2, ge=0, le=1, unit="1",
                                        doc="share of a patch's returns data snooping may remove, at most")
    max_patch_slope_deg: float = setting(60.0, gt=0, le=90, doc="slope of a patch (roofs), at most")
    max_angle_deg: float = setting(5.0, gt=0, doc="homologous patches: angle between the normals, at most")
    max_offset: float = setting(1.0, gt=0, unit="m", doc="homologous patches: distance along the normal, at most")
    thin_cell: float = setting(40.0, gt=0, unit="m", doc="one tie patch per exposition class per square of this size")
    models: str = setting("strip", choices=MODELS, doc="GPS/IMU models: one per strip (split at its breaks), "
                          "one per mission ([[strips]] mission), or one for the block")
    breaks: dict[str, tuple[float, ...]] | None = setting(
        None, unit="s", default_doc="none",
        doc="per strip id, GPS times at which its model is split (C0-continuous sub-models)",
    )
    position_degree: int = setting(1, ge=-1, le=10, unit="1", doc="degree of the position correction polynomials")
    attitude_degree: int = setting(1, ge=-1, le=10, unit="1", doc="degree of the attitude correction polynomials")
    calibrate: tuple[str, ...] = setting(("boresight",), choices=CALIBRATE, doc="calibration unknowns to estimate")
    coefficient_sigma_m: float = setting(0.5, gt=0, doc="prior '= 0' of position coefficients of degree >= 1")
    coefficient_sigma_deg: float = setting(0.01, gt=0, doc="prior '= 0' of attitude coefficients of degree >= 1")
    #: prior sigma of the constant position terms; None: none with a trajectory, 0.3 m without one (flat
    #: patches do not determine horizontal shifts: the provisional solution keeps them near 0 unless tied)
    constant_sigma_m: float | None = setting(
        None, ge=0, default_doc="none; 0.3 without trajectory", doc="prior '= 0' of the constant position terms"
    )
    constant_sigma_deg: float = setting(0.01, ge=0, doc="prior '= 0' of the constant attitude terms (0: none)")
    snooping: bool = setting(True, doc="data snooping of the patch observations")
    critical_value: float = setting(3.29, gt=0, unit="1", doc="data snooping: critical value of |w|")
    workers: int = setting(1, ge=1, unit="1", doc="strips searched for patches at once (processes)")
    scheduler: str | None = setting(None, default_doc="none",
                                    doc="address of a Dask scheduler: the patch search runs there, a task per strip")

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise LidarError(f"mode must be one of {', '.join(MODES)}, not {self.mode!r}")
        if self.models not in MODELS:
            raise LidarError(f"models must be one of {', '.join(MODELS)}, not {self.models!r}")
        bad = sorted(set(self.calibrate) - set(CALIBRATE))
        if bad:
            raise LidarError(f"calibrate: unknown {', '.join(bad)} (known: {', '.join(CALIBRATE)})")

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
        options = read(cls, table, where, "adjustment")
        return replace(options, **{k: v for k, v in overrides.items() if v is not None})
