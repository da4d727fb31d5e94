"""Strip differences per strip pair (the report's table), by hand."""
from __future__ import annotations

import numpy as np

from scangeo.lidar.differences import Differences, common_rows


def test_per_pair_by_hand():
    a = np.array(["02", "01", "01", "02", "01", "10"], object)
    b = np.array(["03", "02", "02", "03", "03", "11"], object)
    dz = np.array([0.3, 0.1, -0.3, -0.1, 0.2, 0.0])
    d = Differences(np.arange(6), a, b, dz, np.ones(6, bool), 2.0)
    got = d.per_pair()
    assert list(got) == ["01-02", "01-03", "02-03", "10-11"]  # sorted by the pair's ids
    assert got["01-02"] == {"cells": 2, "rms": float(np.sqrt(0.05)), "mean": float(np.mean([0.1, -0.3]))}
    assert got["01-03"] == {"cells": 1, "rms": 0.2, "mean": 0.2}
    assert got["02-03"]["cells"] == 2 and np.isclose(got["02-03"]["mean"], 0.1)
    assert got["10-11"] == {"cells": 1, "rms": 0.0, "mean": 0.0}


def test_per_pair_of_no_cells():
    e = np.zeros(0)
    assert Differences(e.astype(np.int64), e.astype(object), e.astype(object), e, e.astype(bool), 1.0).per_pair() == {}


def test_common_rows_are_the_shared_keys_in_their_texts_order():
    # the rows (cell, pair) of both states, ordered by the text of their keys (Differences.key): cell keys
    # up to 2^62 (patches.cell_keys), 1 to 3 digit strip ids, so that text and number order differ
    rng = np.random.default_rng(7)
    strips = np.array(["1", "2", "10", "11", "100"], object)

    def differences(n):
        cell = rng.integers(0, 2**62, n // 4).repeat(4)[:n]
        pair = rng.choice([(0, 1), (0, 2), (1, 3), (2, 4), (3, 4)], n)
        d = Differences(cell, strips[pair[:, 0]], strips[pair[:, 1]], rng.normal(size=n), rng.random(n) < 0.5, 1.0)
        _, first = np.unique(d.key(), return_index=True)
        return d.take(np.sort(first))

    before, other = differences(400), differences(400)
    other = other.take(~np.isin(other.key(), before.key()))   # rows only the after state has
    half = before.take(slice(None, None, 2))
    after = Differences(*(np.concatenate([getattr(other, f), getattr(half, f)]) for f in ("cell", "a", "b")),
                        np.concatenate([other.dz, half.dz + 0.1]), np.concatenate([other.flat, half.flat]), 1.0)
    b, a = common_rows(before, after)
    expected = sorted(half.key())
    assert len(expected) >= 100 and list(b.key()) == expected and list(a.key()) == expected
    index = {k: i for i, k in enumerate(before.key())}
    np.testing.assert_array_equal(b.dz, before.dz[[index[k] for k in expected]])
    np.testing.assert_array_equal(a.dz, b.dz + 0.1)
