"""Break selection by BIC on synthetic misclosures with known strip error functions (no adjustment)."""
from __future__ import annotations

import numpy as np
import pytest

from scangeo.adjustment.diagnosis.diagnose import _ray_weights
from scangeo.adjustment.diagnosis.patterns import (
    PatternData,
    SelectionOptions,
    break_intervals,
    design,
    evaluate,
    select_breaks,
)

N = 1000  # lines per strip


def _three_strips(problem, noise=1.0, rho=0.0, seed=0, per_overlap=60) -> PatternData:
    """Misclosures of tie points in the overlaps 0-1 and 1-2 of three strips (the middle one flown the other
    way); each row sees its two strips' vertical errors with weight 0.5 and their across-track errors with
    +-0.8 (the ray-intersection sensitivity), plus AR(1) noise along the overlap."""
    rng = np.random.default_rng(seed)
    value, trow, tstrip, tcomp, tline, tw = [], [], [], [], [], []
    for a, b in ((0, 1), (1, 2)):
        la = np.sort(rng.uniform(0, N - 1, per_overlap))
        lb = N - 1 - la
        e = np.zeros(per_overlap)
        for i in range(per_overlap):
            e[i] = (rho * e[i - 1] if i else 0.0) + rng.normal(0, noise) * np.sqrt(1 - rho**2)
        for i in range(per_overlap):
            r = len(value)
            y = e[i]
            for s, line, sign in ((a, la[i], 1.0), (b, lb[i], -1.0)):
                fz, fx = problem(s, line)
                y += 0.5 * fz + 0.8 * sign * fx
                for k, w in ((0, 0.8 * sign), (1, 0.5)):
                    trow.append(r)
                    tstrip.append(s)
                    tcomp.append(k)
                    tline.append(line)
                    tw.append(w)
            value.append(y)
    n = len(value)
    return PatternData(np.array(value), np.zeros(n, int), np.array(trow), np.array(tstrip), np.array(tcomp),
                       np.array(tline), np.array(tw), ("01", "02", "03"), (N, N, N), ("misclosure_m",),
                       ("across_m", "vertical_m"))


def kinked(s, line):
    """Strip 02: height excursion with kinks at lines 300 and 700, an across-track drift along with it."""
    if s != 1:
        return 0.0, 0.0
    z = np.interp(line, [0, 300, 700, N - 1], [4.0, 18.0, -18.0, -4.0])
    return z, 0.2 * z


def test_the_problem_strip_and_its_breaks_are_found():
    for seed in range(2):
        data = _three_strips(kinked, seed=seed)
        fit = select_breaks(data)
        assert fit.breaks[0] == () and fit.breaks[2] == ()
        assert len(fit.breaks[1]) == 2
        assert np.allclose(fit.breaks[1], [300, 700], atol=25), fit.breaks
        assert set(fit.constant) == {0, 2}  # the good strips need no more than SE's constant
        for b, truth in zip(break_intervals(data, fit), (300, 700)):
            assert b.strip == "02" and b.low <= truth <= b.high and b.high - b.low < 150


def test_no_break_in_noise_even_when_it_is_correlated():
    quiet = lambda s, line: (0.0, 0.0)  # noqa: E731
    found = [select_breaks(_three_strips(quiet, noise=2.0, rho=0.5, seed=seed)).breaks for seed in range(4)]
    assert sum(any(b) for b in found) == 0, found


def test_serial_correlation_keeps_correlated_noise_from_buying_breaks():
    quiet = lambda s, line: (0.0, 0.0)  # noqa: E731
    data = _three_strips(quiet, noise=2.0, rho=0.85, seed=5, per_overlap=40)
    plain = select_breaks(data, SelectionOptions(serial_correlation=False))
    corrected = select_breaks(data)
    assert sum(len(b) for b in corrected.breaks) <= sum(len(b) for b in plain.breaks)
    assert sum(len(b) for b in corrected.breaks) == 0


def test_design_is_continuous_at_a_break():
    data = _three_strips(kinked, seed=1)
    A, cols = design(data, [[], [400.0], []])
    assert len(cols) == 2 * (2 + 3 + 2)
    # a row at the break line itself sees only the break node of strip 02
    rows = PatternData(np.zeros(2), np.zeros(2, int), np.array([0, 1]), np.array([1, 1]), np.array([1, 1]),
                       np.array([400.0 - 1e-9, 400.0 + 1e-9]), np.ones(2), data.strips, data.n_lines,
                       data.channels, data.components)
    A, cols = design(rows, [[], [400.0], []])
    assert np.allclose(A[0], A[1], atol=1e-9)
    # degree 2 adds a bubble per segment that vanishes at the nodes
    A2, cols2 = design(rows, [[], [400.0], []], degree=2)
    assert len(cols2) == len(cols) + 2 * (1 + 2 + 1) and np.allclose(A2[:, len(cols):], 0.0, atol=1e-6)


def test_bic_counts_the_breaks_and_the_rank():
    data = _three_strips(kinked, seed=2)
    constant = evaluate(data, [[], [], []], constant=range(3))
    split = evaluate(data, [[], [300.0, 700.0], []], constant=(0, 2))
    # constant errors give one constant misclosure per overlap: rank 2 of the 6 columns
    assert constant.k == 2
    # strip 02's two functions with 4 nodes each make any pair of piecewise-linear functions on its two
    # overlaps (rank 8, the constant strips add nothing to it), plus the 2 break positions
    assert split.k == 8 + 2
    assert split.bic < constant.bic - 100


def test_ray_intersection_sensitivity():
    # two rays meeting at the origin from sensors 1000 m up, 400 m to either side
    centres = np.array([[-400.0, 0.0, 1000.0], [400.0, 0.0, 1000.0]])
    g = _ray_weights(centres, np.zeros(3))
    assert g[:, 2] == pytest.approx([0.5, 0.5])  # a height shift of one strip lifts the point by half of it
    assert g.sum(axis=0) == pytest.approx([0.0, 0.0, 1.0])  # a common shift moves the point by the shift
    # moving the western sensor east lifts the point along the eastern ray: 1 / (tan a - tan b) = 1000 / 800
    assert g[0, 0] == pytest.approx(-g[1, 0]) and g[0, 0] == pytest.approx(1000 / 800)

def test_a_model_that_saturates_a_channel_is_not_scored():
    from scangeo.adjustment.diagnosis.local_fit import MIN_REDUNDANCY

    # 7 tie points per overlap, 14 rows: strip 02's functions with two breaks take rank 8 (6 residual degrees of
    # freedom left), with four rank 10 (4 left, fewer than a model with breaks must leave)
    rows = 14
    data = _three_strips(kinked, seed=2, per_overlap=rows // 2)
    none = evaluate(data, [[], [], []], constant=range(3))
    two = evaluate(data, [[], [300.0, 700.0], []], constant=(0, 2))
    four = evaluate(data, [[], [150.0, 300.0, 500.0, 700.0], []], constant=(0, 2))
    assert rows - (two.k - 2) >= MIN_REDUNDANCY > rows - (four.k - 4)
    assert np.isfinite(none.bic) and np.isfinite(two.bic) and two.bic < none.bic
    assert four.bic == np.inf
    assert four.deviance < two.deviance  # what the criterion would have bought from the collapsing variance
    found = select_breaks(data)
    assert np.isfinite(found.bic) and len(found.breaks[1]) <= 3
