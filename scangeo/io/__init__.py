"""Project files: project.toml, points.csv, ground.csv."""
from scangeo.io.points import GroundPoints, ImagePoints
from scangeo.io.project import Project

__all__ = ["Project", "ImagePoints", "GroundPoints"]
