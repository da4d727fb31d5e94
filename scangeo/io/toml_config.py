"""Typed reading of TOML tables: every key checked, unknown keys are errors naming them."""
from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

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


class Table:
    """A TOML table read key by key; ``finish()`` rejects keys nobody asked for."""

    def __init__(self, data: Any, path: Path, name: str) -> None:
        if not isinstance(data, dict):
            raise ProjectFileError(f"{path} [{name}]: expected a table, found {type(data).__name__}")
        self.data = data
        self.path = path
        self.name = name
        self.used: set[str] = set()

    def _where(self, key: str) -> str:
        return f"{self.path} [{self.name}] {key}"

    def get(self, key: str, kind: type | tuple, default: Any = ..., required: bool = False) -> Any:
        self.used.add(key)
        if key not in self.data:
            if required or default is ...:
                raise ProjectFileError(f"{self._where(key)}: missing (required)")
            return default
        value = self.data[key]
        kinds = kind if isinstance(kind, tuple) else (kind,)
        if float in kinds and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
            names = " or ".join(k.__name__ for k in kinds)
            raise ProjectFileError(f"{self._where(key)}: expected {names}, found {value!r}")
        return value

    def vector(self, key: str, length: int, default: Any = ...) -> list[float] | Any:
        value = self.get(key, list, default)
        if value is default and default is not ...:
            return default
        if len(value) != length or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            raise ProjectFileError(f"{self._where(key)}: expected {length} numbers, found {value!r}")
        return [float(v) for v in value]

    def choice(self, key: str, options: tuple[str, ...], default: Any = ...) -> str:
        value = self.get(key, str, default)
        if value not in options:
            raise ProjectFileError(f"{self._where(key)}: expected one of {', '.join(options)}, found {value!r}")
        return value

    def finish(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            raise ProjectFileError(
                f"{self.path} [{self.name}]: unknown key{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}"
            )
