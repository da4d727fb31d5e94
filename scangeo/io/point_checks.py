"""Checks of points.csv and ground.csv against the project before an adjustment.

* every measurement names a strip of the project and lies inside its image (lines 0..n-1, pixels
  0..p-1, half a pixel of slack);
* a point absent from ground.csv is a tie point and must be measured in at least two strips;
* a ground point lies within the DTM's extent widened by its own size on every side (further away it
  is a coordinate error: swapped x/y, another zone or CRS).
"""
from __future__ import annotations

from collections import Counter

import numpy as np

from scangeo.errors import ProjectFileError
from scangeo.io.points import GroundPoints, ImagePoints


def check_measurements(project, points: ImagePoints, ground: GroundPoints) -> None:
    """Raise ProjectFileError naming points.csv's line of the first implausible measurement."""
    images = project.image_strips
    points.check_strips([s.id for s in images])
    n_lines = {s.id: project.n_lines(s.id) for s in images}
    pixels = {s.id: project.scanner_of(s.id).model.pixels for s in images}
    for i in range(len(points)):
        sid, line, pixel = str(points.strip[i]), points.line[i], points.pixel[i]
        for name, value, n in (("line", line, n_lines[sid]), ("pixel", pixel, pixels[sid])):
            if not -0.5 <= value <= n - 0.5:
                raise ProjectFileError(
                    f"{points.source} line {points.file_line[i]}: {name} {value:g} of point {points.point[i]} is "
                    f"outside strip {sid}'s image ({name}s 0..{n - 1})"
                )
    given = {str(p) for p in ground.point}
    strips_of = Counter(str(p) for p, _ in set(zip(points.point, points.strip)))
    for i, p in enumerate(points.point):
        if str(p) not in given and strips_of[str(p)] < 2:
            raise ProjectFileError(
                f"{points.source} line {points.file_line[i]}: point {p} is not in ground.csv and is measured in "
                f"strip {points.strip[i]} only (a tie point needs measurements in two strips or more)"
            )


def check_ground(project, ground: GroundPoints) -> None:
    """Raise ProjectFileError naming ground.csv's line of a point far outside the DTM."""
    if not len(ground):
        return
    left, bottom, right, top = project.dtm.grid.bounds()
    w, h = right - left, top - bottom
    x, y = ground.xyz[:, 0], ground.xyz[:, 1]
    far = np.flatnonzero((x < left - w) | (x > right + w) | (y < bottom - h) | (y > top + h))
    if far.size:
        i = int(far[0])
        raise ProjectFileError(
            f"{ground.source} line {ground.file_line[i]}: point {ground.point[i]} at x {x[i]:.1f}, y {y[i]:.1f} is "
            f"far outside the DTM {project.dtm_path.name} (x {left:.0f}..{right:.0f}, y {bottom:.0f}..{top:.0f}); "
            "x and y swapped, or another CRS than [project] crs?"
        )


def check_points(project, points: ImagePoints, ground: GroundPoints) -> None:
    """All checks of this module."""
    check_measurements(project, points, ground)
    check_ground(project, ground)
