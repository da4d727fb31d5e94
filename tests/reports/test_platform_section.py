"""The report's platform section: the sensors' mountings, the relative mounting against its prior, and a
strip without control said so with its propagated precision."""
from __future__ import annotations

import html
import re

from scangeo.adjustment.outputs import write_results
from scangeo.adjustment.results import run_variant
from scangeo.adjustment.variants import Variant
from scangeo.reports.platform_section import platform_section
from tests.session_projects import as_platform, copy_project


def _text(section) -> str:
    return html.unescape(re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", "\n".join(section.parts))))


def test_the_platform_section_shows_mountings_and_the_strips_without_control(small_block, tmp_path):
    prior = ('[[relative_mountings]]\nsensor = "b"\nreference = "a"\nboresight_deg = [0.0, 0.0, 0.0]\n'
             'boresight_sigma_deg = [0.001, 0.001, 0.002]\n\n')
    root = copy_project(small_block, tmp_path / "p", truth=True)
    as_platform(root, second="checks", prior=prior, b_offset_deg=0.2)
    variant = Variant("SE_B", "SE", attitude_degree=-1, calibrate=("boresight",))
    write_results(run_variant(root, variant))
    section = platform_section(root / "results", "SE_B")
    assert section is not None and section.section_id == "platform"
    text = _text(section)
    # the relative mounting: adjusted (the prior alone holds b: its value and sigma), the prior, the lever arms
    assert re.search(r"b to a -?0\.0000 ± 0\.0010, -?0\.0000 ± 0\.0010, -?0\.0000 ± 0\.0020 "
                     r"0\.0000 ± 0\.0010, 0\.0000 ± 0\.0010, 0\.0000 ± 0\.0020 0\.0000, 0\.0000, 0\.0000", text)
    for sid in ("b01", "b02"):
        assert re.search(rf"strip {sid} \(b\) has no control point; it is georeferenced through its flight line "
                         rf"L{sid[1:]}'s trajectory corrections \(shared with {sid[1:]}\) and its mounting from the "
                         r"relative-mounting prior to a: propagated ground precision \d\.\d{3} m", text)
    assert "strip 01 (a) has no control" not in text
    assert platform_section(root / "results", "NOPE") is None


def test_a_one_sensor_project_has_no_platform_section(small_block, tmp_path):
    root = copy_project(small_block, tmp_path / "one", truth=True)
    write_results(run_variant(root, Variant("SE", "SE")))
    assert platform_section(root / "results", "SE") is None
