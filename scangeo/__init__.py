"""scangeo: georeferencing of airborne line-scanner imagery.

Orientation spline, GPS/IMU models with correction functions, hybrid least-squares adjustment,
ground <-> image on a DTM, and rectification. The documentation is in docs/ of the source tree.

Importing scangeo has no process-wide side effects: numba's threading layer is chosen the moment
before scangeo's first parallel kernel runs (``scangeo.threading_layer``), not here.
"""
from scangeo.errors import ScangeoError

__version__ = "0.1.0"
__all__ = ["ScangeoError", "__version__"]
