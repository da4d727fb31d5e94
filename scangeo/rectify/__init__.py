"""Orthorectification of strips onto the DTM (docs/rectify.md).

``rectify_project`` rectifies the strips of a project for a variant (batch, resumable, local
processes or a Dask cluster); ``rectify_strip`` one strip of any :class:`MapStripGeometry`.
(numba's threading layer is chosen in ``scangeo/__init__.py``.)
"""
from scangeo.rectify.batch import BatchResult, rectify_project
from scangeo.rectify.geometry import MapStripGeometry
from scangeo.rectify.options import RectifyOptions
from scangeo.rectify.output_grid import OutputGrid
from scangeo.rectify.strip import StripResult, rectify_strip

__all__ = ["rectify_project", "rectify_strip", "RectifyOptions", "OutputGrid", "MapStripGeometry", "StripResult",
           "BatchResult"]
