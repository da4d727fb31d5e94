"""Reading a TOML file; syntax errors name the file and position (the keys: :mod:`scangeo.io.schema`)."""
from __future__ import annotations

import tomllib
from pathlib import Path

from scangeo.errors import ProjectFileError


def load_toml(path: Path) -> dict:
    """Parse a TOML file; syntax errors name the file and position."""
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as exc:
        raise ProjectFileError(f"{path}: cannot read ({exc.strerror})") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ProjectFileError(f"{path}: not valid TOML ({exc})") from exc
    except UnicodeDecodeError as exc:
        raise ProjectFileError(f"{path}: not UTF-8 text at byte {exc.start} (expected a TOML file)") from None
