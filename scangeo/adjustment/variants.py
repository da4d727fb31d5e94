"""Adjustment variants (strategies) read from ``variants.toml`` (format in docs/adjustment.md).

A variant says how GPS/IMU is corrected (strategy DG, BE, ME, SE, P, S and per-strip overrides with
degrees and break epochs), which points play which role (patterns on point ids), whether tie points
carry DTM heights, the sigmas, the regularisation, the calibration unknowns and data snooping.

One kind of variant serves both sensors. A laser project's variants are read with the laser's
defaults (:data:`LASER_DEFAULTS`: the tighter priors of Kager's strip adjustment) under the file's
``[defaults]``; without a variants.toml a laser project compares the paper's models
(``scangeo/data/laser_variants.toml``: per strip, per mission, for the block).
"""
from __future__ import annotations

import fnmatch
from collections.abc import Iterable
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

from scangeo.errors import MissingFileError, ProjectFileError
from scangeo.io.schema import check, read, setting
from scangeo.io.toml_config import load_toml

STRATEGIES = ("DG", "BE", "ME", "SE", "P", "S")
ROLES = ("control", "check", "height", "planimetric", "tie", "ignore")
#: the sensor's own calibration unknowns by kind (``scangeo.sensors.models``)
WHISKBROOM_CALIBRATION = ("index_error", "scale_error")
PUSHBROOM_CALIBRATION = ("across_offset", "across_scale", "along_offset")
#: Calibration unknowns of a line scanner and of a laser scanner.
IMAGE_CALIBRATION = ("boresight", "lever_arm", "time_offset", *WHISKBROOM_CALIBRATION, *PUSHBROOM_CALIBRATION)
LASER_CALIBRATION = ("boresight", "lever_arm", "range_offset", "index_error")
CALIBRATION = (*IMAGE_CALIBRATION, "range_offset")
#: The keys a laser variant takes by default (beneath a variants file's [defaults]): the priors of the
#: paper's strip adjustment (correction coefficients of degree >= 1 and attitude constants "= 0" within
#: 0.5 m / 0.01 deg), the boresight calibrated, data snooping 4 units a round on the linear model (engine.py).
LASER_DEFAULTS: dict[str, object] = {
    "coefficient_sigma_m": 0.5, "coefficient_sigma_deg": 0.01, "constant_sigma_deg": 0.01,
    "calibrate": ["boresight"], "rejections_per_round": 4, "independent_rejections": False, "max_iterations": 30,
    "snooping_method": "linear",
}
#: The variants file of a laser project without one (the paper's models).
LASER_VARIANTS = "laser_variants.toml"


@dataclass(frozen=True)
class StripModels:
    """Per-strip overrides: degrees, rotation, and break epochs (lines or times) of a split."""

    strip: str = setting(key="id", file_type=str | int, parse=lambda v, where: str(v),
                         doc="the strip's id in project.toml")
    position_degree: int | None = setting(None, ge=-1, le=10, unit="1", default_doc="the variant's",
                                          doc="polynomial degree of the position correction (-1: none)")
    attitude_degree: int | None = setting(None, ge=-1, le=10, unit="1", default_doc="the variant's",
                                          doc="polynomial degree of the attitude correction (-1: none)")
    rotation: bool | None = setting(None, default_doc="the variant's", doc="rigid rotation of the model's positions")
    breaks_lines: tuple[float, ...] = setting((), ge=0, unit="line", doc="image lines where the model splits")
    breaks_times: tuple[float, ...] = setting((), unit="s", doc="times where the model splits")

    def __post_init__(self) -> None:
        check(self)


@dataclass(frozen=True)
class Variant:
    """One adjustment strategy; every field is a key of a ``[variants.NAME]`` table."""

    name: str = setting(internal=True)
    strategy: str = setting("SE", choices=STRATEGIES, doc="DG, BE, ME, SE, P or S (docs/adjustment.md); ME: one "
                                                          "GPS/IMU model per mission ([[strips]] mission)")
    description: str = setting("", doc="one line for tables and reports")
    position_degree: int = setting(0, ge=-1, le=10, unit="1", doc="polynomial degree of every position model")
    attitude_degree: int = setting(0, ge=-1, le=10, unit="1", doc="polynomial degree of every attitude model")
    rotation: bool = setting(False, doc="rigid rotation of each (unsplit) model's positions")
    strips: tuple[StripModels, ...] = setting((), key="strip", doc="per-strip overrides ([[variants.NAME.strip]])")
    roles: tuple[tuple[str, str], ...] = setting((), file_type=dict[str, str], parse=lambda v, where: _roles(v, where),
                                                 default_doc="ground.csv's",
                                                 doc="glob pattern on point ids -> role, applied in order")
    dtm_heights: bool = setting(False, doc="tie points carry Z = DTM(X, Y)")
    dtm_height_points: tuple[str, ...] = setting(("*",), doc="glob patterns of the tie points with DTM heights")
    gps_sigma_m: tuple[float, float, float] = setting((0.05, 0.05, 0.10), gt=0, doc="GPS/IMU position sigma x, y, z")
    imu_sigma_deg: tuple[float, float, float] = setting((0.003, 0.003, 0.005), gt=0,
                                                        doc="GPS/IMU roll, pitch, heading sigma")
    image_sigma_px: float | None = setting(None, gt=0, default_doc="points.csv's", doc="image measurement sigma")
    coefficient_sigma_m: float = setting(10.0, gt=0, doc="pseudo-observation coefficient = 0 (degree >= 1)")
    coefficient_sigma_deg: float = setting(0.1, gt=0, doc="the same for attitude coefficients")
    constant_sigma_m: float | None = setting(None, gt=0, doc="pseudo-observation for the constant terms")
    constant_sigma_deg: float | None = setting(None, gt=0, doc="the same for attitude constants")
    calibrate: tuple[str, ...] = setting((), choices=CALIBRATION, doc="calibration unknowns")
    test_calibration: tuple[str, ...] = setting(
        (), choices=CALIBRATION,
        doc="calibration unknowns of `calibrate` kept only where the observations determine them: a "
            "component whose t-test against its start value is not significant (`calibration_alpha`) is "
            "fixed at the start value and the variant adjusted again, the least significant first")
    calibration_alpha: float = setting(0.05, gt=0, lt=1, unit="1",
                                       doc="significance level of the `test_calibration` t-tests (two-sided)")
    across_offset_sigma_deg: float = setting(0.1, gt=0, doc="prior of a pushbroom's across_offset (docs/adjustment.md)")
    across_scale_sigma: float = setting(0.005, gt=0, unit="1", doc="prior of a pushbroom's across_scale")
    along_offset_sigma_deg: float = setting(0.1, gt=0, doc="prior of a pushbroom's along_offset")
    snooping: bool = setting(True, doc="data snooping")
    critical_value: float = setting(3.29, gt=0, unit="1", doc="critical value of the normalised residual w")
    rejections_per_round: int = setting(32, ge=1, unit="1", doc="units removed per re-solution, at most")
    independent_rejections: bool = setting(True, doc="only units whose w-tests cannot influence each other "
                                           "are removed in one round (1 per round: Baarda's)")
    snooping_method: str = setting("update", choices=("update", "linear", "resolve"),
                                   doc="re-solution after a removal: low-rank update, the same on the linear "
                                       "model until no w is left (laser default), or full")
    max_iterations: int = setting(20, ge=1, unit="1", doc="Gauss-Newton iterations at most")
    backend: str = setting("auto", choices=("auto", "cholmod", "superlu"), doc="sparse solver")

    def __post_init__(self) -> None:
        check(self, where=f"Variant {self.name}")
        untested = sorted(set(self.test_calibration) - set(self.calibrate))
        if untested:
            raise ProjectFileError(f"Variant {self.name} test_calibration: {', '.join(untested)} is not in "
                                   f"calibrate ({', '.join(self.calibrate) or 'nothing'}): only a calibrated "
                                   "unknown can be tested")

    def role_of(self, point: str, role: str) -> str:
        """The role of a point in this variant: ground.csv's (or ``tie``), then the patterns in order."""
        return self.roles_of([(point, role)])[point]

    def roles_of(self, points: Iterable[tuple[str, str]]) -> dict[str, str]:
        """:meth:`role_of` of each (point, ground.csv's role) pair: point -> role.

        The last pattern that matches wins. A pattern without a glob character is a point's name (the
        cross-validation holds points out by name, one pattern each): looked up, not matched against
        every point, so the cost is points + patterns, not their product.
        """
        names: dict[str, tuple[int, str]] = {}
        globs: list[tuple[int, str, str]] = []
        for i, (pattern, new) in enumerate(self.roles):
            if any(c in pattern for c in "*?["):
                globs.append((i, pattern, new))
            else:
                names[pattern] = (i, new)
        out: dict[str, str] = {}
        for point, role in points:
            last, found = names.get(point, (-1, role))
            for i, pattern, new in globs:  # in order: a later match than the name's replaces it
                if i > last and fnmatch.fnmatchcase(point, pattern):
                    last, found = i, new
            out[point] = found
        return out

    def strip_models(self, strip: str) -> StripModels:
        for s in self.strips:
            if s.strip == strip:
                return s
        return StripModels(strip)

    def dtm_height_at(self, point: str) -> bool:
        return self.dtm_heights and any(fnmatch.fnmatchcase(point, p) for p in self.dtm_height_points)


#: Variants available without a variants.toml.
BUILTIN = {
    "DG": Variant("DG", "DG", "direct georeferencing: GPS/IMU as measured", snooping=False),
    "BE": Variant("BE", "BE", "one GPS/IMU model for the block, degree 0"),
    "SE": Variant("SE", "SE", "one GPS/IMU model per strip, degree 0"),
}


def _roles(value: dict, where: str) -> tuple[tuple[str, str], ...]:
    for pattern, role in value.items():
        if role not in ROLES:
            raise ProjectFileError(f"{where[:-1]}.{pattern}]: expected one of {', '.join(ROLES)}, found {role!r}")
    return tuple(value.items())


def _variant(table: dict, path: Path, name: str, defaults: dict, sensor: str = "image") -> Variant:
    where = f"variants.{name}"
    if not isinstance(table, dict):
        raise ProjectFileError(f"{path} [{where}]: expected a table, found {table!r}")
    variant = read(Variant, {**defaults, **table}, str(path), where, name=name)
    if variant.strategy in ("DG", "BE", "ME") and any(s.breaks_lines or s.breaks_times for s in variant.strips):
        raise ProjectFileError(f"{path} [{where}.strip]: breaks need per-strip models (strategy SE, P or S)")
    allowed = LASER_CALIBRATION if sensor == "laser" else IMAGE_CALIBRATION
    other = [c for c in variant.calibrate if c not in allowed]
    if other:
        raise ProjectFileError(f"{path} [{where}.calibrate]: {other[0]!r} is not a calibration unknown of "
                               f"{'a laser' if sensor == 'laser' else 'an image'} project (expected one of "
                               f"{', '.join(allowed)})")
    if sensor == "laser" and any(s.breaks_lines for s in variant.strips):
        raise ProjectFileError(f"{path} [{where}.strip]: breaks_lines of a laser strip (it has no lines): "
                               "give breaks_times")
    return variant


def read_variants(path, sensor: str = "image") -> dict[str, Variant]:
    """All variants of a ``variants.toml``: ``[defaults]`` merged into every ``[variants.NAME]``.

    ``sensor`` ``"laser"``: the variants of a laser project, :data:`LASER_DEFAULTS` beneath ``[defaults]``.
    """
    path = Path(path)
    data = load_toml(path)
    for key in data:
        if key not in ("defaults", "variants"):
            raise ProjectFileError(f"{path}: unknown table [{key}] (expected defaults, variants)")
    defaults = data.get("defaults", {})
    if not isinstance(defaults, dict):
        raise ProjectFileError(f"{path} [defaults]: expected a table, found {defaults!r}")
    raw = data.get("variants", {})
    if not isinstance(raw, dict) or not raw:
        raise ProjectFileError(f"{path}: expected at least one [variants.NAME] table")
    base = dict(LASER_DEFAULTS) if sensor == "laser" else {}
    return {name: _variant(t, path, name, {**base, **defaults}, sensor) for name, t in raw.items()}


def laser_variants(project_root) -> tuple[Path, dict[str, Variant]]:
    """A laser project's variants file and variants: ``PROJECT/variants.toml``, else the paper's models
    (module docstring)."""
    path = Path(project_root) / "variants.toml"
    if not path.exists():
        path = Path(str(files("scangeo.data") / LASER_VARIANTS))
    return path, read_variants(path, "laser")


def laser_variant(name: str = "strip", **keys) -> Variant:
    """A laser variant from keys of a ``[variants.NAME]`` table over :data:`LASER_DEFAULTS` (default: per
    strip, degree 1 in position and attitude, the paper's model), every key checked; a key given as
    None is left out (a default's prior removed: ``constant_sigma_deg=None``)."""
    table = {**LASER_DEFAULTS, "strategy": "SE", "position_degree": 1, "attitude_degree": 1, **keys}
    return _variant({k: list(v) if isinstance(v, tuple) else v for k, v in table.items() if v is not None},
                    Path("variant"), name, {}, "laser")


def builtin_variants(sensor: str = "image") -> dict[str, Variant]:
    """The variants available without a variants.toml: DG, BE, SE; for a laser, the paper's models."""
    if sensor == "laser":
        return read_variants(Path(str(files("scangeo.data") / LASER_VARIANTS)), "laser")
    return dict(BUILTIN)


def find_variant(project_root, name: str, variants_file=None, sensor: str = "image") -> Variant:
    """A variant by name from ``variants_file`` (default PROJECT/variants.toml) or the built-in ones
    (a laser project's: the paper's models)."""
    path = Path(variants_file) if variants_file else Path(project_root) / "variants.toml"
    variants = builtin_variants(sensor)
    if path.exists():
        variants.update(read_variants(path, sensor))
    elif variants_file:
        raise MissingFileError(f"{path}: no such variants file")
    if name not in variants:
        raise ProjectFileError(f"{path}: no variant {name!r} (variants: {', '.join(variants)})")
    return variants[name]


__all__ = ["BUILTIN", "CALIBRATION", "IMAGE_CALIBRATION", "LASER_CALIBRATION", "LASER_DEFAULTS",
           "PUSHBROOM_CALIBRATION", "StripModels", "Variant", "WHISKBROOM_CALIBRATION", "builtin_variants",
           "find_variant", "laser_variant", "laser_variants", "read_variants"]
