"""scangeo: georeferencing of airborne line-scanner imagery.

Orientation spline, GPS/IMU models with correction functions, hybrid least-squares adjustment,
ground <-> image on a DTM, and rectification. See docs/ and ../shared/DESIGN.md.
"""
from scangeo.errors import ScangeoError

__version__ = "0.1.0"
__all__ = ["ScangeoError", "__version__"]
