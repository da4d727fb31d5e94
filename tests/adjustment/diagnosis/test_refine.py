"""Placing breaks by the split model's profile (scangeo.adjustment.diagnosis.refine) on known cost functions."""
from __future__ import annotations

import math

import pytest
from scipy import stats

from scangeo.adjustment.diagnosis.diagnose import dropped_notes
from scangeo.adjustment.diagnosis.patterns import BreakEstimate
from scangeo.adjustment.diagnosis.refine import Profile, RefineOptions, break_tests, refine_breaks

NO_TEST = RefineOptions(test_level=None)


def parabola_cost(true: dict[str, list[float]], scale: float, calls: list):
    """vTPv = 300 + sum ((b - true) / scale)^2 over every break: a profile whose 95 % interval is
    true +- 1.96 scale (sigma0 1)."""

    def cost(breaks):
        calls.append({s: tuple(b) for s, b in breaks.items()})
        total = 300.0
        for s, lines in breaks.items():
            total += sum(((b - t) / scale) ** 2 for b, t in zip(sorted(lines), true[s]))
        return total, 1.0, 100 + 6 * sum(len(b) for b in breaks.values())

    return cost


def kinked_cost(true: list[float], gain: list[float], scale: float, redundancy: float = 300.0):
    """A split model's vTPv on one strip ("02") with sigma0 1: each true break, when some break lies
    near it, lowers vTPv by its ``gain`` less a parabola in the distance ((d / scale)^2, at most the
    gain); 6 unknowns per break."""

    def cost(breaks):
        lines = breaks.get("02", ())
        total = redundancy + sum(gain)
        for t, g in zip(true, gain):
            if lines:
                total -= max(g - min((b - t) ** 2 for b in lines) / scale ** 2, 0.0)
        return total, math.sqrt(total / redundancy), 100 + 6 * len(lines)

    return cost


def test_a_break_found_early_moves_to_the_profiles_minimum_with_its_interval():
    calls: list = []
    start = [BreakEstimate("02", 900.0, 850.0, 950.0), BreakEstimate("02", 2300.0, 2250.0, 2350.0)]
    out, profiles = refine_breaks(start, {"01": 3500, "02": 3500}, parabola_cost({"02": [1200.0, 2450.0]}, 60.0, calls),
                                  NO_TEST)
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
    out, _ = refine_breaks(start, {"02": 1000}, parabola_cost({"02": [10.0, 10.0]}, 30.0, calls), NO_TEST)
    gap = RefineOptions().min_gap_fraction * 1000
    assert out[0].line == pytest.approx(gap, abs=1.0)
    assert out[1].line == pytest.approx(out[0].line + gap, abs=1.0)
    assert all(min(c["02"]) >= gap - 1.0 for c in calls)


def test_probes_that_all_fail_keep_the_bic_estimate():
    start = [BreakEstimate("02", 400.0, 380.0, 420.0)]
    out, profiles = refine_breaks(start, {"02": 1000}, lambda breaks: (math.inf, math.nan, 0))
    assert out == start and profiles[0].sigma0 != profiles[0].sigma0


def test_profile_interval_interpolates_to_the_chi2_level():
    p = Profile([0.0, 10.0, 20.0, 30.0], [10.0, 3.0, 2.0, 10.0], 1.0)
    low, high = p.interval()
    # the level is 2 + 3.84 = 5.84: between 0 and 10 (10 -> 3) and between 20 and 30 (2 -> 10)
    assert low == pytest.approx(10.0 - 10.0 * (5.84 - 3.0) / 7.0, abs=0.01)
    assert high == pytest.approx(20.0 + 10.0 * 3.841 / 8.0, abs=0.01)
    assert p.best() == 20.0


def test_a_break_the_split_model_does_not_need_is_dropped_and_the_others_placed_again():
    # two true breaks worth 60 each; the BIC's extra break at 700 (where nothing is) buys nothing, and
    # the others start 400 lines off
    cost = kinked_cost([2400.0, 4900.0], [60.0, 60.0], 300.0)
    start = [BreakEstimate("02", 700.0, 600.0, 800.0), BreakEstimate("02", 2000.0, 1900.0, 2100.0),
             BreakEstimate("02", 4500.0, 4400.0, 4600.0)]
    out, profiles = refine_breaks(start, {"02": 7000}, cost)
    assert len(out) == len(profiles) == 2
    step = RefineOptions().coarse_fraction * 7000
    for b, true in zip(out, (2400.0, 4900.0)):
        assert abs(b.line - true) <= 0.25 * step, b
        # F of the 7 parameters (6 unknowns + the line) against the gain of 60 (sigma0 about 1)
        assert b.f_statistic == pytest.approx(60.0 / 7.0, rel=0.1) and b.p_value < 1e-6, b
        assert b.bic_line in (2000.0, 4500.0)


def test_a_strips_last_break_is_kept_and_a_significant_one_is_not_dropped():
    # a third break worth 30 stays: without it the break at 2400 takes over part of its gain (1400 lines
    # away: 30 - (1400 / 300)^2 = 8.2 left), so vTPv rises by 21.8: F = 21.8 / 7 = 3.1, p = 0.003;
    # a strip's only break stays even when weak
    cost = kinked_cost([1000.0, 2400.0, 4900.0], [30.0, 60.0, 60.0], 300.0)
    start = [BreakEstimate("02", 1000.0, 900.0, 1100.0), BreakEstimate("02", 2400.0, 2300.0, 2500.0),
             BreakEstimate("02", 4900.0, 4800.0, 4950.0)]
    out, _ = refine_breaks(start, {"02": 7000}, cost)
    assert [round(b.line) for b in out] == [1000, 2400, 4900]
    assert out[0].f_statistic == pytest.approx((30.0 - (30.0 - (1400.0 / 300.0) ** 2)) / 7.0)
    assert out[0].p_value == pytest.approx(stats.f.sf(out[0].f_statistic, 7, 300.0)) and out[0].p_value < 0.05
    weak = kinked_cost([3000.0], [2.0], 300.0)
    out, _ = refine_breaks([BreakEstimate("02", 3000.0, 2900.0, 3100.0)], {"02": 7000}, weak)
    assert len(out) == 1 and out[0].p_value > 0.05


def test_break_tests_follow_the_f_distribution():
    cost = kinked_cost([2400.0, 4900.0], [60.0, 14.0], 300.0, redundancy=400.0)
    tests = break_tests({"02": [2400.0, 4900.0]}, cost)
    sigma0_sq = 400.0 / 400.0
    for t, gain in zip(tests, (60.0, 14.0)):
        assert t.added == 7 and t.delta_vtpv == pytest.approx(gain)
        assert t.f_statistic == pytest.approx(gain / 7.0 / sigma0_sq)
        assert t.p_value == pytest.approx(stats.f.sf(gain / 7.0, 7, 400.0))
    # 14 / 7 = 2.0 lies just below F(7, 400) at 95 % (2.03): the second break is not significant
    assert tests[1].p_value > 0.05 > tests[0].p_value


def test_a_dropped_break_is_named_in_the_diagnosis_notes():
    cost = kinked_cost([2400.0, 4900.0], [60.0, 60.0], 300.0)
    proposed = [BreakEstimate("02", 700.0, 600.0, 800.0), BreakEstimate("02", 2000.0, 1900.0, 2100.0),
                BreakEstimate("02", 4500.0, 4400.0, 4600.0)]
    kept, _ = refine_breaks(proposed, {"02": 7000}, cost)
    notes = dropped_notes(proposed, kept, 0.05)
    assert notes == ["strip 02: the BIC's break at line 700 was dropped, the split model does not need it "
                     "(F test at 5 %)"]
    assert dropped_notes(proposed, proposed, 0.05) == []
