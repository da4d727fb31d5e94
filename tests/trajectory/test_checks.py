"""Plausibility checks of trajectories: coverage and gaps name lines and times; attitudes in
radians, or beyond plausible roll/pitch, are reported naming the file."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from scangeo.errors import TrajectoryError
from scangeo.trajectory.checks import StripTimes, attitude_findings, check_coverage, check_gaps, check_strip_trajectory
from scangeo.trajectory.stream import GpsImuStream


def flight(heading_deg: float = 30.0, n: int = 501, rate: float = 50.0, speed: float = 60.0, roll_deg=1.0,
           pitch_deg=2.0, gap: tuple[int, int] | None = None) -> GpsImuStream:
    """A straight flight at 48 deg N on course ``heading_deg`` (true heading = course, no crab)."""
    t = 1000.0 + np.arange(n) / rate
    if gap is not None:
        keep = np.ones(n, bool)
        keep[gap[0]:gap[1]] = False
        t = t[keep]
    s = speed * (t - t[0])
    c = np.radians(heading_deg)
    lat = np.radians(48.0) + s * np.cos(c) / 6.37e6
    lon = np.radians(16.0) + s * np.sin(c) / (6.39e6 * np.cos(np.radians(48.0)))
    one = np.ones_like(t)
    return GpsImuStream(t, lat, lon, 1500.0 * one, np.radians(roll_deg) * one, np.radians(pitch_deg) * one,
                        c * one, source="nav/7.csv")


def strip(first: float, last: float, rate: float = 10.0) -> StripTimes:
    return StripTimes("7", first + np.arange(int(round((last - first) * rate)) + 1) / rate)


def test_coverage_names_the_uncovered_lines():
    s = flight()  # 1000 .. 1010 s
    check_coverage(s, strip(1001.0, 1009.0))
    with pytest.raises(TrajectoryError, match=r"does not cover lines 81-100 of strip 7 "):
        check_coverage(s, strip(1002.0, 1012.0))  # lines at 1010.1 .. 1012.0 s: 81..100
    with pytest.raises(TrajectoryError, match=r"lines 0-9 of strip 7"):
        check_coverage(s, strip(999.0, 1005.0))


def test_gap_names_its_length_time_and_lines():
    s = flight(gap=(100, 600), n=1001)  # records at 1001.98 and 1012.00 s; line 70 (1012.0 s) is on a record
    with pytest.raises(TrajectoryError, match=r"gap of 10.0 s at time 1001.980 .* lines 0-69 of strip 7"):
        check_gaps(s, strip(1005.0, 1015.0))
    check_gaps(s, strip(1012.5, 1019.0))  # a gap outside the strip's lines does no harm


def test_plausible_attitudes_pass():
    assert attitude_findings(flight(heading_deg=250.0)) == []


def test_radians_written_as_degrees_are_named():
    s = flight(heading_deg=100.0, roll_deg=2.0, pitch_deg=3.0)
    # the file held radians: the reader took 1.745 (rad) for degrees
    wrong = GpsImuStream(s.time, s.lat, s.lon, s.h, np.radians(np.radians(2.0)) * np.ones(len(s)),
                         np.radians(np.radians(3.0)) * np.ones(len(s)), np.radians(s.heading), source=s.source)
    (message,) = attitude_findings(wrong)
    assert message.startswith("trajectory nav/7.csv: the heading differs from the course over ground by 98.3 deg")
    assert "look like radians" in message and "agrees to 0.0 deg" in message


def test_heading_off_course_and_roll_beyond_limits():
    s = flight(heading_deg=0.0)
    off = GpsImuStream(s.time, s.lat, s.lon, s.h, np.radians(75.0) * np.ones(len(s)), s.pitch,
                       s.heading + np.radians(90.0), source=s.source)
    course, roll = attitude_findings(off)
    assert "by 90.0 deg" in course and "true heading" in course
    assert roll == ("trajectory nav/7.csv record 1: roll of 75.0 deg is beyond a plausible 60 deg for a survey flight "
                    "(degrees expected; wrong column?)")


def test_warning_is_logged_once(caplog):
    s = flight(heading_deg=100.0)
    wrong = GpsImuStream(s.time, s.lat, s.lon, s.h, s.roll, s.pitch, np.radians(s.heading), source="nav/once.csv")
    with caplog.at_level(logging.WARNING, logger="scangeo.trajectory.checks"):
        check_strip_trajectory(wrong, strip(1001.0, 1009.0))
        check_strip_trajectory(wrong, strip(1001.0, 1009.0))
    assert [r.getMessage()[:40] for r in caplog.records] == ["trajectory nav/once.csv: the heading dif"]


def test_project_warns_on_radians(small_block, tmp_path, caplog):
    """Attitudes written in radians in a project's trajectory: the warning names the file."""
    from scangeo.io.project import Project
    from tests.session_projects import copy_project

    root = copy_project(small_block, tmp_path / "p")
    path = root / "nav" / "02.csv"
    rows = path.read_text().splitlines()
    out = [rows[0]]
    for row in rows[1:]:
        f = row.split(",")
        f[4:7] = [f"{np.radians(float(v)):.9f}" for v in f[4:7]]
        out.append(",".join(f))
    path.write_text("\n".join(out) + "\n")
    with caplog.at_level(logging.WARNING, logger="scangeo.trajectory.checks"):
        Project.load(root).stream("02")
    (record,) = caplog.records
    assert str(path) in record.getMessage() and "look like radians" in record.getMessage()
