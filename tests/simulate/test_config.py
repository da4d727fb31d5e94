"""Presets are data: typed, checked, with errors that name the key."""
from __future__ import annotations

import pytest

from scangeo.errors import ProjectFileError
from scangeo.resources import PRESETS
from scangeo.simulate.config import available_presets, load_preset


def test_shipped_presets_load():
    assert {"small", "vienna2000", "block24"} <= set(available_presets())
    v = load_preset("vienna2000")
    assert (v.sensor.pixels, v.sensor.fov_deg, v.sensor.line_rate_hz) == (716, 42.9, 25.0)
    assert v.flight.strips == 3 and v.flight.lines == 7000
    assert v.gpsimu_errors.problem_strip == 2 and v.gpsimu_errors.breaks_lines == (2400.0, 4900.0)
    problem = v.strip_errors(2)
    assert max(abs(z) for z in problem.excursion_z_m) <= 20.0
    assert v.strip_errors(1).excursion_z_m == ()  # good strips take the defaults
    assert load_preset("block24").flight.strips == 24


def test_a_users_file_and_overrides(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text((PRESETS / "small.toml").read_text().replace("lines = 600", "lines = 321"))
    config = load_preset(path, {"points": {"blunders": 3}})
    assert config.flight.lines == 321 and config.points.blunders == 3
    assert config.source == str(path)


@pytest.mark.parametrize("text, key", [
    ("[flight]\nlnes = 3\n", "lnes"),
    ("[flight.turbulence]\nroll = 1.0\n", "roll"),
    ("[[gpsimu_errors.strip]]\nstrip = 1\nexcursion_lines = [0.0, 10.0]\nexcursion_z_m = [1.0]\n", "excursion_z_m"),
    ("[sensor]\npixels = \"many\"\n", "pixels"),
    ("[flight]\ndirection = \"east\"\n", "flight.direction"),
    ("[gpsimu_errors]\nproblem_strip = 5\n", "problem_strip"),
])
def test_bad_keys_and_values_are_named(tmp_path, text, key):
    path = tmp_path / "bad.toml"
    path.write_text("[block]\ncentre_lonlat = [16.3, 48.2]\n" + text)
    with pytest.raises(ProjectFileError, match=key) as info:
        load_preset(path)
    assert str(path) in str(info.value)


def test_unknown_preset_lists_the_known_ones():
    with pytest.raises(ProjectFileError, match="vienna2000"):
        load_preset("vienna1999")
