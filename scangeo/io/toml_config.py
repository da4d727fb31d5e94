"""Reading a TOML file; syntax errors name the file and position (the keys: :mod:`scangeo.io.schema`)."""
from __future__ import annotations

import tomllib
from importlib.resources.abc import Traversable
from pathlib import Path

from scangeo.errors import ProjectFileError
from scangeo.textfile import read_text


def load_toml(path: Path | Traversable) -> dict:
    """Parse a TOML file saved as UTF-8 (a byte-order mark allowed: :func:`scangeo.textfile.read_text`);
    syntax errors name the file and position."""
    text = read_text(path, "a TOML file", ProjectFileError)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ProjectFileError(f"{path}: not valid TOML ({exc})") from exc
