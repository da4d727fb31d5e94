"""The previous scangeo ground -> image kernel, frozen, as a baseline for tests/benchmarks.

``scangeo/sensors/kernels.py`` as of commit ``PREVIOUS_COMMIT`` (the last before whiskbroom strips
moved to ``scangeo.sensors.ground_to_image_kernels``) is taken from the repository's history with
``git show`` (not copied into the tree) into a cache directory and imported from there, so the
baseline stays the same code whatever later commits do to ``kernels.py``. ``previous_ground_to_image``
calls it exactly as ``StripGeometry.ground_to_image`` did then.
"""
from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

PREVIOUS_COMMIT = "3a331b5"
REPO = Path(__file__).resolve().parents[2]


def previous_kernels():
    """The frozen kernels module, or None when the repository's history is not available."""
    target = Path(tempfile.gettempdir()) / "scangeo_previous_kernels" / f"kernels_{PREVIOUS_COMMIT}.py"
    if not target.exists():
        try:
            text = subprocess.run(["git", "-C", str(REPO), "show", f"{PREVIOUS_COMMIT}:scangeo/sensors/kernels.py"],
                                  check=True, capture_output=True, text=True).stdout
        except (OSError, subprocess.CalledProcessError):
            return None
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_suffix(".tmp")
        tmp.write_text(text)
        tmp.replace(target)
    if target.stem in sys.modules:
        return sys.modules[target.stem]
    spec = importlib.util.spec_from_file_location(target.stem, target)
    module = importlib.util.module_from_spec(spec)
    sys.modules[target.stem] = module  # numba's cache finds the module's functions by its name
    spec.loader.exec_module(module)
    return module


def previous_ground_to_image(kernels, strip, p_P: np.ndarray, tol_line: float = 1e-6):
    """(line, pixel, status) of project-frame points by the frozen kernel (as the strip did then)."""
    p_P = np.ascontiguousarray(np.atleast_2d(np.asarray(p_P, dtype=float)))
    n = len(p_P)
    times, R, p, _, _ = strip._coarse
    kind, sp, table = strip.sensor.kernel_params()
    tan_c = float(np.tan(strip.sensor.along_angle(np.array([0.5 * (strip.sensor.pixels - 1)]))[0]))
    cA = np.ascontiguousarray(R[:, :, 0] - tan_c * R[:, :, 2])
    cC = np.einsum("ki,ki->k", cA, p)
    line, pixel, status = np.empty(n), np.empty(n), np.empty(n, dtype=np.int64)
    kernels.ground_to_image_kernel(
        p_P, *strip._mount_args(), kind, sp, np.ascontiguousarray(table, dtype=float), *strip._timing_args(),
        float(strip.n_lines), times, cA, cC, strip.overscan_window(p_P), tol_line / strip.timing.mean_rate,
        max(1, min(n, 256)), line, pixel, status,
    )
    return line, pixel, status
