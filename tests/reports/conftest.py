"""A small simulated block with a problem strip, compared and reported once per test session."""
from __future__ import annotations

import pytest

from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset

#: The ``small`` preset without images, its second strip made a problem strip: height excursions
#: with kinks at two break lines (the pattern of vienna2000 on 600 lines).
PROBLEM_SMALL = {
    "output": {"images": False, "truth_ortho": False},
    "gpsimu_errors": {"problem_strip": 2, "breaks_lines": [200.0, 400.0], "strip": [{
        "strip": 2, "shift_m": [1.0, 3.0], "excursion_lines": [0.0, 200.0, 400.0, 599.0],
        "excursion_x_m": [0.0, 1.5, -1.5, 0.5], "excursion_z_m": [2.0, 10.0, -10.0, -2.0]}]},
    "points": {"break_points_per_band_per_strip": 3, "break_band_lines": 60.0},
}


@pytest.fixture(scope="session")
def problem_small(tmp_path_factory):
    """The simulated project folder (no results yet; tests copy it before writing into it)."""
    root = tmp_path_factory.mktemp("reports") / "small"
    simulate(root, load_preset("small", PROBLEM_SMALL))
    return root


@pytest.fixture(scope="session")
def compared_small(tmp_path_factory, problem_small):
    """A copy of ``problem_small`` compared with the default variants and reported.

    Returns (root, comparison, report files).
    """
    import shutil

    from scangeo.reports.comparison import compare_project
    from scangeo.reports.report import write_report
    from scangeo.reports.tables import write_comparison

    root = tmp_path_factory.mktemp("compared") / "small"
    shutil.copytree(problem_small, root)
    comparison = compare_project(root)
    write_comparison(comparison)
    return root, comparison, write_report(root)
