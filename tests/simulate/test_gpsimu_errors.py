"""The excursion shapes of the GPS/IMU error model."""
from __future__ import annotations

import numpy as np

from scangeo.simulate.gpsimu_errors import piecewise_excursion


def test_kinked_excursion_passes_the_values_with_kinks_and_bulges():
    knots = np.array([0.0, 96.0, 196.0, 280.0])  # seconds (lines 0, 2400, 4900, 7000 at 25 Hz)
    t = np.linspace(-10.0, 290.0, 30001)
    z = piecewise_excursion(t, knots, (5.0, 19.0, -18.0, -4.0), (3.0, -4.0, 2.0))
    for k, v in zip(knots, (5.0, 19.0, -18.0, -4.0)):
        assert abs(np.interp(k, t, z) - v) < 1e-3  # through the values, continuous
    assert z[0] == 5.0 and z[-1] == -4.0  # constant outside
    mid = 0.5 * (knots[0] + knots[1])
    assert abs(np.interp(mid, t, z) - (12.0 + 3.0)) < 1e-3  # linear + the full bulge at mid-piece
    slope = np.gradient(z, t)
    i = np.searchsorted(t, knots[1])
    assert slope[i - 5] > 0.0 > slope[i + 5] and slope[i - 5] - slope[i + 5] > 0.4  # a kink at the inner knot


def test_smooth_excursion_is_c1():
    knots = np.array([0.0, 96.0, 196.0, 280.0])
    t = np.linspace(0.0, 280.0, 28001)
    z = piecewise_excursion(t, knots, (5.0, 19.0, -18.0, -4.0), (0.0, 0.0, 0.0), shape="smooth")
    assert abs(np.interp(96.0, t, z) - 19.0) < 1e-6
    slope = np.gradient(z, t)
    assert np.max(np.abs(np.diff(slope))) < 1e-3  # no jump of the slope anywhere
