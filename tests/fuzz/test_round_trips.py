"""Round trips write -> read of the formats scangeo writes: what comes back is what went in,
to the precision the format states."""
from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tests.fuzz.profile import ROUND_TRIP

# ids a user may give: any printable text without the CSV's own line breaks, stripped (readers strip fields)
IDS = st.text(st.characters(blacklist_categories=("Cs", "Cc", "Zl", "Zp")), min_size=1, max_size=12).map(
    str.strip).filter(bool)


@st.composite
def streams(draw):
    from scangeo.trajectory.stream import GpsImuStream

    n = draw(st.integers(2, 40))
    steps = draw(arrays(float, n - 1, elements=st.floats(1e-3, 10.0)))
    t = draw(st.floats(0.0, 6e5)) + np.concatenate([[0.0], np.cumsum(steps)])
    t = np.round(t, 6)
    if np.any(np.diff(t) <= 0):
        t = np.round(t[0], 6) + np.arange(n) * 0.01
    lat = np.radians(draw(arrays(float, n, elements=st.floats(-80.0, 80.0))))
    lon = np.radians(draw(arrays(float, n, elements=st.floats(-179.0, 179.0))))
    h = draw(arrays(float, n, elements=st.floats(-100.0, 9000.0)))
    att = [np.radians(draw(arrays(float, n, elements=st.floats(-90.0, 90.0)))) for _ in range(2)]
    heading = np.radians(draw(arrays(float, n, elements=st.floats(-180.0, 180.0))))
    return GpsImuStream(t, lat, lon, h, att[0], att[1], np.unwrap(heading), source="<hypothesis>")


@ROUND_TRIP
@given(stream=streams())
def test_trajectory_csv(tmp_path, stream):
    from scangeo.trajectory.readers import read_trajectory_csv, write_trajectory_csv

    path = tmp_path / "nav.csv"
    write_trajectory_csv(path, stream)
    back = read_trajectory_csv(path)
    np.testing.assert_allclose(back.time, stream.time, atol=1e-6, rtol=0)
    np.testing.assert_allclose(back.lat, stream.lat, atol=np.radians(1e-11), rtol=0)
    np.testing.assert_allclose(back.lon, stream.lon, atol=np.radians(1e-11), rtol=0)
    np.testing.assert_allclose(back.h, stream.h, atol=1e-4, rtol=0)
    np.testing.assert_allclose(back.roll, stream.roll, atol=np.radians(1e-8), rtol=0)
    np.testing.assert_allclose(back.pitch, stream.pitch, atol=np.radians(1e-8), rtol=0)
    np.testing.assert_allclose(back.heading, stream.heading, atol=np.radians(1e-8), rtol=0)
    assert not list(tmp_path.glob("*.tmp*"))


@ROUND_TRIP
@given(rows=st.lists(st.tuples(IDS, st.sampled_from(["1", "02", "a b"]), st.floats(-0.5, 1e5), st.floats(-0.5, 1e4),
                               st.floats(0.001, 100.0)), min_size=1, max_size=20,
                     unique_by=lambda r: (r[0], r[1])))
def test_points_csv(tmp_path, rows):
    from scangeo.io.points import ImagePoints

    point, strip, line, pixel, sigma = (np.array(c, dtype=object if k < 2 else float) for k, c in enumerate(zip(*rows)))
    pts = ImagePoints(point, strip, line, pixel, sigma, np.arange(len(rows)) + 2)
    pts.write(tmp_path / "points.csv")
    back = ImagePoints.read(tmp_path / "points.csv")
    assert list(back.point) == list(point) and list(back.strip) == list(strip)
    np.testing.assert_allclose(back.line, line, atol=5e-5, rtol=0)
    np.testing.assert_allclose(back.pixel, pixel, atol=5e-5, rtol=0)
    np.testing.assert_allclose(back.sigma_px, sigma, rtol=1e-5)


@ROUND_TRIP
@given(rows=st.lists(st.tuples(IDS, st.floats(-1e6, 1e7), st.floats(-1e7, 1e7), st.floats(-400, 9000),
                               st.floats(0.001, 10.0), st.floats(0.001, 10.0),
                               st.sampled_from(["control", "check", "height", "planimetric"])),
                     min_size=1, max_size=20, unique_by=lambda r: r[0]))
def test_ground_csv(tmp_path, rows):
    from scangeo.io.points import GroundPoints

    cols = list(zip(*rows))
    g = GroundPoints(np.array(cols[0], dtype=object), np.column_stack(cols[1:4]).astype(float), np.array(cols[4]),
                     np.array(cols[5]), np.array(cols[6], dtype=object), np.arange(len(rows)) + 2)
    g.write(tmp_path / "ground.csv")
    back = GroundPoints.read(tmp_path / "ground.csv")
    assert list(back.point) == list(g.point) and list(back.role) == list(g.role)
    np.testing.assert_allclose(back.xyz, g.xyz, atol=5e-5, rtol=0)
    np.testing.assert_allclose(back.sigma_xy, g.sigma_xy, rtol=1e-5)
    np.testing.assert_allclose(back.sigma_z, g.sigma_z, rtol=1e-5)


@ROUND_TRIP
@given(header=st.lists(IDS, min_size=1, max_size=5, unique=True),
       cells=st.lists(st.lists(st.text(max_size=10), min_size=5, max_size=5), max_size=10))
def test_atomic_csv(tmp_path, header, cells):
    import csv

    from scangeo.atomic import write_csv

    rows = [r[:len(header)] for r in cells]
    write_csv(tmp_path / "t.csv", header, rows)
    with open(tmp_path / "t.csv", newline="", encoding="utf-8") as f:
        back = list(csv.reader(f))
    assert back == [header, *rows]
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]
