"""Overlaps and their cells (scangeo.match.overlaps) on strips that are rectangles on the ground."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.match import overlaps


class Rect:
    """A strip that sees the ground inside a rectangle (1 m pixels: the margin shrinks it in metres)."""

    def __init__(self, box):
        self.box = box
        self.calls = 0

    def sees(self, x, y, margin_px=0.0):
        self.calls += 1
        x0, y0, x1, y1 = self.box
        x, y = np.asarray(x, float), np.asarray(y, float)
        return (x >= x0 + margin_px) & (x <= x1 - margin_px) & (y >= y0 + margin_px) & (y <= y1 - margin_px)


def _block(n, width=1000.0, spacing=300.0, length=3000.0):
    """``n`` north-south strips side by side, ``spacing`` apart: every point in up to 4 strips."""
    return {f"{i:02d}": Rect((i * spacing, 0.0, i * spacing + width, length)) for i in range(n)}


@pytest.fixture
def rect_boxes(monkeypatch):
    monkeypatch.setattr(overlaps, "boxes", lambda strips: {s: r.box for s, r in strips.items()})


def test_triple_overlaps_name_every_further_strip_that_sees_the_cell(rect_boxes):
    strips = _block(6)
    found, _ = overlaps.find_overlaps(strips, res=5.0, per_overlap=200, per_cell=10, margin_px=4.0)
    assert {o.name for o in found} == {f"{a:02d}-{b:02d}" for a in range(6) for b in range(a + 1, min(a + 4, 6))}
    triples = 0
    for o in found:
        assert o.cells
        for c in o.cells:
            cx, cy = np.array([0.5 * (c.xmin + c.xmax)]), np.array([0.5 * (c.ymin + c.ymax)])
            expected = tuple(s for s in strips if s not in (o.a, o.b) and strips[s].sees(cx, cy, 4.0)[0])
            assert c.others == expected
            triples += bool(c.others)
    assert triples > 20


def test_work_per_overlap_does_not_grow_with_the_block(rect_boxes):
    calls = {}
    for n in (6, 24):
        strips = _block(n)
        found, _ = overlaps.find_overlaps(strips, res=5.0, per_overlap=200, per_cell=10, margin_px=4.0)
        calls[n] = sum(r.calls for r in strips.values()) / len(found)
    # the pair's own lattice (2 calls) and the strips near the overlap; not every strip of the block
    assert calls[24] <= 1.15 * calls[6]
    assert calls[24] < 12


def test_tasks_open_the_project_and_orientation_once_and_strips_share_the_local_map(tiny_project):
    import os

    from scangeo.match.options import MatchOptions
    from scangeo.match.strips import MatchStrip
    from scangeo.match.tasks import clear_caches
    from scangeo.orientation.reuse import orientation_of, project_of

    root = tiny_project.root
    clear_caches()
    project = project_of(str(root))
    assert project_of(str(root)) is project and orientation_of(project, "DG") is orientation_of(project, "DG")
    a = MatchStrip(project, "DG", "1", MatchOptions(), orientation=orientation_of(project, "DG"))
    b = MatchStrip(project, "DG", "2", MatchOptions())
    # one polynomial map -> project frame per DTM, and it is the exact conversion to 1 mm
    assert a.geometry._to_project is not None and a.geometry._to_project is b.geometry._to_project
    x = tiny_project.x0 + np.array([0.0, 250.0, 500.0])
    y = tiny_project.y0 + np.array([-800.0, 0.0, 800.0])
    H = np.full(3, tiny_project.ground_H)
    exact = project.map_frame.map_to_project(x, y, H)
    assert np.abs(b.geometry.map_to_project(x, y, H) - exact).max() < 1e-3
    # the nadir ground point of strip 1 is seen by strip 1 at its centre pixel
    line, pixel = a.image_of(np.array([tiny_project.x0]), np.array([tiny_project.y0]))
    assert abs(pixel[0] - (tiny_project.pixels - 1) / 2) < 0.05
    # a changed project file is read again
    toml = root / "project.toml"
    st = toml.stat()
    os.utime(toml, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert project_of(str(root)) is not project
    clear_caches()
