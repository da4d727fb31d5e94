"""One configuration schema: every key's type, range and allowed values checked, errors naming file and key."""
from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from scangeo.adjustment.variants import read_variants
from scangeo.errors import OptionsError, ProjectFileError, RectifyOptionsError
from scangeo.io.project_schema import read_project_file
from scangeo.io.schema import keys, read, setting, type_text
from scangeo.match.options import MatchOptions
from scangeo.rectify.options import RectifyOptions
from scangeo.simulate.config import config_from_dict

EXAMPLE = Path(__file__).resolve().parents[2] / "data" / "example"


@dataclass(frozen=True)
class Inner:
    level: int | None = setting(None, ge=1, le=9)


@dataclass(frozen=True)
class Demo:
    flag: bool = setting(False)
    count: int = setting(3, ge=1)
    size_m: float = setting(1.0, gt=0, lt=10)
    name: str = setting("a", choices=("a", "b"))
    triple: tuple[float, float, float] = setting((0.0, 0.0, 0.0))
    words: tuple[str, ...] = setting((), choices=("x", "y"))
    mode: bool | str = setting("auto")
    inner: Inner = setting(Inner())
    kind: str = setting("p", choices=("p", "q"))
    only_q: float = setting(0.0, when=("kind", "q"))


@pytest.mark.parametrize("table, key, expected", [
    ({"flag": "false"}, "flag", "expected true or false, found 'false'"),
    ({"flag": 0}, "flag", "expected true or false, found 0"),
    ({"count": 2.0}, "count", "expected an integer >= 1, found 2.0"),
    ({"count": True}, "count", "expected an integer >= 1, found True"),
    ({"count": 0}, "count", "expected an integer >= 1, found 0"),
    ({"size_m": "0.1"}, "size_m", "expected a number in (0, 10) (m), found '0.1'"),
    ({"size_m": 10}, "size_m", "expected a number in (0, 10) (m), found 10"),
    ({"size_m": float("nan")}, "size_m", "expected a number, found nan"),
    ({"name": "c"}, "name", "expected one of a, b, found 'c'"),
    ({"name": 1}, "name", "expected a string (one of a, b), found 1"),
    ({"triple": [1, 2]}, "triple", "expected 3 numbers, found [1, 2]"),
    ({"triple": [1, "2", 3]}, "triple", "expected 3 numbers, found [1, '2', 3]"),
    ({"words": ["x", "z"]}, "words", "expected a list of strings (one of x, y), found ['x', 'z']"),
    ({"words": "x"}, "words", "expected a list, found 'x'"),
    ({"mode": 3}, "mode", "expected true or false or a string, found 3"),
    ({"inner": {"level": 0}}, "inner.level", "expected an integer in [1, 9], found 0"),
    ({"inner": {"levle": 1}}, "inner", "unknown key 'levle' (expected one of level)"),
    ({"inner": 3}, "inner", "expected a table, found 3"),
    ({"only_q": 1.0}, "only_q", "not a key when kind is not 'q'"),
    ({"kind": "r", "only_q": 1.0}, "kind", "expected one of p, q, found 'r'"),
])
def test_each_kind_of_bad_value_names_file_key_expected_and_found(table, key, expected):
    with pytest.raises(ProjectFileError) as info:
        read(Demo, table, "demo.toml", "demo")
    assert str(info.value) == f"demo.toml [demo.{key}]: {expected}" or (
        key == "inner" and str(info.value) == f"demo.toml [demo.inner]: {expected}")


def test_good_values_are_converted():
    d = read(Demo, {"flag": True, "count": 5, "size_m": 2, "triple": [1, 2, 3], "words": ["y"], "mode": False,
                    "inner": {"level": 9}, "kind": "q", "only_q": 4}, "demo.toml")
    assert d == Demo(True, 5, 2.0, "a", (1.0, 2.0, 3.0), ("y",), False, Inner(9), "q", 4.0)
    assert isinstance(d.size_m, float) and isinstance(d.triple[0], float)
    assert read(Demo, {}, "demo.toml") == Demo()


def test_units_ranges_and_types_are_metadata():
    by_name = {k.name: k for k in keys(Demo)}
    assert by_name["size_m"].unit == "m" and by_name["size_m"].setting.range_text() == "(0, 10)"
    assert by_name["count"].setting.range_text() == ">= 1"
    assert type_text(by_name["triple"].hint) == "3 numbers"
    assert type_text(by_name["mode"].hint) == "true/false or string"


@pytest.mark.parametrize("table, key, expected", [
    ({"igm": "false"}, "igm", "expected true or false, found 'false'"),
    ({"max_error_px": "0.1"}, "max_error_px", "expected a number > 0 (px), found '0.1'"),
    ({"max_error_px": 0}, "max_error_px", "expected a number > 0 (px), found 0"),
    ({"memory_budget_mb": 8}, "memory_budget_mb", "expected a number >= 16 (MiB), found 8"),
    ({"layers": ["time", "colour"]}, "layers", "expected a list of strings (one of"),
    ({"bounds": [0, 0, 1]}, "bounds", "expected 4 numbers (map unit), found [0, 0, 1]"),
    ({"geotiff": {"compress": "jpeg"}}, "geotiff.compress",
     "expected one of deflate, zstd, lzw, none, lerc-lossy, found 'jpeg'"),
    ({"geotiff": {"blocksize": "512"}}, "geotiff.blocksize",
     "expected an integer >= 16, multiple of 16 (px), found '512'"),
    ({"geotiff": {"blocksize": 520}}, "geotiff.blocksize", "expected an integer >= 16, multiple of 16 (px), found 520"),
    ({"tile_size": 40}, "tile_size", "expected an integer >= 16, multiple of 16 (cell), found 40"),
    ({"geotiff": {"threads": 0}}, "geotiff.threads", "expected ALL_CPUS or a number >= 1, found 0"),
])
def test_rectify_options(table, key, expected):
    with pytest.raises(RectifyOptionsError) as info:
        RectifyOptions.from_dict(table, "rectify.toml")
    assert str(info.value).startswith(f"rectify.toml [rectify.{key}]: {expected}")


def _built_in_python(cls, table: dict):
    """``cls`` built from a table's values in Python (nested tables as their dataclasses)."""
    import dataclasses
    import typing

    hints = typing.get_type_hints(cls)
    values = {k: _built_in_python(hints[k], v) if isinstance(v, dict) and dataclasses.is_dataclass(hints[k]) else v
              for k, v in table.items()}
    return cls(**values)


@pytest.mark.parametrize("cls, table, error, key, expected", [
    (RectifyOptions, {"max_error_px": 0}, RectifyOptionsError, "max_error_px", "expected a number > 0 (px), found 0"),
    (RectifyOptions, {"memory_budget_mb": 8}, RectifyOptionsError, "memory_budget_mb",
     "expected a number >= 16 (MiB), found 8"),
    (RectifyOptions, {"igm": "false"}, RectifyOptionsError, "igm", "expected true or false, found 'false'"),
    (RectifyOptions, {"bounds": [0, 0, 1]}, RectifyOptionsError, "bounds",
     "expected 4 numbers (map unit), found [0, 0, 1]"),
    (RectifyOptions, {"tile_size": 40}, RectifyOptionsError, "tile_size",
     "expected an integer >= 16, multiple of 16 (cell), found 40"),
    (RectifyOptions, {"resampling": "lanczos"}, RectifyOptionsError, "resampling",
     "expected one of nearest, bilinear, cubic, found 'lanczos'"),
    (RectifyOptions, {"geotiff": {"compress": "jpeg"}}, RectifyOptionsError, "compress",
     "expected one of deflate, zstd, lzw, none, lerc-lossy, found 'jpeg'"),
    (MatchOptions, {"template_px": 8}, OptionsError, "template_px", "expected an integer >= 7, odd (cell), found 8"),
    (MatchOptions, {"check_share": 1.0}, OptionsError, "check_share", "expected a number in [0, 1), found 1.0"),
    (MatchOptions, {"bands": [0, 2]}, OptionsError, "bands", "expected a list of integers >= 1, found [0, 2]"),
    (MatchOptions, {"id_prefix": "M-"}, OptionsError, "id_prefix", "expected letters or digits, found 'M-'"),
])
def test_options_built_in_python_fail_as_the_same_keys_of_a_file(cls, table, error, key, expected):
    """The same class of error and the same words; only the place differs (the field, or file and key)."""
    with pytest.raises(error) as from_file:
        cls.from_dict(table, "run.toml")
    with pytest.raises(error) as in_python:
        _built_in_python(cls, table)
    section = "match" if cls is MatchOptions else "rectify"
    path = f"geotiff.{key}" if "geotiff" in table else key
    owner = "GeoTiffProfile" if "geotiff" in table else cls.__name__
    assert str(from_file.value) == f"run.toml [{section}.{path}]: {expected}"
    assert str(in_python.value) == f"{owner}.{key}: {expected}"


def test_options_built_in_python_are_converted_as_a_file_is_read():
    o = RectifyOptions(resolution=2, layers=["time"], bounds=np.array([0, 0, 10, 20]))
    assert o == RectifyOptions.from_dict({"resolution": 2, "layers": ["time"], "bounds": [0, 0, 10, 20]}, "r")
    assert np.isnan(RectifyOptions(nodata=float("nan")).nodata)  # a nodata value may be NaN
    assert isinstance(o.resolution, float) and o.layers == ("time",) and o.bounds == (0.0, 0.0, 10.0, 20.0)
    assert MatchOptions(bands=np.array([3, 1])).bands == (3, 1)
    with pytest.raises(RectifyOptionsError, match=r"RectifyOptions.geotiff: expected a GeoTiffProfile, found \{"):
        RectifyOptions(geotiff={"level": 3})


def test_rectify_options_read():
    o = RectifyOptions.from_dict({"resolution": 2, "igm": True, "layers": ["time"], "geotiff": {"level": 6}}, "r")
    assert (o.resolution, o.igm, o.layers, o.geotiff.level) == (2.0, True, ("time",), 6)


def test_project_file(tmp_path):
    text = (EXAMPLE / "project.toml").read_text()
    import tomllib

    pf = read_project_file(tomllib.loads(text), "project.toml")
    assert [s.id for s in pf.strips] == ["01", "02"] and pf.sensor.fov_deg == 42.9
    for old, new, expected in [
        ("pixels = 716", "pixels = 716.0", "project.toml [sensor.pixels]: expected an integer >= 1 (px), found 716.0"),
        ("fov_deg = 42.9", "fov_deg = \"42.9\"", "project.toml [sensor.fov_deg]: expected a number in (0, 180) (deg)"),
        ("fov_deg = 42.9", "fov_deg = 42.9\nfocal_length_mm = 50", "project.toml [sensor.focal_length_mm]: not a key"),
        ('kind = "whiskbroom"', 'kind = "frame"', "project.toml [sensor.kind]: expected one of whiskbroom, pushbroom"),
        ('crs = "EPSG:32633"', "crs = 32633", "project.toml [project.crs]: expected a string, found 32633"),
        ('crs = "EPSG:32633"', "", "project.toml [project.crs]: missing (required)"),
        ('id = "02"', "id = 2.5", "project.toml [strips[1].id]: expected a string or an integer, found 2.5"),
        ('id = "02"', 'id = "01"', "project.toml: strip id '01' appears more than once"),
        ("first_line_time = 300155.96", 'first_line_time = "300155.96"',
         "project.toml [strips[1].first_line_time]: expected a number (s), found '300155.96'"),
        ("[sensor]", "[sensr]\na = 1\n[sensor]", "project.toml: unknown table [sensr]"),
    ]:
        assert old in text
        with pytest.raises(ProjectFileError) as info:
            read_project_file(tomllib.loads(text.replace(old, new, 1)), "project.toml")
        assert str(info.value).startswith(expected), str(info.value)


def test_variants_file(tmp_path):
    path = tmp_path / "variants.toml"
    shutil.copy(EXAMPLE / "variants.toml", path)
    assert list(read_variants(path)) == ["SE", "P2", "S2"]
    text = path.read_text()
    for old, new, expected in [
        ('strategy = "SE"', 'strategy = "XX"',
         "[variants.SE.strategy]: expected one of DG, BE, ME, SE, P, S, found 'XX'"),
        ("dtm_heights = true", 'dtm_heights = "true"', "[variants.P2.dtm_heights]: expected true or false"),
        ("position_degree = 4", "position_degree = 11", "[variants.P2.strip[0].position_degree]: expected an integer"),
        ('"K1*" = "control"', '"K1*" = "boss"', "[variants.S2.roles.K1*]: expected one of control"),
        ("gps_sigma_m = [0.05, 0.05, 0.10]", "gps_sigma_m = [0.05, 0.05]", "[variants.SE.gps_sigma_m]: expected 3"),
    ]:
        assert old in text
        path.write_text(text.replace(old, new, 1))
        with pytest.raises(ProjectFileError) as info:
            read_variants(path)
        assert str(info.value).startswith(f"{path} {expected}"), str(info.value)


def test_preset_values():
    with pytest.raises(ProjectFileError) as info:
        config_from_dict({"flight": {"sidelap": 0.95}}, "p.toml")
    assert str(info.value) == "p.toml [flight.sidelap]: expected a number in [0, 0.9), found 0.95"
    with pytest.raises(ProjectFileError) as info:
        config_from_dict({"output": {"images": "no"}}, "p.toml")
    assert str(info.value) == "p.toml [output.images]: expected true or false, found 'no'"


def test_the_docs_tables_are_generated_from_the_schema():
    from scangeo.io.schema_docs import BLOCK, main

    docs = Path(__file__).resolve().parents[2] / "docs" / "formats.md"
    names = [m.group("name") for m in BLOCK.finditer(docs.read_text())]
    assert "scangeo.io.project_schema.SensorKeys" in names and "scangeo.rectify.options.RectifyOptions" in names
    assert main([str(docs), "--check"]) == 0, "run: python -m scangeo.io.schema_docs docs/formats.md"
