"""Reading a user's text file (CSV, TOML, trajectories, tables) as editors save it.

Every text input of scangeo is read by :func:`read_text`: UTF-8, with or without the byte-order
mark that spreadsheets and Windows editors put first ("CSV UTF-8"); the mark is dropped. Any other
encoding is refused with the file's name and what was expected, never decoded by guess: a latin-1
(Windows-1252) file is named with the line and column of its first byte that is not UTF-8, a
UTF-16 or UTF-32 file (with or without its mark) as such.
"""
from __future__ import annotations

import codecs
import os
from importlib.resources.abc import Traversable
from pathlib import Path

from scangeo.errors import InputFileError

#: byte-order marks of the encodings that are refused, longest first (UTF-32's starts like UTF-16's)
_OTHER_MARKS = (
    (codecs.BOM_UTF32_LE, "UTF-32"),
    (codecs.BOM_UTF32_BE, "UTF-32"),
    (codecs.BOM_UTF16_LE, "UTF-16"),
    (codecs.BOM_UTF16_BE, "UTF-16"),
)


def read_text(path: str | os.PathLike | Traversable, expected: str, error: type[InputFileError] = InputFileError
              ) -> str:
    """The text of a file saved as UTF-8, with or without a byte-order mark (which is dropped).

    Parameters
    ----------
    path : str, Path or Traversable
        The file (a package resource too).
    expected : str
        What the file should be, for messages (``"a CSV file"``, ``"a TOML file"``).
    error : subclass of InputFileError
        The class raised for a file that cannot be read or is not UTF-8 text.

    Returns
    -------
    str
        The text, line ends as in the file.

    Raises
    ------
    InputFileError
        (``error``) The file cannot be read, or is not UTF-8 text: the message names the file, the
        encoding found where it is recognisable (UTF-16, UTF-32; latin-1 by the line and column of
        the first byte that is not UTF-8) and what was expected.
    """
    if not isinstance(path, Traversable):
        path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot read ({exc.strerror})") from exc
    if raw.startswith(codecs.BOM_UTF8):
        raw = raw[len(codecs.BOM_UTF8):]
    else:
        for mark, name in _OTHER_MARKS:
            if raw.startswith(mark):
                raise error(f"{path}: {name} text (expected {expected} saved as UTF-8)")
    if b"\x00" in raw:  # valid UTF-8, but no editor's text: UTF-16 or UTF-32 without a mark, or binary
        wide = _wide_encoding(raw)
        found = f"{wide} text without a byte-order mark" if wide else "a binary file (NUL bytes), not text"
        raise error(f"{path}: {found} (expected {expected} saved as UTF-8)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise error(
            f"{path} line {line} column {column}: byte 0x{raw[exc.start]:02X} is not UTF-8 (a latin-1 or "
            f"Windows-1252 file?; expected {expected} saved as UTF-8)"
        ) from None


def _wide_encoding(raw: bytes) -> str | None:
    """"UTF-16" or "UTF-32" when mostly ASCII text in that encoding without a mark, else None."""
    head = raw[:400]
    if len(head) < 4 or head.count(0) < len(head) // 3:
        return None
    for width, name in ((4, "UTF-32"), (2, "UTF-16")):
        n = len(head) // width * width
        units = [head[i:i + width] for i in range(0, n, width)]
        for order in (slice(None), slice(None, None, -1)):  # little and big endian
            ascii_ = sum(u[order][0] != 0 and not any(u[order][1:]) for u in units)
            if ascii_ >= 0.9 * len(units):
                return name
    return None


__all__ = ["read_text"]
