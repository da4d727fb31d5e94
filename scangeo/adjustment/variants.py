"""Adjustment variants (strategies) read from ``variants.toml`` (format in docs/adjustment.md).

A variant says how GPS/IMU is corrected (strategy DG, BE, SE, P, S and per-strip overrides with
degrees and break epochs), which points play which role (patterns on point ids), whether tie points
carry DTM heights, the sigmas, the regularisation, the calibration unknowns and data snooping.
"""
from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path

from scangeo.errors import ProjectFileError
from scangeo.io.toml_config import Table, load_toml

STRATEGIES = ("DG", "BE", "SE", "P", "S")
ROLES = ("control", "check", "height", "planimetric", "tie", "ignore")
CALIBRATION = ("boresight", "lever_arm", "time_offset", "index_error", "scale_error")


@dataclass(frozen=True)
class StripModels:
    """Per-strip overrides: degrees, rotation, and break epochs (lines or times) of a split."""

    strip: str
    position_degree: int | None = None
    attitude_degree: int | None = None
    rotation: bool | None = None
    breaks_lines: tuple[float, ...] = ()
    breaks_times: tuple[float, ...] = ()


@dataclass(frozen=True)
class Variant:
    """One adjustment strategy; every field is a key of a ``[variants.NAME]`` table."""

    name: str
    strategy: str = "SE"
    description: str = ""
    position_degree: int = 0
    attitude_degree: int = 0
    rotation: bool = False
    strips: tuple[StripModels, ...] = ()
    roles: tuple[tuple[str, str], ...] = ()
    dtm_heights: bool = False
    dtm_height_points: tuple[str, ...] = ("*",)
    gps_sigma_m: tuple[float, float, float] = (0.05, 0.05, 0.10)
    imu_sigma_deg: tuple[float, float, float] = (0.003, 0.003, 0.005)
    image_sigma_px: float | None = None
    coefficient_sigma_m: float = 10.0
    coefficient_sigma_deg: float = 0.1
    constant_sigma_m: float | None = None
    constant_sigma_deg: float | None = None
    calibrate: tuple[str, ...] = ()
    snooping: bool = True
    critical_value: float = 3.29
    rejections_per_round: int = 1
    snooping_method: str = "update"
    max_iterations: int = 20
    backend: str = "auto"

    def role_of(self, point: str, role: str) -> str:
        """The role of a point in this variant: ground.csv's (or ``tie``), then the patterns in order."""
        for pattern, new in self.roles:
            if fnmatch.fnmatchcase(point, pattern):
                role = new
        return role

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


def _variant(t: Table, name: str, defaults: dict) -> Variant:
    data = {**defaults, **t.data}
    t = Table(data, t.path, t.name)
    kw: dict = {"name": name}
    kw["strategy"] = t.choice("strategy", STRATEGIES, "SE")
    kw["description"] = t.get("description", str, "")
    for key in ("position_degree", "attitude_degree", "max_iterations", "rejections_per_round"):
        kw[key] = t.get(key, int, getattr(Variant, key))
    for key in ("rotation", "dtm_heights", "snooping"):
        kw[key] = t.get(key, bool, getattr(Variant, key))
    for key in ("coefficient_sigma_m", "coefficient_sigma_deg", "critical_value"):
        kw[key] = t.get(key, float, getattr(Variant, key))
    for key in ("constant_sigma_m", "constant_sigma_deg", "image_sigma_px"):
        kw[key] = t.get(key, float, None)
    kw["gps_sigma_m"] = tuple(t.vector("gps_sigma_m", 3, list(Variant.gps_sigma_m)))
    kw["imu_sigma_deg"] = tuple(t.vector("imu_sigma_deg", 3, list(Variant.imu_sigma_deg)))
    kw["backend"] = t.choice("backend", ("auto", "cholmod", "superlu"), "auto")
    kw["snooping_method"] = t.choice("snooping_method", ("update", "resolve"), "update")
    kw["dtm_height_points"] = tuple(str(p) for p in t.get("dtm_height_points", list, ["*"]))
    calibrate = t.get("calibrate", list, [])
    for c in calibrate:
        if c not in CALIBRATION:
            raise ProjectFileError(f"{t.path} [{t.name}] calibrate: {c!r} is not one of {', '.join(CALIBRATION)}")
    kw["calibrate"] = tuple(calibrate)
    roles = t.get("roles", dict, {})
    for pattern, role in roles.items():
        if role not in ROLES:
            raise ProjectFileError(
                f"{t.path} [{t.name}] roles: {pattern!r} = {role!r}: expected one of {', '.join(ROLES)}"
            )
    kw["roles"] = tuple(roles.items())
    strips = []
    for i, s in enumerate(t.get("strip", list, [])):
        st = Table(s, t.path, f"{t.name}.strip #{i + 1}")
        strips.append(
            StripModels(
                str(st.get("id", (str, int))),
                st.get("position_degree", int, None),
                st.get("attitude_degree", int, None),
                st.get("rotation", bool, None),
                tuple(float(v) for v in st.get("breaks_lines", list, [])),
                tuple(float(v) for v in st.get("breaks_times", list, [])),
            )
        )
        st.finish()
        if (strips[-1].breaks_lines or strips[-1].breaks_times) and kw["strategy"] in ("DG", "BE"):
            raise ProjectFileError(f"{t.path} [{t.name}]: breaks need per-strip models (strategy SE, P or S)")
    kw["strips"] = tuple(strips)
    t.finish()
    for key in ("position_degree", "attitude_degree"):
        if not -1 <= kw[key] <= 10:
            raise ProjectFileError(f"{t.path} [{t.name}] {key}: expected -1..10, found {kw[key]}")
    return Variant(**kw)


def read_variants(path) -> dict[str, Variant]:
    """All variants of a ``variants.toml``: ``[defaults]`` merged into every ``[variants.NAME]``."""
    path = Path(path)
    data = load_toml(path)
    for key in data:
        if key not in ("defaults", "variants"):
            raise ProjectFileError(f"{path}: unknown table [{key}] (expected defaults, variants)")
    defaults = Table(data.get("defaults", {}), path, "defaults").data
    raw = data.get("variants", {})
    if not isinstance(raw, dict) or not raw:
        raise ProjectFileError(f"{path}: expected at least one [variants.NAME] table")
    return {name: _variant(Table(t, path, f"variants.{name}"), name, defaults) for name, t in raw.items()}


def find_variant(project_root, name: str, variants_file=None) -> Variant:
    """A variant by name from ``variants_file`` (default PROJECT/variants.toml) or the built-in ones."""
    path = Path(variants_file) if variants_file else Path(project_root) / "variants.toml"
    variants = dict(BUILTIN)
    if path.exists():
        variants.update(read_variants(path))
    elif variants_file:
        raise ProjectFileError(f"{path}: no such variants file")
    if name not in variants:
        raise ProjectFileError(f"{path}: no variant {name!r} (variants: {', '.join(variants)})")
    return variants[name]


__all__ = ["BUILTIN", "StripModels", "Variant", "find_variant", "read_variants"]
