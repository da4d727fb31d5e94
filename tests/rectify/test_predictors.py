"""The compiled TIFF predictors of the COG writer against their numpy reference, bit for bit."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scangeo.rectify import predictors


@settings(max_examples=40, deadline=None)
@given(dtype=st.sampled_from(["float32", "float64", ">f4", ">f8"]), bands=st.integers(1, 9),
       rows=st.integers(1, 7), cols=st.integers(1, 11), seed=st.integers(0, 2**32 - 1),
       special=st.booleans())
def test_floating_point_predictor_is_libtiffs(dtype, bands, rows, cols, seed, special):
    rng = np.random.default_rng(seed)
    values = rng.standard_normal((bands, rows + 2, cols + 3)) * 10.0 ** rng.integers(-30, 30)
    if special:  # NaN nodata, infinities, signed zeros, subnormals: the bits as they are
        flat = values.reshape(-1)
        picks = rng.integers(0, flat.size, size=max(1, flat.size // 3))
        flat[picks] = rng.choice([np.nan, np.inf, -np.inf, 0.0, -0.0, 1e-310], size=picks.size)
    tile = values.astype(dtype)
    block = tile[:, 1:1 + rows, 2:2 + cols]  # a block is a view into its tile
    got = predictors.floating_point(block)
    want = predictors.floating_point_reference(block.transpose(1, 2, 0))
    assert got.dtype == np.uint8 and got.shape == want.shape
    assert np.array_equal(got, want)


@settings(max_examples=40, deadline=None)
@given(dtype=st.sampled_from(["uint8", "uint16", "int16", "int32", "uint32", ">u2", ">i2"]), bands=st.integers(1, 9),
       rows=st.integers(1, 7), cols=st.integers(1, 11), seed=st.integers(0, 2**32 - 1))
def test_horizontal_predictor_wraps_as_the_integer_type(dtype, bands, rows, cols, seed):
    info = np.iinfo(np.dtype(dtype))
    rng = np.random.default_rng(seed)
    tile = rng.integers(info.min, info.max, size=(bands, rows + 1, cols + 1), endpoint=True).astype(dtype)
    block = tile[:, 1:, 1:]
    got = predictors.horizontal(block)
    want = predictors.horizontal_reference(block.transpose(1, 2, 0))
    assert got.dtype.isnative and got.dtype.kind == np.dtype(dtype).kind
    assert np.array_equal(got, want)  # values compared, whatever the byte order


def test_a_known_row_by_hand():
    """One pixel of two float32 bands, 1.0 (3F 80 00 00) and -2.0 (C0 00 00 00), then the same again:
    byte planes 3F C0 3F C0 | 80 00 80 00 | 00 ... then each byte minus the one two before it."""
    block = np.array([[[1.0, 1.0]], [[-2.0, -2.0]]], dtype=np.float32)  # (bands 2, rows 1, cols 2)
    got = predictors.floating_point(block)[0]
    planes = np.array([0x3F, 0xC0, 0x3F, 0xC0, 0x80, 0x00, 0x80, 0x00] + [0] * 8, dtype=np.int64)
    want = planes.copy()
    want[2:] = (planes[2:] - planes[:-2]) % 256
    assert got.tolist() == want.tolist()


def test_other_types_are_refused():
    with pytest.raises(ValueError, match="float32 or float64"):
        predictors.floating_point(np.zeros((1, 2, 2), np.float16))
    with pytest.raises(ValueError, match="integer block"):
        predictors.horizontal(np.zeros((1, 2, 2), np.float32))
