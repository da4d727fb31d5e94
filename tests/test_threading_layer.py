"""Importing scangeo leaves numba alone; scangeo's parallel kernels choose numba's ``workqueue``
threading layer before their first run unless the user chose a layer."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest


def _run(code: str, **env: str) -> str:
    environ = {k: v for k, v in os.environ.items() if k != "NUMBA_THREADING_LAYER"}
    environ.update(env)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=environ, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_import_scangeo_does_not_load_or_configure_numba():
    # numba is not even imported by `import scangeo` ...
    assert _run("import sys, scangeo; print('numba' in sys.modules)") == "False"
    # ... and when the user imported it first, its configuration is left as it was
    out = _run("import numba; before = numba.config.THREADING_LAYER; import scangeo; "
               "print(before, numba.config.THREADING_LAYER)")
    assert out == "default default"


# a parallel kernel through its entry point: bilinear values of a small raster on a lattice
_KERNEL = ("import numpy as np, numba; from affine import Affine; from scangeo.grid import RasterGrid; "
           "g = RasterGrid(np.arange(12.0).reshape(3, 4), Affine(1, 0, 0, 0, -1, 3)); "
           "v = g.sample_lattice(np.array([0.5, 1.5]), np.array([2.5])); "
           "print(v.tolist(), numba.threading_layer())")


def test_parallel_kernels_run_on_workqueue_when_the_user_chose_nothing():
    assert _run(_KERNEL) == "[[0.0, 1.0]] workqueue"


@pytest.mark.parametrize("how", ["environment", "config"])
def test_a_users_choice_of_threading_layer_is_kept(how):
    if how == "environment":
        out = _run(_KERNEL, NUMBA_THREADING_LAYER="omp")
    else:
        out = _run("import numba; numba.config.THREADING_LAYER = 'omp'; " + _KERNEL)
    assert out == "[[0.0, 1.0]] omp"


def test_a_layer_numba_already_started_is_left_alone():
    # the user's own parallel code ran first (on numba's default choice): scangeo does not try to change it
    out = _run("import numba; numba.get_num_threads(); first = numba.threading_layer(); "
               + _KERNEL.replace("print(v.tolist(), numba.threading_layer())",
                                 "print(first == numba.threading_layer(), numba.config.THREADING_LAYER)"))
    assert out == "True default"
