"""The error hierarchy: one root, subclasses by what went wrong.

Every message names the file, line or key, what was found and what was expected, e.g.
``nav/12.csv line 4031: time 123.40 is not after the previous 123.44 (times must increase)``.
"""
from __future__ import annotations


class ScangeoError(Exception):
    """Root of every error scangeo raises for a user's input or a failed computation."""


class InputFileError(ScangeoError):
    """A file could not be read or does not have the expected content."""


class ProjectFileError(InputFileError):
    """project.toml, variants.toml, points.csv or ground.csv is malformed."""


class OrientationFileError(InputFileError):
    """An ``orientation.json`` (an adjusted orientation, docs/formats.md) is missing, of another
    schema version, or malformed (names the file and the key)."""


class TrajectoryError(InputFileError):
    """A GPS/IMU trajectory file is malformed (times, columns, records)."""


class CRSError(ProjectFileError):
    """A coordinate reference system given by the user is not known to PROJ (names the file and key)."""


class DTMError(ScangeoError):
    """A DTM cannot be read or does not cover what is asked."""


class SensorError(ScangeoError):
    """A sensor model is configured inconsistently."""


class ConvergenceError(ScangeoError):
    """An iterative computation did not converge."""


class AdjustmentError(ScangeoError):
    """The adjustment cannot be set up or solved."""


class LidarError(ScangeoError):
    """A laser-scanner computation is given inconsistent input (geometry, errors, strips, budget)."""


class OutputLockedError(ScangeoError):
    """Another scangeo run is writing the same project (its lock file is held)."""


def where(path: object, line: int | None = None, key: str | None = None) -> str:
    """Format a location prefix for messages: ``file line N`` or ``file [key]``."""
    text = str(path)
    if line is not None:
        text += f" line {line}"
    if key is not None:
        text += f" [{key}]"
    return text
