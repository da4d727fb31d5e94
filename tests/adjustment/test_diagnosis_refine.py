"""Placing breaks by the split model's profile (scangeo.adjustment.diagnosis_refine) on known cost functions."""
from __future__ import annotations

import math

import pytest

from scangeo.adjustment.diagnosis_patterns import BreakEstimate
from scangeo.adjustment.diagnosis_refine import Profile, RefineOptions, refine_breaks


def parabola_cost(true: dict[str, list[float]], scale: float, calls: list):
    """vTPv = 300 + sum ((b - true) / scale)^2 over every break: a profile whose 95 % interval is
    true +- 1.96 scale (sigma0 1)."""

    def cost(breaks):
        calls.append({s: tuple(b) for s, b in breaks.items()})
        total = 300.0
        for s, lines in breaks.items():
            total += sum(((b - t) / scale) ** 2 for b, t in zip(sorted(lines), true[s]))
        return total, 1.0

    return cost


def test_a_break_found_early_moves_to_the_profiles_minimum_with_its_interval():
    calls: list = []
    start = [BreakEstimate("02", 900.0, 850.0, 950.0), BreakEstimate("02", 2300.0, 2250.0, 2350.0)]
    out, profiles = refine_breaks(start, {"01": 3500, "02": 3500}, parabola_cost({"02": [1200.0, 2450.0]}, 60.0, calls))
    step = RefineOptions().coarse_fraction * 3500
    for b, true in zip(out, (1200.0, 2450.0)):
        assert abs(b.line - true) <= 0.25 * step, b
        assert b.low < true < b.high, b
        # the interval of the parabola: true +- 1.96 * 60 (linear interpolation between probes)
        assert (b.high - b.low) == pytest.approx(2 * 1.96 * 60.0, rel=0.25), b
        assert b.method == "S model"
    assert [b.bic_line for b in out] == [900.0, 2300.0]
    # 7 coarse probes and 4 finer ones per break, every probe with the other break where it stands
    assert len(calls) == 22
    assert all(c["02"][1] == 2300.0 for c in calls[:11]) and all(c["02"][0] == out[0].line for c in calls[11:])
    assert profiles[0].best() == out[0].line


def test_a_break_stays_between_its_neighbours_and_off_the_strip_ends():
    calls: list = []
    # the profile wants both breaks at line 10: the first may go down to the least gap, the second not past the first
    start = [BreakEstimate("02", 150.0, 100.0, 200.0), BreakEstimate("02", 300.0, 250.0, 350.0)]
    out, _ = refine_breaks(start, {"02": 1000}, parabola_cost({"02": [10.0, 10.0]}, 30.0, calls))
    gap = RefineOptions().min_gap_fraction * 1000
    assert out[0].line == pytest.approx(gap, abs=1.0)
    assert out[1].line == pytest.approx(out[0].line + gap, abs=1.0)
    assert all(min(c["02"]) >= gap - 1.0 for c in calls)


def test_probes_that_all_fail_keep_the_bic_estimate():
    start = [BreakEstimate("02", 400.0, 380.0, 420.0)]
    out, profiles = refine_breaks(start, {"02": 1000}, lambda breaks: (math.inf, math.nan))
    assert out == start and profiles[0].sigma0 != profiles[0].sigma0


def test_profile_interval_interpolates_to_the_chi2_level():
    p = Profile([0.0, 10.0, 20.0, 30.0], [10.0, 3.0, 2.0, 10.0], 1.0)
    low, high = p.interval()
    # the level is 2 + 3.84 = 5.84: between 0 and 10 (10 -> 3) and between 20 and 30 (2 -> 10)
    assert low == pytest.approx(10.0 - 10.0 * (5.84 - 3.0) / 7.0, abs=0.01)
    assert high == pytest.approx(20.0 + 10.0 * 3.841 / 8.0, abs=0.01)
    assert p.best() == 20.0
