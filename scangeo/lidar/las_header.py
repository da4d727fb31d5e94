"""Checks of a LAS/LAZ file's header against the file itself, before laspy reads it.

laspy trusts the header: a corrupted count of VLRs makes it loop for minutes, a corrupted point count
makes it allocate what the count asks for. :func:`check_las_file` reads the public header block with
``struct`` and checks every count and offset against the file's size, so a damaged file is an
:class:`~scangeo.errors.InputFileError` naming the file and the header field, e.g.
``strip.las [header.point_count]: 4294967295 returns of 28 bytes from byte 227 need 120259084487 bytes,
the file has 451 (truncated?)``.

Checked (LAS 1.0-1.4, docs/formats.md "Checks on input"):

- the signature ``LASF``, a version 1.0-1.4 and a header size at least that version's;
- the offset to the point data within the file and after the header;
- the VLRs: their count and lengths fit between the header and the point data;
- the point format 0-10 and a record length at least that format's size;
- uncompressed: point count x record length fits in the file (before the first EVLR);
- LAZ: the ``laszip encoded`` VLR is there, its items add up to the record length, the chunk table
  lies within the file, its chunks fit in the point data and hold the point count, and the chunks of
  layered compression (point formats 6-10) hold the count and layer sizes they say;
- LAS 1.4: the EVLRs (start, count, lengths) lie within the file.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from scangeo.errors import InputFileError, MissingFileError, where

#: Header size of each LAS minor version (bytes).
HEADER_SIZE = {0: 227, 1: 227, 2: 227, 3: 235, 4: 375}
#: Record length of each standard point format (bytes); a record may be longer (extra bytes).
POINT_SIZE = {0: 20, 1: 28, 2: 26, 3: 34, 4: 57, 5: 63, 6: 30, 7: 36, 8: 38, 9: 59, 10: 67}
VLR_HEADER = 54
EVLR_HEADER = 60
LASZIP_USER_ID = b"laszip encoded"
LASZIP_RECORD_ID = 22204
VARIABLE_CHUNKS = 0xFFFFFFFF


@dataclass(frozen=True)
class LasHeaderInfo:
    """What the checks read from the public header block."""

    version: tuple[int, int]
    header_size: int
    offset_to_point_data: int
    number_of_vlrs: int
    point_format: int
    compressed: bool
    record_length: int
    point_count: int
    start_of_first_evlr: int
    number_of_evlrs: int
    file_size: int


def _fail(path: Path | str, key: str, text: str) -> InputFileError:
    return InputFileError(f"{where(path, key=f'header.{key}')}: {text}")


def _read_header(path: Path, f: BinaryIO, size: int) -> LasHeaderInfo:
    head = f.read(HEADER_SIZE[4])
    if head[:4] != b"LASF":
        raise _fail(path, "signature", f"expected 'LASF', found {head[:4]!r}: not a LAS/LAZ file")
    if len(head) < HEADER_SIZE[0]:
        raise _fail(path, "header_size", f"the file has {size} bytes, a LAS header at least {HEADER_SIZE[0]} "
                                         "(truncated?)")
    major, minor = head[24], head[25]
    if major != 1 or minor not in HEADER_SIZE:
        raise _fail(path, "version", f"expected 1.0 to 1.4, found {major}.{minor}")
    header_size, offset, n_vlrs, fmt, record = struct.unpack_from("<HIIBH", head, 94)
    legacy_count = struct.unpack_from("<I", head, 107)[0]
    if header_size < HEADER_SIZE[minor]:
        raise _fail(path, "header_size", f"expected at least {HEADER_SIZE[minor]} bytes for LAS 1.{minor}, "
                                         f"found {header_size}")
    if size < header_size:
        raise _fail(path, "header_size", f"the header has {header_size} bytes, the file {size} (truncated?)")
    start_evlr, n_evlrs, count = 0, 0, legacy_count
    if minor >= 4:
        start_evlr, n_evlrs, count = struct.unpack_from("<QIQ", head, 235)
    return LasHeaderInfo(
        version=(major, minor),
        header_size=header_size,
        offset_to_point_data=offset,
        number_of_vlrs=n_vlrs,
        point_format=fmt & 0x3F,
        compressed=bool(fmt & 0x80) and not fmt & 0x40,
        record_length=record,
        point_count=count,
        start_of_first_evlr=start_evlr,
        number_of_evlrs=n_evlrs,
        file_size=size,
    )


def _check_layout(path: Path, h: LasHeaderInfo) -> None:
    if not h.header_size <= h.offset_to_point_data <= h.file_size:
        raise _fail(path, "offset_to_point_data", f"expected between the header's end ({h.header_size}) and "
                                                  f"the file's ({h.file_size}), found {h.offset_to_point_data}")
    if h.point_format not in POINT_SIZE:
        raise _fail(path, "point_format", f"expected 0 to 10, found {h.point_format}")
    if h.record_length < POINT_SIZE[h.point_format]:
        raise _fail(path, "point_record_length", f"point format {h.point_format} needs at least "
                                                 f"{POINT_SIZE[h.point_format]} bytes, found {h.record_length}")


def _walk_records(path: Path, f: BinaryIO, key: str, start: int, count: int, end: int, extended: bool) -> list:
    """(user id, record id, data offset, data length) of ``count`` (E)VLRs from ``start``, all before ``end``."""
    size = EVLR_HEADER if extended else VLR_HEADER
    if count * size > end - start:
        raise _fail(path, key, f"{count} records of at least {size} bytes do not fit in the {max(end - start, 0)} "
                               f"bytes from byte {start} to {end}")
    records, pos = [], start
    for i in range(count):
        if pos + size > end:
            raise _fail(path, key, f"record {i + 1} of {count} would start at byte {pos}, its header end past "
                                   f"byte {end}")
        f.seek(pos)
        raw = f.read(size)
        length = struct.unpack_from("<Q" if extended else "<H", raw, 20)[0]
        data = pos + size
        if data + length > end:
            raise _fail(path, key, f"record {i + 1} of {count} at byte {pos} ({length} bytes of data) ends at "
                                   f"{data + length}, past byte {end}")
        records.append((raw[2:18].split(b"\0")[0], struct.unpack_from("<H", raw, 18)[0], data, length))
        pos = data + length
    return records


def _check_points(path: Path, h: LasHeaderInfo) -> None:
    """Uncompressed: the counted records fit before the EVLRs or the end of the file."""
    limit = h.start_of_first_evlr if h.number_of_evlrs else h.file_size
    need = h.offset_to_point_data + h.point_count * h.record_length
    if need > limit:
        what = f"the EVLRs start at byte {limit}" if h.number_of_evlrs else f"the file has {h.file_size}"
        raise _fail(path, "point_count", f"{h.point_count} returns of {h.record_length} bytes from byte "
                                         f"{h.offset_to_point_data} need {need} bytes, {what} (truncated?)")


def _laszip_items(path: Path, raw: bytes, h: LasHeaderInfo) -> tuple[int, list[tuple[int, int]]]:
    """Chunk size and (type, size) of the items of the laszip VLR, checked against the record length."""
    if len(raw) < 34:
        raise _fail(path, "vlr.laszip", f"expected at least 34 bytes, found {len(raw)}")
    chunk_size = struct.unpack_from("<I", raw, 12)[0]
    n_items = struct.unpack_from("<H", raw, 32)[0]
    if len(raw) < 34 + 6 * n_items:
        raise _fail(path, "vlr.laszip", f"{n_items} items need {34 + 6 * n_items} bytes, the record has {len(raw)}")
    items = [struct.unpack_from("<HH", raw, 34 + 6 * i) for i in range(n_items)]
    if sum(size for _, size in items) != h.record_length:
        raise _fail(path, "point_record_length", f"the laszip items describe {sum(s for _, s in items)} bytes a "
                                                 f"return, the header says {h.record_length}")
    if chunk_size == 0:
        raise _fail(path, "vlr.laszip", "chunk size 0")
    return chunk_size, items


#: Layers of each item type of LAS 1.4 layered compression (type 14, extra bytes: one per byte).
LAYERS = {10: 9, 11: 1, 12: 2, 13: 1}


def _chunk_table(path: Path, f: BinaryIO, h: LasHeaderInfo, raw: bytes) -> tuple[int, list[tuple[int, int]]]:
    """The chunk table's offset and its (points, bytes) per chunk, read by lazrs once its size is known sane."""
    end = h.start_of_first_evlr if h.number_of_evlrs else h.file_size
    f.seek(h.offset_to_point_data)
    table = struct.unpack("<q", f.read(8).ljust(8, b"\0"))[0]
    if table == -1 and h.file_size >= 8:  # the writer could not seek back: the offset is in the last 8 bytes
        f.seek(h.file_size - 8)
        table = struct.unpack("<q", f.read(8))[0]
    if not h.offset_to_point_data + 8 <= table <= end - 8:
        raise _fail(path, "laz.chunk_table", f"expected the chunk table between byte {h.offset_to_point_data + 8} "
                                             f"and {end - 8}, found it at {table} (truncated?)")
    f.seek(table)
    n_chunks = struct.unpack("<II", f.read(8))[1]
    if n_chunks > table - h.offset_to_point_data:
        raise _fail(path, "laz.chunk_table", f"{n_chunks} chunks cannot lie in the "
                                             f"{table - h.offset_to_point_data} bytes of point data")
    import lazrs

    f.seek(h.offset_to_point_data)
    try:
        chunks = lazrs.read_chunk_table(f, lazrs.LazVlr(raw))
    except BaseException as exc:  # lazrs: LazrsError, or a Rust panic (a BaseException) on garbage
        if not isinstance(exc, Exception) and type(exc).__name__ != "PanicException":
            raise
        raise _fail(path, "laz.chunk_table", f"cannot be decoded ({exc})") from exc
    return table, [(int(n), int(b)) for n, b in chunks]


def _check_laz(path: Path, f: BinaryIO, h: LasHeaderInfo, vlrs: list) -> None:
    """LAZ: the laszip VLR matches the record; the chunk table lies within the file, its chunks fit in the point
    data and hold the point count; layered chunks (LAS 1.4 formats) hold the sizes they say."""
    laszip = [(data, length) for user, rid, data, length in vlrs if user == LASZIP_USER_ID and rid == LASZIP_RECORD_ID]
    if not laszip:
        raise _fail(path, "point_format", "compressed points (LAZ) without the 'laszip encoded' VLR")
    f.seek(laszip[0][0])
    raw = f.read(laszip[0][1])
    chunk_size, items = _laszip_items(path, raw, h)
    table, chunks = _chunk_table(path, f, h, raw)
    data_bytes = table - h.offset_to_point_data - 8
    if sum(b for _, b in chunks) > data_bytes or any(b <= 0 for _, b in chunks):  # back to back; a gap is let be
        raise _fail(path, "laz.chunk_table", f"{len(chunks)} chunks of {sum(b for _, b in chunks)} bytes, the point "
                                             f"data has {data_bytes} (truncated or corrupted?)")
    if chunk_size == VARIABLE_CHUNKS:
        counts = [n for n, _ in chunks]
    elif -(-h.point_count // chunk_size) != len(chunks):  # ceil: the last chunk may hold fewer
        counts = []
    else:
        counts = [min(chunk_size, h.point_count - i * chunk_size) for i in range(len(chunks))]
    if sum(counts) != h.point_count or len(counts) != len(chunks) or any(n <= 0 for n in counts):
        raise _fail(path, "point_count", f"{h.point_count} returns, the chunk table holds {len(chunks)} chunks of "
                                         f"{sum(n for n, _ in chunks) if chunk_size == VARIABLE_CHUNKS else chunk_size}"
                                         " returns (truncated or corrupted?)")
    if not any(t in LAYERS or t == 14 for t, _ in items):
        return
    n_layers = sum(LAYERS.get(t, size if t == 14 else 0) for t, size in items)
    head = h.record_length + 4 + 4 * n_layers
    start = h.offset_to_point_data + 8
    for i, ((_, nbytes), count) in enumerate(zip(chunks, counts)):
        f.seek(start + h.record_length)
        raw_sizes = f.read(4 + 4 * n_layers)
        if head > nbytes or len(raw_sizes) < 4 + 4 * n_layers:
            raise _fail(path, "laz.chunk", f"chunk {i + 1} ({nbytes} bytes) is shorter than its header ({head} bytes)")
        in_chunk, *sizes = struct.unpack(f"<I{n_layers}I", raw_sizes)
        if in_chunk != count or head + sum(sizes) != nbytes:
            raise _fail(path, "laz.chunk", f"chunk {i + 1} at byte {start} says {in_chunk} returns in "
                                           f"{head + sum(sizes)} bytes, the chunk table {count} in {nbytes}")
        start += nbytes


def check_las_file(path: str | Path) -> LasHeaderInfo:
    """Check a LAS/LAZ file's header against the file (see the module's docstring); returns what it read.

    Raises :class:`~scangeo.errors.InputFileError` naming the file and the header field.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        with path.open("rb") as f:
            h = _read_header(path, f, size)
            _check_layout(path, h)
            vlrs = _walk_records(path, f, "number_of_vlrs", h.header_size, h.number_of_vlrs,
                                 h.offset_to_point_data, extended=False)
            if h.number_of_evlrs:
                if not h.offset_to_point_data <= h.start_of_first_evlr <= h.file_size:
                    raise _fail(path, "start_of_first_evlr", f"expected between the point data (byte "
                                                             f"{h.offset_to_point_data}) and the file's end "
                                                             f"({h.file_size}), found {h.start_of_first_evlr}")
                _walk_records(path, f, "number_of_evlrs", h.start_of_first_evlr, h.number_of_evlrs,
                              h.file_size, extended=True)
            if h.compressed:
                _check_laz(path, f, h, vlrs)
            else:
                _check_points(path, h)
    except InputFileError:
        raise
    except FileNotFoundError as exc:
        raise MissingFileError(f"{path}: no such LAS/LAZ file") from exc
    except IsADirectoryError as exc:
        raise InputFileError(f"{path}: a folder, expected a LAS/LAZ file") from exc
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read ({exc})") from exc
    return h
