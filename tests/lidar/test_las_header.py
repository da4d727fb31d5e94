"""The LAS/LAZ header checks (scangeo.lidar.las_header): valid files of every kind pass and read
exactly what laspy reads; each corrupted header field is an InputFileError naming the file and the field."""
from __future__ import annotations

import struct
from pathlib import Path

import laspy
import numpy as np
import pytest

from scangeo.errors import InputFileError
from scangeo.lidar import lasio
from scangeo.lidar.las_header import check_las_file

SHARED_LIDAR = Path(__file__).resolve().parents[3] / "shared" / "data" / "lidar"


def make(path: Path, point_format: int, version: str, n: int, compress: bool) -> Path:
    las = laspy.create(point_format=point_format, file_version=version)
    las.header.offsets = [600000.0, 5340000.0, 0.0]
    las.header.scales = [0.01, 0.01, 0.01]
    rng = np.random.default_rng(n)
    las.x = 600000.0 + rng.uniform(0, 500, n)
    las.y = 5340000.0 + rng.uniform(0, 500, n)
    las.z = 200.0 + rng.normal(0, 5, n)
    las.gps_time = 1000.0 + np.arange(n) * 1e-4
    las.point_source_id = np.where(np.arange(n) % 3 == 0, 3, 4).astype(np.uint16)
    las.write(str(path), do_compress=compress)
    return path


KINDS = [(1, "1.2", False), (3, "1.3", False), (6, "1.4", False), (1, "1.2", True), (6, "1.4", True),
         (7, "1.4", True)]


@pytest.mark.parametrize("point_format,version,compress", KINDS, ids=[f"{f}-{v}-{'laz' if c else 'las'}"
                                                                      for f, v, c in KINDS])
def test_valid_files_pass_and_read_what_laspy_reads(tmp_path, point_format, version, compress):
    # 120 000 returns: LAZ files of 3 chunks (50 000 a chunk), the last one partial
    path = make(tmp_path / f"s.la{'z' if compress else 's'}", point_format, version, 120_000, compress)
    info = check_las_file(path)
    assert info.point_count == 120_000 and info.compressed == compress and info.point_format == point_format
    cloud = lasio.read_strip("s", [path], point_source_id=3)
    ref = laspy.read(str(path))
    sel = np.asarray(ref.point_source_id) == 3
    assert cloud.size == 40_000
    assert np.array_equal(cloud.xyz, np.column_stack([ref.x[sel], ref.y[sel], ref.z[sel]]))
    assert np.array_equal(cloud.time, np.asarray(ref.gps_time)[sel])


@pytest.mark.skipif(not SHARED_LIDAR.is_dir(), reason="no real LAS files in ../shared/data/lidar")
def test_real_files_pass_and_read_what_laspy_reads():
    for path in sorted(SHARED_LIDAR.glob("*.la[sz]")):
        assert check_las_file(path).point_count == laspy.read(str(path)).header.point_count
        cloud = lasio.read_strip("x", [path])
        ref = laspy.read(str(path))
        assert np.array_equal(cloud.xyz, np.column_stack([ref.x, ref.y, ref.z])), path.name
        assert np.array_equal(cloud.time, np.asarray(ref.gps_time)), path.name


def patched(path: Path, offset: int, fmt: str, *values) -> Path:
    raw = bytearray(path.read_bytes())
    struct.pack_into(fmt, raw, offset, *values)
    out = path.with_name("bad" + path.suffix)
    out.write_bytes(bytes(raw))
    return out


# LAS 1.2 (header 227 bytes): offset 94 header size, 96 offset to points, 100 VLR count, 104 point format,
# 105 record length, 107 point count; LAS 1.4 adds 235 first EVLR, 243 EVLR count, 247 point count (64 bit)
LAS12 = [
    ("signature", 0, "<4s", b"LASG", "[header.signature]"),
    ("version", 24, "<BB", (2, 0), "[header.version]: expected 1.0 to 1.4, found 2.0"),
    ("header-size", 94, "<H", 100, "[header.header_size]: expected at least 227"),
    ("offset-to-points", 96, "<I", 10**9, "[header.offset_to_point_data]"),
    ("vlr-count", 100, "<I", 2**32 - 1, "[header.number_of_vlrs]"),
    ("point-format", 104, "<B", 11, "[header.point_format]: expected 0 to 10, found 11"),
    ("record-length", 105, "<H", 10, "[header.point_record_length]: point format 1 needs at least 28 bytes"),
    ("point-count", 107, "<I", 2**32 - 1, "[header.point_count]: 4294967295 returns of 28 bytes"),
]


@pytest.mark.parametrize("field,offset,fmt,value,message", LAS12, ids=[c[0] for c in LAS12])
def test_a_corrupted_las_header_field_is_named(tmp_path, field, offset, fmt, value, message):
    good = make(tmp_path / "s.las", 1, "1.2", 20, False)
    bad = patched(good, offset, fmt, *(value if isinstance(value, tuple) else (value,)))
    with pytest.raises(InputFileError) as err:
        lasio.read_strip("s", [bad])
    assert str(err.value).startswith(f"{bad} [header.") and message in str(err.value)


def test_short_and_empty_files(tmp_path):
    good = make(tmp_path / "s.las", 1, "1.2", 20, False)
    (tmp_path / "short.las").write_bytes(good.read_bytes()[:150])
    with pytest.raises(InputFileError, match=r"short.las \[header.header_size\]: the file has 150 bytes"):
        check_las_file(tmp_path / "short.las")
    (tmp_path / "empty.las").write_bytes(b"")
    with pytest.raises(InputFileError, match=r"empty.las \[header.signature\]"):
        check_las_file(tmp_path / "empty.las")


def test_las14_point_count_and_evlrs(tmp_path):
    good = make(tmp_path / "s.las", 6, "1.4", 20, False)
    size = good.stat().st_size
    with pytest.raises(InputFileError, match=r"\[header.point_count\]: 1099511627776 returns of 30 bytes"):
        check_las_file(patched(good, 247, "<Q", 1 << 40))
    evlrs = patched(good, 235, "<QI", size - 10, 1000)  # 1000 EVLRs in the last 10 bytes
    with pytest.raises(InputFileError, match=r"\[header.number_of_evlrs\]: 1000 records"):
        check_las_file(evlrs)
    with pytest.raises(InputFileError, match=r"\[header.start_of_first_evlr\]"):
        check_las_file(patched(good, 235, "<QI", size + 1, 1))


def _laz_layout(path: Path) -> tuple[int, int]:
    raw = path.read_bytes()
    offset = struct.unpack_from("<I", raw, 96)[0]
    return offset, struct.unpack_from("<q", raw, offset)[0]


def test_corrupted_laz_chunk_table_and_chunks(tmp_path):
    good = make(tmp_path / "s.laz", 7, "1.4", 120_000, True)
    offset, table = _laz_layout(good)
    record = 36  # point format 7
    cases = [
        (offset, "<q", table + 10**6, r"\[header.laz.chunk_table\]: expected the chunk table between"),
        (table + 4, "<I", 10**9, r"\[header.laz.chunk_table\]: 1000000000 chunks cannot lie"),
        (247, "<Q", 170_000, r"\[header.point_count\]: 170000 returns, the chunk table holds 3 chunks"),
        # the first chunk's count of returns, then the size of its first layer
        (offset + 8 + record, "<I", 49_999, r"\[header.laz.chunk\]: chunk 1 at byte \d+ says 49999 returns"),
        (offset + 8 + record + 4, "<I", 2**31, r"\[header.laz.chunk\]: chunk 1 at byte"),
    ]
    for at, fmt, value, message in cases:
        with pytest.raises(InputFileError, match=message):
            lasio.read_strip("s", [patched(good, at, fmt, value)])
    raw = bytearray(good.read_bytes())
    hdr = struct.unpack_from("<H", raw, 94)[0]
    assert raw[hdr + 2:hdr + 16] == b"laszip encoded"  # the first VLR; its data follow its 54-byte header
    struct.pack_into("<H", raw, hdr + 54 + 34 + 2, 99)  # the first item's size
    (tmp_path / "items.laz").write_bytes(bytes(raw))
    with pytest.raises(InputFileError, match=r"\[header.point_record_length\]: the laszip items describe 105"):
        check_las_file(tmp_path / "items.laz")
