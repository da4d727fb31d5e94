"""A small simulated block with a problem strip, compared and reported once per test session."""
from __future__ import annotations

import pytest

from scangeo.simulate.block import simulate
from scangeo.simulate.config import load_preset

#: The ``small`` preset without images and with three strips, the middle one made a problem strip:
#: height excursions of +-20 m with kinks at two break lines (the pattern of vienna2000 on 600 lines),
#: 40 tie points per overlap (the diagnosis finds the problem strip from them: a strip with one
#: neighbour only cannot be told from it, hence three strips).
PROBLEM_SMALL = {
    "output": {"images": False, "truth_ortho": False},
    "flight": {"strips": 3},
    "gpsimu_errors": {"problem_strip": 2, "breaks_lines": [200.0, 400.0], "strip": [{
        "strip": 2, "shift_m": [1.0, 3.0], "excursion_lines": [0.0, 200.0, 400.0, 599.0],
        "excursion_x_m": [0.0, 3.0, -3.0, 1.0], "excursion_z_m": [4.0, 20.0, -20.0, -4.0]}]},
    "points": {"break_points_per_band_per_strip": 3, "break_band_lines": 60.0, "tie_per_overlap": 40},
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
    comparison = compare_project(root, folds=2)
    write_comparison(comparison)
    return root, comparison, write_report(root)
