"""scangeo: georeferencing of airborne line-scanner imagery.

Orientation spline, GPS/IMU models with correction functions, hybrid least-squares adjustment,
ground <-> image on a DTM, and rectification. The documentation is in docs/ of the source tree.

Importing scangeo makes numba use its ``workqueue`` threading layer unless the user chose one
(``NUMBA_THREADING_LAYER``): the OpenMP layer's threads spin after every parallel region and take
a core from the Python-side work between kernel calls on small machines (a 10,000-line strip took
36 s to rectify instead of 11.5 s on 2 cores; docs/performance.md). The core kernels run as fast
on ``workqueue`` (tests/benchmarks/ground_to_image.py, both layers side by side in
docs/performance.md). It must be chosen before the first parallel kernel runs, hence here.
"""
import os

import numba

if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"  # type: ignore[attr-defined]

from scangeo.errors import ScangeoError  # noqa: E402

__version__ = "0.1.0"
__all__ = ["ScangeoError", "__version__"]
