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
