"""Observation groups: stateless, vectorised, returning whitened residuals and a sparse Jacobian.

An observation group owns ``n_rows`` scalar observations with their a priori sigmas. Given the values
of the unknowns (a mapping ``key -> array``) it returns :class:`Linearisation`: the whitened residuals
``r = (f(x) - l) / sigma`` (model minus observation, in units of sigma) and the Jacobian ``dr/dx`` as
:class:`~scangeo.lsq.parameters.JacobianPart` coordinates per block. Fixed parameters are the
layout's business: a group always differentiates with respect to every component it touches.

Rows are grouped into *observation units* (``row_unit``): the rows that data snooping removes together
(the line and pixel of one image measurement, the x, y, z of one control point).
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from scangeo.lsq.keys import Key
from scangeo.lsq.parameters import JacobianPart

Values = Mapping[Key, np.ndarray]


@dataclass
class Linearisation:
    """Whitened residuals (n_rows,) and the Jacobian parts of one group at one point."""

    residuals: np.ndarray
    parts: list[JacobianPart]


class ObservationGroup(ABC):
    """Base of every observation group.

    Subclasses set ``name`` (a label for reports), ``sigma`` (n_rows,) a priori standard deviations
    in ``units`` (one unit string per row), ``ids`` (an observation id per row, e.g. the point name),
    ``components`` (per row, e.g. ``"line"``/``"pixel"`` or ``"x"``), and ``row_unit`` (per row, the
    index of its observation unit). ``kind`` says what the group is for the accounting:
    ``"observation"`` or ``"pseudo"`` (priors, regularisation, coefficient = 0).
    """

    name: str = "observations"
    kind: str = "observation"
    #: whether data snooping tests (and may remove) this group's observations
    snooped: bool = True
    sigma: np.ndarray
    units: np.ndarray
    ids: np.ndarray
    components: np.ndarray
    row_unit: np.ndarray

    @property
    def n_rows(self) -> int:
        return int(self.sigma.size)

    @abstractmethod
    def keys(self) -> Sequence[Key]:
        """The keys of every block this group depends on."""

    @abstractmethod
    def linearise(self, values: Values) -> Linearisation:
        """Whitened residuals and Jacobian at ``values``."""

    def residuals(self, values: Values) -> np.ndarray:
        """Whitened residuals only (groups may override with a cheaper computation)."""
        return self.linearise(values).residuals

    def _describe(self, ids, components, units, row_unit=None) -> None:
        """Set the per-row descriptions (broadcast to ``n_rows``)."""
        n = self.n_rows
        self.ids = np.broadcast_to(np.asarray(ids, dtype=object), (n,)).copy()
        self.components = np.broadcast_to(np.asarray(components, dtype=object), (n,)).copy()
        self.units = np.broadcast_to(np.asarray(units, dtype=object), (n,)).copy()
        self.row_unit = np.arange(n) if row_unit is None else np.asarray(row_unit, dtype=np.int64)


class PseudoObservations(ObservationGroup):
    """Pseudo-observations ``x[key][component] = value`` with sigma, one row each.

    Used for priors, for the preventive regularisation of correction coefficients (value 0) and for
    the regularisation the solver adds on the fly.
    """

    kind = "pseudo"

    def __init__(self, name: str, keys: Sequence[Key], components: np.ndarray, values: np.ndarray,
                 sigma: np.ndarray, component_names: Sequence[str] | None = None) -> None:
        self.name = name
        self._keys = list(keys)
        uniq = {k: i for i, k in enumerate(dict.fromkeys(self._keys))}
        self._unique = list(uniq)
        self._block = np.array([uniq[k] for k in self._keys], dtype=np.int64)
        self._cols = np.asarray(components, dtype=np.int64)
        self.value = np.asarray(values, dtype=float)
        self.sigma = np.asarray(sigma, dtype=float)
        names = component_names if component_names is not None else [str(c) for c in self._cols]
        self._describe([k.label for k in self._keys], list(names), "")

    def keys(self) -> Sequence[Key]:
        return self._unique

    def linearise(self, values: Values) -> Linearisation:
        x = np.array([values[k][c] for k, c in zip(self._keys, self._cols)], dtype=float)
        r = (x - self.value) / self.sigma
        rows = np.arange(self.n_rows)
        return Linearisation(r, [JacobianPart(self._unique, rows, self._cols, 1.0 / self.sigma, self._block)])
