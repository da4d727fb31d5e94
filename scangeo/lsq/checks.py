"""Finite-difference check of an observation group's analytic Jacobian (shared by the tests)."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from scangeo.lsq.keys import Key
from scangeo.lsq.observations import ObservationGroup, Values
from scangeo.lsq.parameters import Layout, Parameters


@dataclass
class JacobianCheck:
    """Analytic and central-difference Jacobians (dense, n_rows x n) and their largest difference."""

    analytic: np.ndarray
    numeric: np.ndarray
    labels: list[tuple[Key, str]]

    @property
    def max_error(self) -> float:
        return float(np.max(np.abs(self.analytic - self.numeric), initial=0.0))

    @property
    def max_relative_error(self) -> float:
        """Largest error relative to the largest entry of its column.

        Columns whose entries are all below 1e-6 of the largest entry of the Jacobian are measured
        against that floor (their numeric derivatives are rounding noise).
        """
        scale = np.max(np.abs(self.numeric), axis=0, initial=0.0)
        floor = 1e-6 * float(np.max(scale, initial=0.0))
        scale = np.maximum(scale, floor if floor > 0 else 1.0)
        return float(np.max(np.abs(self.analytic - self.numeric) / scale, initial=0.0))

    def worst(self) -> str:
        if self.analytic.size == 0:
            return "empty"
        i, j = np.unravel_index(np.argmax(np.abs(self.analytic - self.numeric)), self.analytic.shape)
        key, name = self.labels[j]
        return (f"row {i}, {key.label}[{name}]: analytic {self.analytic[i, j]:.9g}, "
                f"numeric {self.numeric[i, j]:.9g}")


def check_jacobian(group: ObservationGroup, values: Values,
                   steps: float | Mapping[Key, float | np.ndarray] = 1e-6,
                   stride: Mapping[Key, int] | None = None) -> JacobianCheck:
    """Compare ``group``'s Jacobian at ``values`` with central differences.

    Parameters
    ----------
    group : the observation group.
    values : ``{key: array}`` for every key the group uses.
    steps : the difference step, one for all or per key (scalar or per component), in the units of
        the unknowns.
    stride : per key, check only every n-th component (the others are left out of the result; e.g. 7
        for a spline's (K, 6) coefficients visits every component kind across the knots).
    """
    params = Parameters()
    for key in group.keys():
        params.add(key, values[key], True)
    layout = Layout.of(params)
    lin = group.linearise(values)
    analytic = layout.matrix(lin.parts, group.n_rows).toarray()
    numeric = np.zeros_like(analytic)
    base = {k: np.array(values[k], dtype=float) for k in group.keys()}
    checked = []
    for col, full in enumerate(layout.free_to_full):
        key = next(k for k in layout.keys if layout.start[k] <= full < layout.start[k] + layout.size[k])
        i = full - layout.start[key]
        if stride is not None and i % stride.get(key, 1):
            continue
        checked.append(col)
        if isinstance(steps, Mapping):
            h = float(np.broadcast_to(steps.get(key, 1e-6), (layout.size[key],))[i])
        else:
            h = float(steps)
        plus, minus = dict(base), dict(base)
        plus[key] = base[key].copy()
        minus[key] = base[key].copy()
        plus[key][i] += h
        minus[key][i] -= h
        numeric[:, col] = (group.residuals(plus) - group.residuals(minus)) / (2 * h)
    if stride is not None:
        return JacobianCheck(analytic[:, checked], numeric[:, checked], [layout.labels[c] for c in checked])
    return JacobianCheck(analytic, numeric, layout.labels)
