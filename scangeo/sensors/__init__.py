"""Sensor models and the strip geometry (ground <-> image)."""
from scangeo.sensors.models import Pushbroom, SensorModel, Whiskbroom
from scangeo.sensors.strip import STATUS, Mounting, StripGeometry, cast_rays, status_text

__all__ = ["Whiskbroom", "Pushbroom", "SensorModel", "Mounting", "StripGeometry", "STATUS", "cast_rays", "status_text"]
