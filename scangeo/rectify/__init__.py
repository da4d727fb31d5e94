"""Orthorectification of strips onto the DTM (docs/rectify.md).

``rectify_project`` rectifies the strips of a project for a variant (batch, resumable, local
processes or a Dask cluster); ``rectify_strip`` one strip of any :class:`StripGeometry`.

Importing this package makes numba use its ``workqueue`` threading layer unless the user chose one
(``NUMBA_THREADING_LAYER``) or a parallel kernel has already run: with the OpenMP layer, whose
threads spin after every parallel region, the Python-side work between the geometry core's
kernel calls ran on a core shared with a spinning thread; a 10,000-line strip took 36 s instead of
11.5 s on the 2-core machines (tests/benchmarks/rectify.py; ``OMP_WAIT_POLICY=PASSIVE`` has the
same effect when set before the process starts).
"""
import os

import numba

if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"

from scangeo.rectify.batch import BatchResult, rectify_project  # noqa: E402
from scangeo.rectify.geometry import StripGeometry  # noqa: E402
from scangeo.rectify.options import RectifyOptions  # noqa: E402
from scangeo.rectify.output_grid import OutputGrid  # noqa: E402
from scangeo.rectify.strip import StripResult, rectify_strip  # noqa: E402

__all__ = ["rectify_project", "rectify_strip", "RectifyOptions", "OutputGrid", "StripGeometry", "StripResult",
           "BatchResult"]
