"""Strip differences per strip pair (the report's table), by hand."""
from __future__ import annotations

import numpy as np

from scangeo.lidar.differences import Differences


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
