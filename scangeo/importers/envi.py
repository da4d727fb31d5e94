"""ENVI cubes as sensors write them: the header and the raw data file beside it, read and checked.

A cube is a raw data file (``X.bil``, ``X.bip``, ``X.bsq``, ``X.img``, ``X.raw`` or ``X``) and a
text header: ``X.hdr`` or ``X.bil.hdr`` (Resonon writes the second, HySpex and PARGE the first).
Either file may be named. The header must give ``samples``, ``lines``, ``bands``, ``data type``
and ``interleave``; ``header offset`` and ``byte order`` default to 0. The data file must hold
exactly ``header offset + samples x lines x bands x bytes`` bytes: fewer is a truncated file, more a
header of another cube. Only the header is read; the pixels stay where they are (the project names
the data file, GDAL's ENVI driver and :mod:`scangeo.rectify.raw_image` read it).
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.errors import ImportFileError, MissingFileError
from scangeo.rectify.raw_image import read_envi_header

#: ENVI ``data type`` codes and their numpy types
DATA_TYPES = {1: "u1", 2: "i2", 3: "i4", 4: "f4", 5: "f8", 12: "u2", 13: "u4", 14: "i8", 15: "u8"}
#: data file names tried beside a header ``X.hdr``: ``X`` + each suffix
DATA_SUFFIXES = (".bil", ".bip", ".bsq", ".img", ".raw", ".dat", "")


@dataclass(frozen=True)
class EnviCube:
    """An ENVI cube's header, checked against its data file.

    ``samples``: pixels per line; ``lines``: image lines; ``wavelengths``: the header's band centres
    (its ``wavelength units``, usually nm; empty when absent); ``frame_rate_hz``: Resonon's
    ``framerate`` key, None when absent.
    """

    header: Path
    data: Path
    samples: int
    lines: int
    bands: int
    interleave: str
    dtype: np.dtype
    header_offset: int
    wavelengths: tuple[float, ...]
    band_names: tuple[str, ...]
    frame_rate_hz: float | None
    keys: dict[str, str]

    @property
    def expected_bytes(self) -> int:
        return self.header_offset + self.samples * self.lines * self.bands * self.dtype.itemsize

    @classmethod
    def read(cls, path) -> EnviCube:
        """Read and check the cube named by its header or its data file."""
        header, data = locate(Path(path))
        keys = _keys(header)
        samples, lines, bands = (_count(header, keys, k) for k in ("samples", "lines", "bands"))
        code = _int(header, keys, "data type")
        if code not in DATA_TYPES:
            raise ImportFileError(f"{header} [data type]: {code} is not an ENVI data type "
                                  f"(expected one of {', '.join(map(str, DATA_TYPES))})")
        interleave = keys.get("interleave", "").strip().lower()
        if interleave not in ("bil", "bip", "bsq"):
            raise ImportFileError(f"{header} [interleave]: {interleave or 'missing'!r}, expected bil, bip or bsq")
        order = keys.get("byte order", "0").strip()
        if order not in ("0", "1"):
            raise ImportFileError(f"{header} [byte order]: {order!r}, expected 0 (little endian) or 1 (big endian)")
        if keys.get("file compression", "0").strip() not in ("", "0"):
            raise ImportFileError(f"{header} [file compression]: a compressed cube; expected a raw (uncompressed) one")
        offset = _int(header, keys, "header offset", default=0)
        dtype = np.dtype(DATA_TYPES[code]).newbyteorder("<" if order == "0" else ">")
        cube = cls(header, data, samples, lines, bands, interleave, dtype, offset,
                   _numbers(header, keys, "wavelength", bands), _names(keys, bands),
                   _frame_rate(header, keys), keys)
        size = data.stat().st_size
        if size != cube.expected_bytes:
            what = "truncated" if size < cube.expected_bytes else "longer than its header says"
            raise ImportFileError(
                f"{data}: {size} bytes, but its header {header.name} says {samples} samples x {lines} lines x "
                f"{bands} bands of {dtype.itemsize}-byte {dtype.name}" + (f" after {offset} header bytes"
                                                                         if offset else "")
                + f" = {cube.expected_bytes} bytes ({what})")
        return cube


def locate(path: Path) -> tuple[Path, Path]:
    """(header, data file) of a cube named by either; errors name what was looked for."""
    if path.suffix.lower() == ".hdr":
        if not path.is_file():
            raise MissingFileError(f"{path}: no such ENVI header")
        stem = path.with_suffix("")
        candidates = [stem] if stem.suffix else [stem.with_name(stem.name + s) for s in DATA_SUFFIXES]
        for c in candidates:
            if c.is_file():
                return path, c
        raise MissingFileError(f"{path}: no data file beside the header (looked for "
                               f"{', '.join(c.name for c in candidates)})")
    if not path.is_file():
        raise MissingFileError(f"{path}: no such cube")
    headers = [path.with_name(path.name + ".hdr"), path.with_suffix(".hdr")]
    for h in headers:
        if h.is_file():
            return h, path
    raise MissingFileError(f"{path}: no ENVI header beside the cube (looked for "
                           f"{', '.join(dict.fromkeys(h.name for h in headers))})")


def _keys(header: Path) -> dict[str, str]:
    try:
        keys = read_envi_header(header)
    except (OSError, UnicodeError) as exc:
        raise ImportFileError(f"{header}: cannot read the ENVI header ({exc})") from None
    if not keys:
        raise ImportFileError(f"{header}: not an ENVI header (expected a first line 'ENVI')")
    return keys


def _int(header: Path, keys: dict[str, str], key: str, default: int | None = None) -> int:
    if key not in keys:
        if default is not None:
            return default
        raise ImportFileError(f"{header} [{key}]: missing (an ENVI header gives samples, lines, bands, "
                              "data type and interleave)")
    try:
        return int(keys[key].strip())
    except ValueError:
        raise ImportFileError(f"{header} [{key}]: {keys[key].strip()!r} is not an integer") from None


def _count(header: Path, keys: dict[str, str], key: str) -> int:
    value = _int(header, keys, key)
    if value < 1:
        raise ImportFileError(f"{header} [{key}]: {value}, expected a positive count")
    return value


def _list(keys: dict[str, str], key: str) -> list[str]:
    value = keys.get(key, "").strip()
    if not value.startswith("{"):
        return []
    return [v.strip() for v in value.strip("{}").split(",") if v.strip()]


def _numbers(header: Path, keys: dict[str, str], key: str, bands: int) -> tuple[float, ...]:
    values = _list(keys, key)
    if not values:
        return ()
    try:
        out = tuple(float(v) for v in values)
    except ValueError:
        raise ImportFileError(f"{header} [{key}]: not a list of numbers") from None
    if len(out) != bands:
        raise ImportFileError(f"{header} [{key}]: {len(out)} values, but the header has {bands} bands")
    return out


def _names(keys: dict[str, str], bands: int) -> tuple[str, ...]:
    names = _list(keys, "band names")
    return tuple(names) if len(names) == bands else ()


def _frame_rate(header: Path, keys: dict[str, str]) -> float | None:
    value = keys.get("framerate", "").strip()
    if not value:
        return None
    m = re.match(r"[-+0-9.eE]+", value)
    if not m or not float(m.group()) > 0:
        raise ImportFileError(f"{header} [framerate]: {value!r}, expected a frame rate in Hz")
    return float(m.group())


__all__ = ["DATA_SUFFIXES", "DATA_TYPES", "EnviCube", "locate"]
