"""Cloud-optimised GeoTIFFs written by scangeo: tiles compressed as they are made, no GDAL copy.

GDAL's COG driver compresses with libdeflate at about 80 MB/s on a rectified strip (uint16, 11
bands, sensor noise): 2.9 of the 3.5 CPU s of a 10,000-line strip's final copy
(docs/performance.md). Here every 512 x 512 block (and every block of every overview level) is
compressed by ISA-L's deflate (``isal``, about 290 MB/s on the same data, the same zlib stream every
TIFF reader decodes) in worker threads while the resampling pass goes on, spooled to a file, and
the final file is assembled from the spool in the cloud-optimised order:

* the TIFF header and GDAL's structural metadata ("ghost header": ``LAYOUT=IFDS_BEFORE_DATA``,
  ``BLOCK_ORDER=ROW_MAJOR``, ``BLOCK_LEADER=SIZE_AS_UINT4``, ``BLOCK_TRAILER=LAST_4_BYTES_REPEATED``),
  so that GDAL reports ``LAYOUT=COG``;
* the image file directories: the full resolution first, then the overview levels;
* the blocks, the smallest overview level first and the full resolution last, row-major within a
  level, each preceded by its size (4 bytes) and followed by its last 4 bytes repeated.

Pixel-interleaved, predictor 2 (horizontal differencing) for integer types and predictor 3 (the
floating-point predictor: byte planes, then differencing) for floats, deflate level 1. The level has
GDAL's meaning (the ``LEVEL`` of its deflate, libdeflate's scale) on both routes: level 1, the
fastest, is ISA-L's level 1 here, whose blocks are 1.4-1.6 % larger than libdeflate's level 1
(docs/performance.md); another level is GDAL's to write (:meth:`GeoTiffProfile.scangeo_writes
<scangeo.rectify.geotiff.GeoTiffProfile.scangeo_writes>`).

The layout is GDAL's COG driver's, which this module writes by hand: :data:`TESTED_GDAL` are the GDAL
versions whose COG driver the tests compare it with (tests/rectify/test_cog_properties.py); under
another GDAL, :func:`gdal_in_tested_range` is False and GDAL's COG driver writes (a note in the log).
The georeferencing and metadata tags (GeoKeys, pixel scale and tie point, GDAL's nodata and
metadata with the band descriptions, the software tag) are GDAL's own: they are copied from a
one-cell GeoTIFF that GDAL writes in memory with the same CRS, transform, bands and tags, so a
reader sees what GDAL's COG driver would have written; only the pixel blocks are scangeo's.

Blocks are cut from tiles written in any order (:meth:`CogWriter.write`); a block is encoded once
all its cells have been written, and blocks no tile touched are nodata. Memory: the blocks waiting
for an encoder (at most :data:`BACKLOG_BYTES`) and those being filled, about a row of blocks per
overview level whose blocks span several tiles (with 1024-cell tiles and 512-cell blocks, levels 2
and coarser: for a 760-cell wide strip of 11 bands one block of 5.8 MB per level). The overview levels are
computed from each tile with :func:`scangeo.rectify.overviews.halve` (tiles aligned on the
coarsest factor, as for :class:`~scangeo.rectify.overviews.LevelTiles`).
"""
from __future__ import annotations

import logging
import math
import os
import struct
import sys
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rasterio
from affine import Affine
from isal import isal_zlib
from rasterio.windows import Window

from scangeo.atomic import commit
from scangeo.errors import ScangeoError
from scangeo.rectify import predictors
from scangeo.rectify.overviews import halve

log = logging.getLogger(__name__)

#: the GDAL versions (major, minor; both ends included) whose COG driver's layout and tags this writer
#: is tested against; under another GDAL the COG driver writes
TESTED_GDAL = ((3, 9), (3, 10))
#: the deflate level this writer encodes (GDAL's scale; ISA-L's level 1)
LEVEL = 1

#: bytes per value of each TIFF field type
_TYPE_SIZE = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 6: 1, 7: 1, 8: 2, 9: 4, 10: 8, 11: 4, 12: 8, 13: 4, 16: 8, 17: 8, 18: 8}
SHORT, LONG, LONG8 = 3, 4, 16
#: tags scangeo sets itself in every directory (the layout of the blocks); the rest is GDAL's
_STRUCTURE = {254, 256, 257, 259, 273, 278, 279, 284, 317, 322, 323, 324, 325}
#: GDAL's tags an overview's directory carries besides the structure
_OVERVIEW_TAGS = {258, 262, 277, 338, 339, 42113}
#: bytes of the blocks waiting for an encoder at most (but two blocks)
BACKLOG_BYTES = 128 * 2**20
#: files up to this size are classic TIFFs, larger ones BigTIFFs (GDAL's ``BIGTIFF=IF_SAFER`` idea)
CLASSIC_LIMIT = 2**32 - 2**20
_GHOST = (
    "LAYOUT=IFDS_BEFORE_DATA\n"
    "BLOCK_ORDER=ROW_MAJOR\n"
    "BLOCK_LEADER=SIZE_AS_UINT4\n"
    "BLOCK_TRAILER=LAST_4_BYTES_REPEATED\n"
    "KNOWN_INCOMPATIBLE_EDITION=NO\n "
)


class CogLayoutError(ScangeoError, RuntimeError):
    """The COG writer's file would not have the layout it computed (a bug: the file is not written)."""


def gdal_in_tested_range(version: str | None = None) -> bool:
    """Whether ``version`` (default: the GDAL rasterio runs on) is within :data:`TESTED_GDAL`; the first
    False of a process is noted in the log."""
    version = version or rasterio.__gdal_version__
    try:
        major_minor = tuple(int(v) for v in version.split(".")[:2])
    except ValueError:
        major_minor = (0, 0)
    ok = TESTED_GDAL[0] <= major_minor <= TESTED_GDAL[1]
    global _noted
    if not ok and not _noted:
        _noted = True
        log.info("GDAL %s is outside the versions scangeo's COG writer is tested with (%s to %s): GDAL's COG "
                 "driver writes the orthoimages", version, ".".join(map(str, TESTED_GDAL[0])),
                 ".".join(map(str, TESTED_GDAL[1])))
    return ok


_noted = False
_LITTLE = sys.byteorder == "little"


@dataclass(frozen=True)
class Tag:
    """One TIFF field: its code, type, number of values and the values' little-endian bytes."""

    code: int
    type: int
    count: int
    value: bytes

    @classmethod
    def of(cls, code: int, type: int, *values: int) -> Tag:
        fmt = {SHORT: "H", LONG: "I", LONG8: "Q"}[type]
        return cls(code, type, len(values), struct.pack(f"<{len(values)}{fmt}", *values))

    def values(self) -> tuple:
        """The values of an integer or floating-point field (ASCII and undefined: the bytes)."""
        fmt = {1: "B", 3: "H", 4: "I", 6: "b", 8: "h", 9: "i", 11: "f", 12: "d", 16: "Q", 17: "q"}.get(self.type)
        if fmt is None:
            return (self.value,)
        return struct.unpack(f"<{self.count}{fmt}", self.value)


def read_directories(data: bytes) -> list[dict[int, Tag]]:
    """Every image file directory of a little-endian classic or Big TIFF held in ``data`` (at least
    up to the end of its last directory's values), as ``{code: Tag}``."""
    if data[:2] != b"II":
        raise ValueError("read_directories: not a little-endian TIFF")
    magic = struct.unpack_from("<H", data, 2)[0]
    big = magic == 43
    if magic not in (42, 43):
        raise ValueError(f"read_directories: TIFF magic {magic}, expected 42 or 43")
    offset = struct.unpack_from("<Q" if big else "<I", data, 8 if big else 4)[0]
    out = []
    while offset:
        n = struct.unpack_from("<Q" if big else "<H", data, offset)[0]
        entries: dict[int, Tag] = {}
        pos = offset + (8 if big else 2)
        for _ in range(n):
            if big:
                code, typ, count = struct.unpack_from("<HHQ", data, pos)
                inline, at = 8, pos + 12
            else:
                code, typ, count = struct.unpack_from("<HHI", data, pos)
                inline, at = 4, pos + 8
            size = _TYPE_SIZE.get(typ, 1) * count
            if size > inline:
                at = struct.unpack_from("<Q" if big else "<I", data, at)[0]
            entries[code] = Tag(code, typ, count, bytes(data[at:at + size]))
            pos += 20 if big else 12
        out.append(entries)
        offset = struct.unpack_from("<Q" if big else "<I", data, pos)[0]
    return out


def _ifd_size(tags: list[Tag], big: bool) -> int:
    inline = 8 if big else 4
    size = (8 + 20 * len(tags) + 8) if big else (2 + 12 * len(tags) + 4)
    for t in tags:
        if len(t.value) > inline:
            size += len(t.value) + (len(t.value) & 1)
    return size


def _ifd_bytes(tags: list[Tag], at: int, next_ifd: int, big: bool) -> bytes:
    """A directory written at ``at``: its entries sorted by code, then the values that do not fit
    in an entry (word-aligned)."""
    tags = sorted(tags, key=lambda t: t.code)
    inline = 8 if big else 4
    head = struct.pack("<Q", len(tags)) if big else struct.pack("<H", len(tags))
    extra_at = at + len(head) + (20 if big else 12) * len(tags) + (8 if big else 4)
    entries, extra = [], []
    for t in tags:
        if len(t.value) > inline:
            ref = struct.pack("<Q" if big else "<I", extra_at)
            pad = b"\0" * (len(t.value) & 1)
            extra.append(t.value + pad)
            extra_at += len(t.value) + len(pad)
        else:
            ref = t.value.ljust(inline, b"\0")
        if big:
            entries.append(struct.pack("<HHQ", t.code, t.type, t.count) + ref)
        else:
            entries.append(struct.pack("<HHI", t.code, t.type, t.count) + ref)
    tail = struct.pack("<Q" if big else "<I", next_ifd)
    return head + b"".join(entries) + tail + b"".join(extra)


def gdal_tags(count: int, dtype, crs, transform: Affine, nodata,
              annotate: Callable[[rasterio.io.DatasetWriter], None] | None = None) -> dict[int, Tag]:
    """The tags GDAL writes for a pixel-interleaved GeoTIFF of ``count`` bands of ``dtype`` with
    this georeferencing and nodata, and what ``annotate(dataset)`` adds (band descriptions, band
    and dataset tags): read back from a one-cell GeoTIFF GDAL writes in memory."""
    profile = {"driver": "GTiff", "width": 1, "height": 1, "count": count, "dtype": np.dtype(dtype).name,
               "crs": crs, "transform": transform, "nodata": nodata, "interleave": "pixel", "compress": "none"}
    with rasterio.MemoryFile() as mem:
        with mem.open(**profile) as dst:
            if annotate is not None:
                annotate(dst)
        data = mem.read()
    return read_directories(data)[0]


@dataclass
class _Level:
    """One resolution level's blocks: those being filled, and where the encoded ones are."""

    width: int
    height: int
    blocks_x: int
    blocks_y: int

    def valid(self, index: int, bs: int) -> tuple[int, int]:
        by, bx = divmod(index, self.blocks_x)
        return min(bs, self.height - by * bs), min(bs, self.width - bx * bs)


class CogWriter:
    """A cloud-optimised GeoTIFF written tile by tile (:meth:`write`, the signature of a rasterio
    dataset's), with the overview levels ``factors``, finished under its final name by
    :meth:`finish` (through a hidden partial file and :func:`scangeo.atomic.commit`).

    Parameters
    ----------
    spool : a file for the encoded blocks until the final layout is written (removed by
        :meth:`finish` and :meth:`close`).
    level : deflate level on GDAL's scale: 1 or ``None`` (:data:`LEVEL`, ISA-L's level 1); ``compress="none"``
        stores the blocks raw.
    threads : encoding threads.
    backlog_bytes : blocks waiting for an encoder, bytes at most (but two blocks).
    """

    def __init__(self, spool: Path, *, width: int, height: int, count: int, dtype, nodata, crs,
                 transform: Affine, blocksize: int = 512, factors: list[int] | None = None,
                 compress: str = "deflate", level: int | None = None, predictor: bool = True,
                 threads: int = 2, backlog_bytes: int = BACKLOG_BYTES) -> None:
        self.dtype = np.dtype(dtype)
        if compress not in ("deflate", "none"):
            raise ValueError(f"CogWriter: compress {compress!r} is not deflate or none")
        if predictor and not (np.issubdtype(self.dtype, np.integer) or np.issubdtype(self.dtype, np.floating)):
            raise ValueError(f"CogWriter: no predictor for {self.dtype}")
        self.width, self.height, self.count = width, height, count
        self.nodata, self.crs, self.transform = nodata, crs, transform
        self.bs = blocksize
        self.compress, self.predictor = compress, predictor and compress != "none"
        if compress == "deflate" and level not in (None, LEVEL):
            raise ValueError(f"CogWriter: deflate level {level} (this writer encodes level {LEVEL}; GDAL the others)")
        integer = np.issubdtype(self.dtype, np.integer)
        unset = nodata is None or (integer and math.isnan(float(nodata)))
        #: the value of cells no tile wrote (and of the padding of the edge blocks)
        self.fill = np.array(0 if unset else nodata).astype(self.dtype)
        self.levels: list[_Level] = []
        w, h = width, height
        for i in range(len(factors or []) + 1):
            if i:
                w, h = (w + 1) // 2, (h + 1) // 2
            self.levels.append(_Level(w, h, -(-w // blocksize), -(-h // blocksize)))
        self._partial: list[dict[int, list]] = [{} for _ in self.levels]
        #: (level, block) -> (offset in the spool of the leader, bytes of the encoded block)
        self._where: dict[tuple[int, int], tuple[int, int]] = {}
        self._spool_path = Path(spool)
        self._spool = open(self._spool_path, "wb")  # noqa: SIM115 - closed by finish/close
        self._lock = threading.Lock()
        self._pool = ThreadPoolExecutor(max_workers=max(1, threads), thread_name_prefix="scangeo-cog")
        #: blocks waiting for an encoder at most: enough that pass 2 seldom waits (the backlog is
        #: encoded during the next strip's pass 1), at most BACKLOG_BYTES of them (5.8 MB a block
        #: of 11 bands of uint16, 117 MB one of 224 bands), but 2
        block_bytes = count * blocksize * blocksize * self.dtype.itemsize
        self._slots = threading.BoundedSemaphore(max(2, min(4 * max(1, threads) + 4, backlog_bytes // block_bytes)))
        self._futures: list[Future] = []
        self._submitted: set[tuple[int, int]] = set()

    # -- tiles in -------------------------------------------------------------------------------
    def write(self, data: np.ndarray, window: Window) -> None:
        """A tile ``data`` (bands, rows, cols) of the full resolution at ``window``, and its
        overview levels computed from it (offsets multiples of the coarsest factor, but at the
        edges). ``data`` is copied: the caller may reuse it."""
        row, col = int(window.row_off), int(window.col_off)
        data = np.asarray(data)
        for k in range(len(self.levels)):
            if k:
                data = halve(data, self.nodata)
                row, col = row // 2, col // 2
            self._add(k, data, row, col)

    def _add(self, k: int, data: np.ndarray, row: int, col: int) -> None:
        lv, bs = self.levels[k], self.bs
        rows, cols = data.shape[1], data.shape[2]
        for by in range(row // bs, (row + rows - 1) // bs + 1):
            for bx in range(col // bs, (col + cols - 1) // bs + 1):
                index = by * lv.blocks_x + bx
                r0, r1 = max(row, by * bs), min(row + rows, (by + 1) * bs)
                c0, c1 = max(col, bx * bs), min(col + cols, (bx + 1) * bs)
                vr, vc = lv.valid(index, bs)
                part = data[:, r0 - row:r1 - row, c0 - col:c1 - col]
                if (r1 - r0, c1 - c0) == (bs, bs):
                    self._submit(k, index, np.array(part))
                    continue
                entry = self._partial[k].get(index)
                if entry is None:
                    entry = self._partial[k][index] = [np.full((self.count, bs, bs), self.fill, self.dtype), 0]
                entry[0][:, r0 - by * bs:r1 - by * bs, c0 - bx * bs:c1 - bx * bs] = part
                entry[1] += (r1 - r0) * (c1 - c0)
                if entry[1] >= vr * vc:
                    del self._partial[k][index]
                    self._submit(k, index, entry[0])

    def _submit(self, k: int, index: int, block: np.ndarray) -> None:
        if (k, index) in self._submitted:
            raise ValueError(f"CogWriter: block {index} of level {k} written twice (overlapping tiles)")
        self._submitted.add((k, index))
        self._slots.acquire()
        try:
            fut = self._pool.submit(self._encode, k, index, block)
        except BaseException:
            self._slots.release()
            raise
        fut.add_done_callback(lambda _f: self._slots.release())
        self._futures.append(fut)

    # -- encoding (worker threads) --------------------------------------------------------------
    def encode(self, block: np.ndarray) -> bytes:
        """A block (bands, bs, bs) as the TIFF stores it: pixel-interleaved, differenced (integers:
        predictor 2; floats: predictor 3), deflated."""
        if self.predictor and self.dtype.kind == "f":
            d = predictors.floating_point(block)
        elif self.predictor:
            d = predictors.horizontal(block)
        else:
            d = np.ascontiguousarray(block.transpose(1, 2, 0))
        if d.dtype.byteorder == ">" or (d.dtype.byteorder == "=" and not _LITTLE):  # the file is little-endian
            d = d.astype(d.dtype.newbyteorder("<"))
        if self.compress == "deflate":
            return isal_zlib.compress(d, LEVEL)
        return d.tobytes()

    def _encode(self, k: int, index: int, block: np.ndarray) -> None:
        data = self.encode(block)
        record = struct.pack("<I", len(data)) + data + data[-4:].rjust(4, b"\0")
        with self._lock:
            at = self._spool.tell()
            self._spool.write(record)
            self._where[(k, index)] = (at, len(data))

    # -- the final file -------------------------------------------------------------------------
    def finish(self, final: Path, tmp: Path,
               annotate: Callable[[rasterio.io.DatasetWriter], None] | None = None) -> Path:
        """Encode what is left (blocks partly or never written keep nodata elsewhere), write the
        file in the cloud-optimised layout as ``tmp`` (a hidden name beside ``final``), rename it
        to ``final``. ``annotate(dataset)`` writes the band descriptions and tags (see
        :func:`gdal_tags`)."""
        try:
            for k, lv in enumerate(self.levels):
                for index in range(lv.blocks_x * lv.blocks_y):
                    entry = self._partial[k].pop(index, None)
                    if entry is not None or (k, index) not in self._submitted:
                        self._submit(k, index, entry[0] if entry is not None
                                     else np.full((self.count, self.bs, self.bs), self.fill, self.dtype))
            for fut in self._futures:
                fut.result()  # an encoder's failure surfaces here
            self._pool.shutdown(wait=True)
            self._spool.close()
            template = gdal_tags(self.count, self.dtype, self.crs, self.transform, self.nodata, annotate)
            tmp = Path(tmp)
            try:
                self._assemble(tmp, template)
                commit(tmp, final)
            finally:
                tmp.unlink(missing_ok=True)
        finally:
            self.close()
        return Path(final)

    def _directories(self, template: dict[int, Tag], big: bool, offsets: list[list[int]] | None) -> list[list[Tag]]:
        out = []
        off_type = LONG8 if big else LONG
        for k, lv in enumerate(self.levels):
            n = lv.blocks_x * lv.blocks_y
            size_type = SHORT if max(lv.width, lv.height) < 65536 else LONG
            tags = [
                Tag.of(256, size_type, lv.width), Tag.of(257, size_type, lv.height),
                Tag.of(259, SHORT, 8 if self.compress == "deflate" else 1),
                Tag.of(284, SHORT, 1),
                Tag.of(322, SHORT, self.bs), Tag.of(323, SHORT, self.bs),
                Tag.of(324, off_type, *(offsets[k] if offsets else [0] * n)),
                Tag.of(325, off_type, *[self._where[(k, i)][1] for i in range(n)]),
            ]
            if self.compress != "none":  # as GDAL: 1 (none) when compressed without the predictor
                tags.append(Tag.of(317, SHORT, (3 if self.dtype.kind == "f" else 2) if self.predictor else 1))
            keep = (lambda c: c not in _STRUCTURE) if k == 0 else (lambda c: c in _OVERVIEW_TAGS)
            tags += [t for c, t in template.items() if keep(c)]
            if k:
                tags.append(Tag.of(254, LONG, 1))
            out.append(tags)
        return out

    def _assemble(self, path: Path, template: dict[int, Tag]) -> None:
        ghost = f"GDAL_STRUCTURAL_METADATA_SIZE={len(_GHOST):06d} bytes\n{_GHOST}".encode()
        data_bytes = sum(n + 8 for _, n in self._where.values())
        big = False
        for _ in range(2):
            header = 16 if big else 8
            first = header + len(ghost) + (len(ghost) & 1)
            sizes = [_ifd_size(d, big) for d in self._directories(template, big, None)]
            data_start = first + sum(sizes)
            if big or data_start + data_bytes < CLASSIC_LIMIT:
                break
            big = True
        # the blocks' places: the smallest level first, row-major within a level
        offsets: list[list[int]] = [[] for _ in self.levels]
        order: list[tuple[int, int]] = []
        at = data_start
        for k in reversed(range(len(self.levels))):
            lv = self.levels[k]
            for i in range(lv.blocks_x * lv.blocks_y):
                offsets[k].append(at + 4)
                order.append((k, i))
                at += self._where[(k, i)][1] + 8
        dirs = self._directories(template, big, offsets)
        ifd_at = [first]
        for s in sizes[:-1]:
            ifd_at.append(ifd_at[-1] + s)
        head = (b"II+\0" + struct.pack("<HHQ", 8, 0, first)) if big else (b"II*\0" + struct.pack("<I", first))
        parts = [head, ghost, b"\0" * (len(ghost) & 1)]
        for j, d in enumerate(dirs):
            parts.append(_ifd_bytes(d, ifd_at[j], ifd_at[j + 1] if j + 1 < len(dirs) else 0, big))
        prefix = b"".join(parts)
        if len(prefix) != data_start:
            raise CogLayoutError(f"{path}: the header and directories take {len(prefix)} bytes, the layout "
                                 f"placed the first block at {data_start} (a bug in scangeo's COG writer)")
        with open(self._spool_path, "rb") as src, open(path, "wb") as dst:
            dst.write(prefix)
            dst.flush()
            for key in order:
                s_at, n = self._where[key]
                _copy(src, dst, s_at, n + 8)

    def close(self) -> None:
        """Stop, and remove the spool (an unfinished writer leaves nothing behind)."""
        self._pool.shutdown(wait=True, cancel_futures=True)
        if not self._spool.closed:
            self._spool.close()
        self._spool_path.unlink(missing_ok=True)


def _copy(src, dst, offset: int, n: int) -> None:
    """``n`` bytes of ``src`` from ``offset`` appended to ``dst`` (in the kernel where it can)."""
    done = 0
    try:
        while done < n:
            m = os.copy_file_range(src.fileno(), dst.fileno(), n - done, offset + done)
            if m <= 0:
                break
            done += m
    except (AttributeError, OSError):
        pass
    if done < n:
        src.seek(offset + done)
        dst.write(src.read(n - done))
