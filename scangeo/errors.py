"""The error hierarchy: one root, subclasses by what went wrong.

Every message names the file, line or key, what was found and what was expected, e.g.
``nav/12.csv line 4031: time 123.40 is not after the previous 123.44 (times must increase)``.

As in rasterio, the classes also derive from the built-in exception that fits, so code that does not
know scangeo can still catch them the usual way: an input file that cannot be read is an
:class:`OSError` (a missing one a :class:`FileNotFoundError`), a bad value in a file or an argument a
:class:`ValueError`, a missing optional dependency an :class:`ImportError`. The root class itself is
never raised: every error is one of the subclasses below.
"""
from __future__ import annotations


class ScangeoError(Exception):
    """Root of every error scangeo raises for a user's input or a failed computation.

    Never raised itself: every error is one of its subclasses (this module), which also derive from
    the built-in exception that fits (OSError, ValueError, ImportError).

    Parameters
    ----------
    message : str
        What went wrong: the file, line or key, what was found and what was expected.
    """


class InputFileError(ScangeoError, OSError):
    """A file could not be read or does not have the expected content (also an OSError)."""


class MissingFileError(InputFileError, FileNotFoundError):
    """An input file or folder does not exist (also a FileNotFoundError)."""


class ProjectFileError(InputFileError, ValueError):
    """project.toml, variants.toml, a preset, points.csv or ground.csv is malformed (also a ValueError)."""


class OrientationFileError(InputFileError, ValueError):
    """An ``orientation.json`` (an adjusted orientation, docs/formats.md) is missing, of another
    schema version, or malformed (names the file and the key)."""


class TrajectoryError(InputFileError, ValueError):
    """A GPS/IMU trajectory file is malformed (times, columns, records)."""


class CRSError(ProjectFileError):
    """A coordinate reference system given by the user is not known to PROJ (names the file and key)."""


class DTMError(InputFileError, ValueError):
    """A DTM cannot be read or does not cover what is asked."""


class SensorError(ScangeoError, ValueError):
    """A sensor model is configured inconsistently."""


class AdjustmentError(ScangeoError):
    """The adjustment cannot be set up or solved."""


class LidarError(ScangeoError, ValueError):
    """A laser-scanner computation is given inconsistent input (geometry, errors, strips, budget)."""


class OutputLockedError(ScangeoError):
    """Another scangeo run is writing the same project (its lock file is held)."""


class OptionsError(ScangeoError, ValueError):
    """An option given to a command or function is unknown or out of range (also a ValueError)."""


class ArgumentError(OptionsError):
    """An argument of a call is out of range or contradicts another (also a ValueError).

    The message names the arguments as Python does (``workers=0: expected 1 or more``); the command
    line shows the same message with its flags (``--workers 0: expected 1 or more``). ``text`` holds
    the message with ``{name}`` where an argument is named, ``values`` the arguments' values.
    """

    def __init__(self, text: str, **values: object) -> None:
        self.text = text
        self.values = values
        super().__init__(self.render(lambda name, value: f"{name}={value!r}"))

    def render(self, label) -> str:
        """The message with every argument named by ``label(name, value) -> str``."""
        return self.text.format(**{name: label(name, value) for name, value in self.values.items()})


class RectifyOptionsError(OptionsError):
    """A rectification option (``RectifyOptions``, ``GeoTiffProfile``, ``[rectify]`` settings) is invalid."""


class GeometryError(ScangeoError, ValueError):
    """The geometry does not allow the computation (a footprint off the DTM, a block too large for a
    local map, an output grid without cells)."""


class StacItemError(InputFileError, ValueError):
    """A STAC item is not valid by its schemas, or one of its schemas is not held on disk."""


class MissingDependencyError(ScangeoError, ImportError):
    """An optional dependency a feature needs is not installed (names the extra to install)."""


def where(path: object, line: int | None = None, key: str | None = None) -> str:
    """Format a location prefix for messages: ``file line N`` or ``file [key]``."""
    text = str(path)
    if line is not None:
        text += f" line {line}"
    if key is not None:
        text += f" [{key}]"
    return text


class ImportFileError(InputFileError, ValueError):
    """A source of ``scangeo import`` cannot be imported: a navigation log, a line-time file, a cube or
    its header, a camera model (names the file, the line, and what was expected)."""


class ParGeFileError(ImportFileError):
    """A PARGE status file (``.gcs``) or a HySpex sensor-model file cannot be imported (names the file)."""
