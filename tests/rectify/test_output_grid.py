"""Output grid: alignment to the resolution, union, offsets, nice resolutions."""
import numpy as np
import pytest

from scangeo.errors import ScangeoError
from scangeo.rectify.output_grid import OutputGrid, nice_resolution


def test_from_bounds_snaps_edges_outwards_to_multiples_of_the_resolution():
    g = OutputGrid.from_bounds("EPSG:32633", (1001.3, 2000.1, 1010.2, 2007.4), 2.5)
    assert (g.xmin, g.ymax, g.width, g.height) == (1000.0, 2007.5, 5, 3)
    assert g.bounds == (1000.0, 2000.0, 1012.5, 2007.5)
    # cell centres: first column at xmin + res/2, first row at ymax - res/2
    assert g.x_of_col(0) == 1001.25 and g.y_of_row(0) == 2006.25
    assert g.col_of_x(g.x_of_col(3)) == pytest.approx(3) and g.row_of_y(g.y_of_row(2)) == pytest.approx(2)
    assert g.transform * (0, 0) == (1000.0, 2007.5)


def test_bounds_on_the_lattice_stay_put():
    g = OutputGrid.from_bounds("EPSG:32633", (0.0, 0.0, 10.0, 5.0), 2.5)
    assert (g.width, g.height, g.xmin, g.ymax) == (4, 2, 0.0, 5.0)


def test_union_and_offsets_of_aligned_grids():
    a = OutputGrid.from_bounds("EPSG:32633", (0, 0, 10, 10), 1.0)
    b = OutputGrid.from_bounds("EPSG:32633", (5, -3, 20, 4), 1.0)
    u = OutputGrid.union([a, b])
    assert u.bounds == (0.0, -3.0, 20.0, 10.0)
    assert a.offset_in(u) == (0, 0)
    assert b.offset_in(u) == (6, 5)
    c = OutputGrid("EPSG:32633", 1.0, 0.5, 10.0, 3, 3)
    with pytest.raises(ScangeoError, match="not aligned"):
        c.offset_in(u)


def test_tiles_cover_the_grid_once():
    g = OutputGrid("EPSG:32633", 1.0, 0.0, 100.0, 70, 45)
    cover = np.zeros(g.shape, int)
    for w in g.tiles(32):
        cover[w.row_off:w.row_off + w.height, w.col_off:w.col_off + w.width] += 1
    assert (cover == 1).all()


def test_nice_resolution_and_bad_input():
    assert nice_resolution(2.487) == 2.5
    assert nice_resolution(0.3142) == 0.31
    with pytest.raises(ScangeoError):
        nice_resolution(0.0)
    with pytest.raises(ScangeoError, match="invalid bounds"):
        OutputGrid.from_bounds("EPSG:32633", (5, 0, 1, 1), 1.0)
