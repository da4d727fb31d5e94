import numpy as np
import pytest

from scangeo.errors import ProjectFileError
from scangeo.timing import LineTiming


def test_rate_timing_round_trip():
    t = LineTiming(1000.0, 25.0)
    assert t.time_of_line(np.array([0.0, 25.0]))[1] == pytest.approx(1001.0)
    lines = np.linspace(-3, 500, 77)
    assert np.allclose(t.line_of_time(t.time_of_line(lines)), lines)


def test_table_timing_interpolates_and_extrapolates(tmp_path):
    times = 50.0 + np.cumsum(np.r_[0, np.full(99, 0.04) + np.linspace(0, 0.001, 99)])
    f = tmp_path / "lines.csv"
    np.savetxt(f, np.column_stack([np.arange(100), times]), delimiter=",", header="line,time", comments="")
    t = LineTiming.from_table_file(f)
    lines = np.linspace(-2, 103, 301)
    assert np.allclose(t.line_of_time(t.time_of_line(lines)), lines)
    assert t.time_of_line(np.array([10.0]))[0] == pytest.approx(times[10])


def test_table_must_increase(tmp_path):
    f = tmp_path / "lines.csv"
    f.write_text("line,time\n0,1.0\n1,1.04\n2,1.04\n")
    with pytest.raises(ProjectFileError, match="line 4"):
        LineTiming.from_table_file(f)
