"""image -> ground -> image over the real SRTM terrain with the real trajectory's attitude dynamics."""
import numpy as np
import pytest

from scangeo.dtm import DTM
from scangeo.frames import MapFrame
from scangeo.sensors import Pushbroom, StripGeometry, Whiskbroom
from scangeo.sensors.kernels import MULTIPLE, OK
from scangeo.timing import LineTiming
from scangeo.trajectory import OrientationSpline, read_trajectory
from scangeo.truth.true_error import Truth

from ..conftest import shared_file

N_LINES = 500


@pytest.fixture(scope="module")
def srtm():
    path = shared_file("dtm/N44E005.hgt")
    # UTM 31N, origin near Mont Ventoux (44.174 N, 5.278 E)
    probe = MapFrame("EPSG:32631", __import__("scangeo.frames", fromlist=["ProjectFrame"]).ProjectFrame(0, 0, 0))
    x, y = probe.geodetic_to_map_2d(np.radians([44.174]), np.radians([5.278]))
    mf = MapFrame.centred_on("EPSG:32631", float(x[0]), float(y[0]), 0.0)
    return DTM.open(path, mf)


def _real_dynamics(start: float) -> OrientationSpline:
    """A north-bound line at 4,000 m over Mont Ventoux carrying the real 200 Hz trajectory's roll,
    pitch, heading and height deviations (25 s of the PDAL sample from ``start`` seconds)."""
    stream = read_trajectory(shared_file("trajectory/sbet_047_IGS08-UTM15N-Ellipsoid-trim.txt"), crs="EPSG:32615")
    seg = stream.between(stream.time[0] + start, stream.time[0] + start + 25.0)
    t = seg.time - seg.time[0]

    def detrend(v):
        return v - np.polyval(np.polyfit(t, v, 1), t)

    speed = 67.0
    values = np.column_stack([
        np.zeros_like(t), -700.0 + speed * t, 4000.0 + detrend(seg.h),
        seg.roll - seg.roll.mean(), seg.pitch - seg.pitch.mean(), detrend(seg.heading),
    ])
    return OrientationSpline.fit(t, values, 0.04)


@pytest.fixture(scope="module")
def real_dynamics_spline():
    """From 44 s: pitch rates below 1 deg/s, the start of a turn (roll to -18 deg); the scan line
    sweeps the ground monotonically, so every ground point is seen exactly once."""
    return _real_dynamics(44.0)


@pytest.fixture(scope="module")
def overscanning_spline():
    """From 0 s: pitch rates up to 3.9 deg/s; at 2,000-3,700 m above ground the scan line runs
    backwards at times (over-scanning) and some ground points are seen two or three times."""
    return _real_dynamics(0.0)


def _round_trip(strip, dtm, window_expected=0):
    lines = np.repeat(np.arange(N_LINES, dtype=float), strip.sensor.pixels)
    pixels = np.tile(np.arange(strip.sensor.pixels, dtype=float), N_LINES)
    ground, status = strip.image_to_ground(lines, pixels, dtm)
    ok = status == OK
    assert ok.mean() > 0.999, np.bincount(status)
    assert strip.overscan_window(ground[ok]) == window_expected
    line2, pixel2, status2 = strip.ground_to_image(ground[ok])
    assert (status2 == OK).all()
    return np.abs(line2 - lines[ok]), np.abs(pixel2 - pixels[ok])


def test_whiskbroom_round_trip_every_pixel(srtm, real_dynamics_spline):
    strip = StripGeometry(Whiskbroom(), real_dynamics_spline, LineTiming(2.0, 25.0), N_LINES)
    dl, dp = _round_trip(strip, srtm)
    assert dl.max() < 1e-4 and dp.max() < 1e-4


@pytest.mark.parametrize("smile_deg", [0.05, 0.2])
def test_pushbroom_round_trip_every_pixel(srtm, real_dynamics_spline, smile_deg):
    """A smile of 0.2 deg moves the edge pixels' scan line by ~12 m (five lines) on the ground: the
    bracketing on the centre pixel's scan line must search beyond its neighbouring line epochs, and
    the pixel's own along-track angle is found by secant steps (roll rates couple it to the time)."""
    n = 1024
    j = np.arange(n)
    across = np.arctan((j - 511.5) * 7e-6 / 0.035)
    along = np.radians(0.2) + np.radians(smile_deg) * ((j - 511.5) / 511.5) ** 2
    strip = StripGeometry(Pushbroom(pixels=n, along=along, across=across), real_dynamics_spline,
                          LineTiming(2.0, 25.0), N_LINES)
    dl, dp = _round_trip(strip, srtm)
    assert dl.max() < 1e-4 and dp.max() < 1e-4


def test_first_intersection_matches_brute_force_on_steep_terrain(srtm, real_dynamics_spline):
    """Against a 0.5 m march with exact conversions: no ray skips a ridge."""
    strip = StripGeometry(Whiskbroom(), real_dynamics_spline, LineTiming(2.0, 25.0), N_LINES)
    rng = np.random.default_rng(5)
    lines = rng.uniform(0, N_LINES - 1, 300)
    pixels = rng.uniform(0, 715, 300)
    o, d = strip.rays(lines, pixels)
    ground, status = strip.image_to_ground(lines, pixels, srtm)
    mf = srtm.map_frame
    for k in range(len(o)):
        lam = np.arange(1500.0, 4500.0, 0.5)
        pts = o[k] + lam[:, None] * d[k]
        x, y, H = mf.project_to_map(pts)
        f = H - srtm.height_at_map(x, y)
        below = np.flatnonzero(f <= 0)
        assert below.size, "the brute-force march did not reach the ground"
        first = pts[below[0]]
        assert status[k] == OK
        assert np.linalg.norm(ground[k] - first) < 1.0  # within the 0.5 m march step along the ray


def test_over_scanning_returns_the_first_sighting(srtm, overscanning_spline):
    """Where the scan line runs backwards a ground point is seen several times: ground -> image must
    return a sighting of the same point, the earliest one, and flag the point."""
    strip = StripGeometry(Whiskbroom(), overscanning_spline, LineTiming(2.0, 25.0), N_LINES)
    lines = np.repeat(np.arange(N_LINES, dtype=float), 716)
    pixels = np.tile(np.arange(716, dtype=float), N_LINES)
    ground, status = strip.image_to_ground(lines, pixels, srtm)
    assert (status == OK).all()
    assert strip.overscan_window(ground) > 0
    line2, pixel2, status2 = strip.ground_to_image(ground)
    seen = np.isfinite(line2)
    assert seen.mean() > 0.999
    # every answer is a true sighting: its ray meets the DTM at the same ground point
    back, _ = strip.image_to_ground(line2[seen], pixel2[seen], srtm)
    assert np.nanmax(np.linalg.norm(back - ground[seen], axis=1)) < 1e-3  # 1 mm = 4e-4 px here
    same = (np.abs(line2 - lines) < 1e-4) & (np.abs(pixel2 - pixels) < 1e-4)
    earlier = seen & ~same
    # a different answer is always an earlier sighting, and most of them are flagged
    assert (line2[earlier] < lines[earlier]).all()
    flagged = (status2 & MULTIPLE) != 0
    assert flagged[earlier].mean() > 0.95
    assert 0.05 < flagged.mean() < 0.5


def test_the_true_error_where_scans_overlap(srtm, overscanning_spline):
    """Where the over-scanning mirror sees ground points two or three times, the true error in the image
    counts the sighting nearest the sample and leaves out the samples at the folds themselves (the truth
    sees their ground point elsewhere first): the truth against itself is exact, and an orientation moved
    4 m across track is off by about that across track and not at all along it, at every sample kept."""
    strip = StripGeometry(Whiskbroom(), overscanning_spline, LineTiming(2.0, 25.0), N_LINES)
    truth = Truth(None, srtm, {"a": strip}, lines=N_LINES, pixels=61)
    line, pixel, ground = truth.samples("a")
    first, _, status = strip.ground_to_image(ground)
    seen_again = (status & MULTIPLE) != 0
    # the first sighting is scans away from the sample's own
    assert seen_again.sum() > 10 and np.nanmax(np.abs(first - line)[seen_again]) > 1.0
    kept = truth.one_to_one("a")
    assert 0.5 * len(line) < kept.sum() < len(line)  # this dynamic folds 16 % of them
    e = truth.error("a", strip)
    assert e.n == kept.sum()
    assert e.rms_along_px < 1e-4 and e.rms_across_px < 1e-4 and e.max_ground_m < 1e-4
    coef = strip.spline.coef.copy()
    coef[:, 0] += 4.0  # east, across this north-bound line
    moved = StripGeometry(Whiskbroom(), strip.spline.with_coef(coef), strip.timing, N_LINES)
    e = truth.error("a", moved)
    assert e.n > 0.95 * kept.sum()
    assert e.rms_along_px < 0.05  # the folds' sightings tens of lines away would make this lines
    # 4 m is 1-2.5 pixels here (the pixels grow toward the swath's edges)
    assert 1.0 < e.rms_across_px < 2.5 and e.rms_ground_m == pytest.approx(4.0, abs=0.5)
