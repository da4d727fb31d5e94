"""The STAC items scangeo writes, validated against their JSON schemas without the network.

pystac's own validation (``pystac.validation``, with jsonschema) fetches every schema but the core
ones over the network. Here every schema comes from the disk: the core item schema and GeoJSON's
from pystac (the package that writes the items, so they are of the items' STAC version), each
extension's from ``scangeo/data/stac`` (:data:`EXTENSION_SCHEMAS`; where each file comes from and
its licence: that folder's README), and PROJJSON's (which the projection extension refers to for
``proj:projjson``) from PROJ's data as pyproj ships it. The registry's retrieval refuses every other
URI: a validation never reaches for the network, and a schema scangeo does not hold is an error
that names it.

jsonschema is an optional dependency (``pip install 'pystac[validation]'``; the ``test`` extra has
it): writing items does not need it, validating them does.
"""
from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from scangeo.errors import MissingDependencyError, StacItemError
from scangeo.resources import STAC_SCHEMAS

#: Extension schema URI -> its file in ``scangeo/data/stac``.
EXTENSION_SCHEMAS = {
    "https://stac-extensions.github.io/projection/v2.0.0/schema.json": "projection-v2.0.0.json",
    "https://stac-extensions.github.io/pointcloud/v1.0.0/schema.json": "pointcloud-v1.0.0.json",
}


def core_schema_uri(stac_version: str) -> str:
    """The URI of the core item schema of ``stac_version`` (e.g. ``1.1.0``)."""
    return f"https://schemas.stacspec.org/v{stac_version}/item-spec/json-schema/item.json"


def _schemas() -> dict[str, dict]:
    """Every schema held on disk, by URI: pystac's core and GeoJSON schemas, the shipped extensions',
    PROJ's PROJJSON schema."""
    from pyproj.datadir import get_data_dir  # start-up cost: pyproj's data only when items are validated
    from pystac.validation.local_validator import get_local_schema_cache

    schemas: dict[str, dict] = dict(get_local_schema_cache())
    for uri, name in EXTENSION_SCHEMAS.items():
        schemas[uri] = json.loads(STAC_SCHEMAS.joinpath(name).read_text(encoding="utf-8"))
    projjson = Path(get_data_dir()) / "projjson.schema.json"
    if projjson.is_file():  # under its own $id: a projection schema referring to another version fails by name
        schema = json.loads(projjson.read_text(encoding="utf-8"))
        schemas[schema["$id"]] = schema
    return schemas


def schema_registry() -> Any:
    """A ``referencing.Registry`` of every schema held on disk (module docstring) whose retrieval of any
    other URI raises ``referencing.exceptions.NoSuchResource``: nothing is fetched.

    Raises
    ------
    MissingDependencyError
        jsonschema (and its ``referencing``) is not installed.
    """
    try:
        from referencing import Registry, Resource
        from referencing.exceptions import NoSuchResource
    except ImportError as exc:  # optional dependency: jsonschema's referencing (pystac[validation])
        raise MissingDependencyError("validating STAC items needs jsonschema: pip install 'pystac[validation]'"
                                     ) from exc

    def refuse(uri: str):
        raise NoSuchResource(ref=uri)  # type: ignore[call-arg]

    return Registry(retrieve=refuse).with_resources(  # type: ignore[call-arg]
        (uri, Resource.from_contents(schema)) for uri, schema in _schemas().items())


def validate_item(item: dict | str | Path, registry: Any = None, source: str | None = None) -> list[str]:
    """Validate one STAC item against the core item schema of its ``stac_version`` and the schema of
    each of its ``stac_extensions``, offline.

    Parameters
    ----------
    item : dict, or str or Path
        The item as a dict, or the path of its JSON file.
    registry : referencing.Registry, optional
        The schemas (:func:`schema_registry`; built here when not given: pass one to validate many).
    source : str, optional
        How messages name the item (default: its path, or its id).

    Returns
    -------
    list of str
        The URIs of the schemas the item was validated against, the core one first.

    Raises
    ------
    StacItemError
        The item fails a schema (the message names the item, the schema, where in the item and what
        was expected), a schema is not held on disk, or the file is not an item's JSON.
    MissingDependencyError
        jsonschema is not installed.
    """
    if isinstance(item, str | Path):
        source = source or str(item)
        try:
            item = json.loads(Path(item).read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise StacItemError(f"{source}: not a STAC item's JSON ({exc})") from exc
    if not isinstance(item, dict) or item.get("type") != "Feature" or not item.get("stac_version"):
        raise StacItemError(f"{source or '<item>'}: not a STAC item (expected a Feature with a stac_version)")
    source = source or str(item.get("id", "<item>"))
    try:
        import jsonschema
        from referencing.exceptions import Unresolvable
    except ImportError as exc:  # optional dependency (module docstring)
        raise MissingDependencyError("validating STAC items needs jsonschema: pip install 'pystac[validation]'"
                                     ) from exc
    registry = registry if registry is not None else schema_registry()
    uris = [core_schema_uri(str(item["stac_version"])), *item.get("stac_extensions", [])]
    for uri in uris:
        try:
            schema = registry.contents(uri)
        except LookupError as exc:  # referencing's NoSuchResource
            raise StacItemError(f"{source}: schema {uri} is not held on disk (scangeo ships "
                                f"{', '.join(EXTENSION_SCHEMAS)} and pystac's core schemas)") from exc
        validator = jsonschema.validators.validator_for(schema)(schema, registry=registry)
        try:
            errors = list(validator.iter_errors(item))
        except Unresolvable as exc:
            raise StacItemError(f"{source}: schema {uri} refers to a schema not held on disk ({exc})") from exc
        if errors:
            best = jsonschema.exceptions.best_match(errors)
            where = "/".join(str(p) for p in best.absolute_path) or "the item"
            raise StacItemError(f"{source}: not valid by {uri} ({len(errors)} error(s)); at {where}: {best.message}")
    return uris


def validate_items(paths: Iterable[str | Path]) -> dict[str, list[str]]:
    """Validate STAC item files offline (:func:`validate_item`), one registry for all.

    Parameters
    ----------
    paths : iterable of str or Path
        The items' JSON files (``NAME.stac.json``).

    Returns
    -------
    dict
        Path (as given) -> the schema URIs it was validated against.

    Raises
    ------
    StacItemError, MissingDependencyError
        As :func:`validate_item`, for the first item that fails.
    """
    registry = schema_registry()
    return {str(p): validate_item(p, registry) for p in paths}


__all__ = ["EXTENSION_SCHEMAS", "core_schema_uri", "schema_registry", "validate_item", "validate_items"]
