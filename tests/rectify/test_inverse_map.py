"""Inverse map: interpolated (line, pixel) against exact solutions at every cell."""
import numpy as np
import pytest

from rectify_synthetic import AnalyticStrip, flat, hills, make_dtm
from scangeo.errors import ScangeoError
from scangeo.rectify.inverse_map import InverseMapOptions, TileGrid, build_inverse_map


def tile_of(strip, x0, y0, res, rows, cols):
    x = x0 + np.arange(cols) * res
    y = y0 - np.arange(rows) * res
    X, Y = np.meshgrid(x, y)
    return TileGrid(x0, y0, res), X, Y, strip.height(X, Y)


def exact_errors(strip, X, Y, H, line, pixel):
    el, ep = strip.ground_to_image(X, Y, H)
    seen = (el >= -0.5) & (el <= strip.lines - 0.5) & (ep >= -0.5) & (ep <= strip.pixels - 0.5)
    return seen, np.maximum(np.abs(el - line), np.abs(ep - pixel))


@pytest.mark.parametrize(
    "terrain, roll, nan_outside",
    [(flat(300.0), 0.0, False), (hills, 0.0, False), (hills, 0.003, False), (hills, 0.003, True)],
    ids=["flat", "hills", "hills+roll", "hills+roll+nan"],
)
def test_every_cell_within_tolerance_of_the_exact_solution(terrain, roll, nan_outside):
    dtm = make_dtm(terrain, 499_000, 501_000, 4_999_500, 5_001_000, 2.0)
    strip = AnalyticStrip(dtm, roll_amp=roll, roll_period=4.0, nan_outside=nan_outside)
    # a tile wider than the swath and reaching past the strip's first line
    grid, X, Y, H = tile_of(strip, 499_800.0, 5_000_300.0, 1.7, 220, 250)
    opts = InverseMapOptions(max_error_px=0.05)
    line, pixel, stats = build_inverse_map(strip.ground_to_image, grid, H, (strip.lines, strip.pixels), opts)
    seen, err = exact_errors(strip, X, Y, H, line, pixel)
    assert seen.sum() > 20_000
    assert np.nanmax(err[seen]) <= 0.05
    assert np.isfinite(line[seen]).all()
    # the coarse lattice does the work: fewer exact solutions than cells (a core that gives no
    # answer beyond the swath costs small blocks along its edges)
    assert stats.exact_points < (0.8 if nan_outside else 0.6) * H.size
    assert 0 < stats.max_error_px <= 0.05 and stats.validated == 256


def test_smooth_geometry_uses_large_blocks_and_attitude_shake_is_absorbed_by_the_baseline():
    dtm = make_dtm(flat(300.0), 499_000, 501_000, 4_999_500, 5_001_000, 2.0)
    high = AnalyticStrip(dtm, Zs=2500.0, step=0.00125)
    grid, X, Y, H = tile_of(high, 499_900.0, 5_000_500.0, 2.5, 128, 128)
    _, _, smooth = build_inverse_map(high.ground_to_image, grid, H, (high.lines, high.pixels), along=(0, 1))
    assert set(smooth.blocks) == {(32, 32)} and smooth.exact_cells == 0
    assert smooth.exact_points < 0.15 * H.size
    # roll shaking at 2 s (0.11 deg): the along-track profiles take it out, blocks stay large
    shaky = AnalyticStrip(dtm, Zs=2500.0, step=0.00125, roll_amp=0.002, roll_period=2.0)
    line, pixel, rough = build_inverse_map(shaky.ground_to_image, grid, H, (shaky.lines, shaky.pixels), along=(0, 1))
    assert set(rough.blocks) == {(32, 32)} and rough.exact_points < 0.15 * H.size
    seen, err = exact_errors(shaky, X, Y, H, line, pixel)
    assert np.nanmax(err[seen]) <= 0.05
    # and without the baseline (the lattice alone) the same tile would need thin blocks
    import scangeo.rectify.inverse_map as im

    original = im._Baseline.measure
    try:
        im._Baseline.measure = classmethod(lambda cls, solve, lattice, uc, vc, hc, *a: cls(
            np.array([0.0, 1.0]), np.zeros(1), np.zeros(1), np.zeros((2, 1, 1)), np.zeros((2, 1, 1))))
        line, pixel, bare = build_inverse_map(shaky.ground_to_image, grid, H, (shaky.lines, shaky.pixels), along=(0, 1))
    finally:
        im._Baseline.measure = original
    assert min(bu for bu, _ in bare.blocks) <= 4 and bare.exact_points > 2 * rough.exact_points
    seen, err = exact_errors(shaky, X, Y, H, line, pixel)
    assert np.nanmax(err[seen]) <= 0.05


def test_lattice_follows_a_diagonal_flight():
    """The same shaking strip seen on a grid rotated by 40 degrees: blocks still thin along track."""
    dtm = make_dtm(flat(300.0), 499_000, 501_000, 4_999_500, 5_001_000, 2.0)
    shaky = AnalyticStrip(dtm, Zs=2500.0, step=0.00125, roll_amp=0.002, roll_period=2.0)
    a = np.radians(40.0)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    centre = np.array([500_000.0, 5_000_300.0])

    def g2i(x, y, H):  # the strip in a map rotated by 40 degrees about the centre
        xy = (np.stack([x, y], -1) - centre) @ rot + centre
        return shaky.ground_to_image(xy[..., 0], xy[..., 1], H)

    grid = TileGrid(499_850.0, 5_000_450.0, 2.5)
    H = np.full((120, 120), 300.0)
    along = rot @ np.array([0.0, 1.0])
    line, pixel, stats = build_inverse_map(g2i, grid, H, (shaky.lines, shaky.pixels), along=tuple(along))
    X, Y = np.meshgrid(grid.x0 + np.arange(120) * 2.5, grid.y0 - np.arange(120) * 2.5)
    el, ep = g2i(X, Y, H)
    seen = (el >= 0) & (el <= shaky.lines - 1) & (ep >= 0) & (ep <= shaky.pixels - 1)
    assert np.abs(np.maximum(np.abs(el - line), np.abs(ep - pixel))[seen]).max() <= 0.05
    assert stats.exact_points < 0.5 * H.size


def test_tighter_tolerance_is_met_and_costs_more():
    dtm = make_dtm(hills, 499_000, 501_000, 4_999_500, 5_001_000, 2.0)
    strip = AnalyticStrip(dtm, roll_amp=0.002)
    grid, X, Y, H = tile_of(strip, 499_850.0, 5_000_500.0, 2.0, 100, 150)
    shape = (strip.lines, strip.pixels)
    _, _, loose = build_inverse_map(strip.ground_to_image, grid, H, shape, InverseMapOptions(max_error_px=0.2))
    line, pixel, tight = build_inverse_map(strip.ground_to_image, grid, H, shape, InverseMapOptions(max_error_px=0.02))
    seen, err = exact_errors(strip, X, Y, H, line, pixel)
    assert np.nanmax(err[seen]) <= 0.02
    assert tight.exact_points > loose.exact_points


def test_cells_without_height_and_tiles_outside_the_swath_stay_unseen():
    dtm = make_dtm(hills, 499_000, 501_000, 4_999_500, 5_001_000, 2.0)
    strip = AnalyticStrip(dtm, nan_outside=True)
    grid, X, Y, H = tile_of(strip, 499_850.0, 5_000_500.0, 2.0, 64, 64)
    H[10:20, 5:40] = np.nan
    line, pixel, _ = build_inverse_map(strip.ground_to_image, grid, H, (strip.lines, strip.pixels))
    seen, err = exact_errors(strip, X, Y, H, line, pixel)
    assert np.isnan(line[10:20, 5:40]).all()
    assert seen.sum() > 1000 and np.isfinite(line[seen]).all() and err[seen].max() <= 0.05
    far = TileGrid(502_000.0, 5_000_500.0, 2.0)
    line, _, stats = build_inverse_map(strip.ground_to_image, far, np.full((64, 64), 300.0), (strip.lines, strip.pixels))
    assert np.isnan(line).all() or (np.abs(line) >= 0).all()
    assert stats.exact_points < 200  # the whole tile is dismissed at the first level


@pytest.mark.parametrize("kw", [{"max_error_px": 0}, {"initial_block": 24}, {"exact_cells": 0}])
def test_bad_options(kw):
    with pytest.raises(ScangeoError):
        InverseMapOptions(**kw)
