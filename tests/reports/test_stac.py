"""STAC Items of orthoimages: valid by the core and the projection schemas offline (scangeo.reports.stac_validation),
projection fields, round trip."""
from __future__ import annotations

import copy
import json

import numpy as np
import pystac
import pystac.validation
import pytest
import rasterio
from affine import Affine
from pyproj import Transformer
from pystac.extensions.projection import ProjectionExtension

from scangeo.errors import StacItemError
from scangeo.reports.stac import item_path, write_stac_items
from scangeo.reports.stac_validation import EXTENSION_SCHEMAS, core_schema_uri, validate_item, validate_items


@pytest.fixture
def ortho(tmp_path):
    """A 30 x 50 cell orthoimage in UTM 33N (5 m cells) with the tags rectify writes."""
    path = tmp_path / "results" / "S4" / "ortho" / "02.tif"
    path.parent.mkdir(parents=True)
    with rasterio.open(path, "w", driver="GTiff", width=50, height=30, count=1, dtype="uint8", crs="EPSG:32633",
                       transform=Affine(5.0, 0.0, 595000.0, 0.0, -5.0, 5340000.0)) as dst:
        dst.write(np.ones((1, 30, 50), dtype="uint8"))
        dst.update_tags(variant="S4", strip="02", orientation="adjusted", sigma0="1.02")
    return path


def test_an_item_is_valid_stac_and_carries_the_grid(ortho, tmp_path):
    (path,) = write_stac_items(tmp_path, "S4", [ortho], {"02": [300010.0, 300022.0]})
    assert path == item_path(ortho) == ortho.with_name("02.stac.json")
    d = json.loads(path.read_text(encoding="utf-8"))
    core = copy.deepcopy(d)
    assert core.pop("stac_extensions") == [ProjectionExtension.get_schema_uri()]
    core["stac_extensions"] = []
    assert pystac.validation.validate_dict(core)  # the core item schema, shipped with pystac
    broken = copy.deepcopy(core)
    del broken["properties"]["datetime"]
    with pytest.raises(pystac.errors.STACValidationError):
        pystac.validation.validate_dict(broken)

    item = pystac.Item.from_file(str(path))
    proj = ProjectionExtension.ext(item)
    assert proj.code == "EPSG:32633"
    assert proj.shape == [30, 50]
    assert proj.transform == [5.0, 0.0, 595000.0, 0.0, -5.0, 5340000.0]
    assert proj.bbox == [595000.0, 5339850.0, 595250.0, 5340000.0]
    assert item.assets["data"].get_absolute_href() == str(ortho)
    assert item.properties["scangeo:variant"] == "S4" and item.properties["scangeo:strip"] == "02"
    assert item.properties["scangeo:sigma0"] == 1.02
    assert item.properties["scangeo:time_span_s"] == [300010.0, 300022.0]
    # the footprint: the grid's corners in WGS 84, inside the bbox
    lon, lat = Transformer.from_crs("EPSG:32633", "EPSG:4326", always_xy=True).transform(
        [595000.0, 595250.0, 595250.0, 595000.0], [5339850.0, 5339850.0, 5340000.0, 5340000.0])
    ring = np.array(item.geometry["coordinates"][0])
    assert len(ring) == 41 and np.array_equal(ring[0], ring[-1])
    for x, y in zip(lon, lat):
        assert np.min(np.hypot(ring[:, 0] - x, ring[:, 1] - y)) < 1e-7
    west, south, east, north = item.bbox
    assert west <= min(lon) + 1e-8 and east >= max(lon) - 1e-8 and south <= min(lat) + 1e-8 and north >= max(lat) - 1e-8
    assert east - west == pytest.approx(max(lon) - min(lon), abs=1e-7)


def test_a_mosaic_item_has_no_strip(ortho, tmp_path):
    mosaic = ortho.with_name("mosaic.tif")
    with rasterio.open(ortho) as src:
        profile, data = src.profile, src.read()
    with rasterio.open(mosaic, "w", **profile) as dst:
        dst.write(data)
    (path,) = write_stac_items(tmp_path, "S4", [mosaic])
    item = pystac.Item.from_file(str(path))
    assert "scangeo:strip" not in item.properties and item.id.endswith("-S4-mosaic")


def test_items_validate_against_their_schemas_with_the_network_blocked(ortho, tmp_path, no_network):
    (path,) = write_stac_items(tmp_path, "S4", [ortho], {"02": [300010.0, 300022.0]})
    assert validate_items([path]) == {str(path): [core_schema_uri(pystac.get_stac_version()),
                                                  ProjectionExtension.get_schema_uri()]}
    assert no_network == []  # nothing was even tried
    d = json.loads(path.read_text(encoding="utf-8"))
    # each schema is applied: a defect of the core item, of the projection fields, of the GeoJSON geometry
    for defect, schema, where in (
        (lambda x: x["properties"].pop("datetime"), "item.json", "properties"),
        (lambda x: x["properties"].__setitem__("proj:shape", [30.5, 50]), "projection", "properties/proj:shape/0"),
        (lambda x: x["properties"].__setitem__("proj:code", 32633), "projection", "properties/proj:code"),
        (lambda x: x["geometry"].__setitem__("coordinates", [[[16.0, 48.0]]]), "item.json", ""),  # not a ring
    ):
        broken = copy.deepcopy(d)
        defect(broken)
        with pytest.raises(StacItemError, match=rf"^02: not valid by \S*{schema}\S* .*; at {where}"):
            validate_item(broken, source="02")
    unknown = copy.deepcopy(d)
    unknown["stac_extensions"].append("https://stac-extensions.github.io/eo/v2.0.0/schema.json")
    with pytest.raises(StacItemError, match=r"eo/v2.0.0/schema.json is not held on disk"):
        validate_item(unknown, source="02")
    assert no_network == []
    assert set(EXTENSION_SCHEMAS) >= {ProjectionExtension.get_schema_uri()}


def test_a_file_that_is_no_item_is_named(tmp_path):
    bad = tmp_path / "x.stac.json"
    bad.write_text("{", encoding="utf-8")
    with pytest.raises(StacItemError, match=rf"^{bad}: not a STAC item's JSON"):
        validate_item(bad)
    bad.write_text('{"type": "FeatureCollection"}', encoding="utf-8")
    with pytest.raises(StacItemError, match=rf"^{bad}: not a STAC item \(expected a Feature"):
        validate_item(bad)
