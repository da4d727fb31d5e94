"""Data shipped inside the package, read with :mod:`importlib.resources`.

The simulation presets (``scangeo/data/presets/NAME.toml``), the default variants of a comparison
(``scangeo/data/variants.toml``) and the STAC extensions' schemas (``scangeo/data/stac/``) are package
data: they are found the same way from the source tree, an editable install or an installed wheel.
The top-level ``data/`` folder of the source tree holds examples for users only; nothing in the
package reads it.
"""
from __future__ import annotations

from importlib.resources import files
from importlib.resources.abc import Traversable

#: The folder of the shipped simulation presets.
PRESETS: Traversable = files("scangeo") / "data" / "presets"
#: The default strategies of ``scangeo compare`` (with placeholders for the problem strip).
DEFAULT_VARIANTS: Traversable = files("scangeo") / "data" / "variants.toml"
#: The JSON schemas of the STAC extensions scangeo's items use (offline validation, with their licences).
STAC_SCHEMAS: Traversable = files("scangeo") / "data" / "stac"


def preset_names() -> list[str]:
    """Names of the shipped presets (``quick``, ``small``, ``vienna2000``, ...), sorted."""
    if not PRESETS.is_dir():
        return []
    return sorted(p.name.removesuffix(".toml") for p in PRESETS.iterdir() if p.name.endswith(".toml"))


def preset_file(name: str) -> Traversable | None:
    """The shipped preset ``name`` (None when there is no such preset)."""
    path = PRESETS.joinpath(f"{name}.toml")
    return path if path.is_file() else None


__all__ = ["DEFAULT_VARIANTS", "PRESETS", "STAC_SCHEMAS", "preset_file", "preset_names"]
