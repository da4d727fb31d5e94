"""numba's threading layer, chosen the moment before scangeo's first parallel kernel runs.

scangeo's parallel kernels run on numba's ``workqueue`` layer unless the user chose a layer
(``NUMBA_THREADING_LAYER``, or ``numba.config.THREADING_LAYER`` set in Python) or numba already
started one. The OpenMP layer's threads spin after every parallel region and take a core from the
Python-side work between kernel calls on small machines: a 10,000-line strip took 36 s to rectify
instead of 11.5 s on 2 cores (docs/performance.md). The core kernels run as fast on ``workqueue``
(tests/benchmarks/ground_to_image.py, both layers side by side in docs/performance.md).

numba starts its layer when a parallel kernel is first compiled or loaded from its cache, i.e. on
the kernel's first call, and ``numba.set_num_threads`` starts it too. Every Python function that
calls a parallel kernel (or ``set_num_threads``) therefore calls :func:`choose_threading_layer`
first. Importing scangeo leaves numba alone.
"""
from __future__ import annotations

import os

import numba

_chosen = False


def choose_threading_layer() -> None:
    """Select numba's ``workqueue`` threading layer unless the user or numba already chose one.

    Cheap after the first call (one flag). Changes nothing when ``NUMBA_THREADING_LAYER`` is set,
    when ``numba.config.THREADING_LAYER`` is not numba's ``"default"``, or when numba has already
    started a threading layer (e.g. the user's own parallel code ran first).
    """
    global _chosen
    if _chosen:
        return
    _chosen = True
    if "NUMBA_THREADING_LAYER" in os.environ or numba.config.THREADING_LAYER != "default":  # type: ignore[attr-defined]
        return
    try:
        numba.threading_layer()
    except ValueError:  # no layer started yet: the choice still takes effect
        numba.config.THREADING_LAYER = "workqueue"  # type: ignore[attr-defined]
