"""The orientation of the strips: the versioned orientation file (:mod:`scangeo.orientation.file`,
written by the adjustment, read by rectify and match) and the GPS/IMU models with their correction
functions (:mod:`scangeo.orientation.models`).
"""
from scangeo.orientation.file import Orientation, StripOrientation, load_orientation, write_orientation
from scangeo.orientation.models import Correction, GpsImuModel, ModelSet

__all__ = ["Correction", "GpsImuModel", "ModelSet", "Orientation", "StripOrientation", "load_orientation",
           "write_orientation"]
