"""Parameter blocks under typed keys, and the layout that maps free parameters to columns.

A :class:`ParameterBlock` holds the current values of one block of unknowns, which of its components
are free (fixed components keep their values and get no column), an optional prior (a
pseudo-observation ``value = prior`` with a sigma per component) and the sigma to use when the
adjustment has to regularise a component on the fly. :class:`Parameters` is the ordered collection of
blocks; :class:`Layout` numbers the free components (the columns of the Jacobian and of the normal
equations) and converts group Jacobians, expressed per block, into one sparse matrix.
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from scangeo.errors import AdjustmentError
from scangeo.lsq.keys import Key


@dataclass
class ParameterBlock:
    """One block of unknowns.

    Attributes
    ----------
    key : Key
    values : (k,) float array, the current values in the block's units.
    free : (k,) bool array; False components are fixed (no column, never changed).
    prior_values, prior_sigma : (k,) float arrays or None. A finite ``prior_sigma[i]`` adds the
        pseudo-observation ``values[i] = prior_values[i]`` with that sigma (block units).
    regularisation_sigma : (k,) float array; the sigma of the pseudo-observation added on the fly
        when a component turns out to be undetermined.
    names : component names for reports (``"x"``, ``"c_z2"``, ...).
    conditions : number of conditions already eliminated by this block's parametrisation (for the
        accounting of unknowns and conditions only).
    """

    key: Key
    values: np.ndarray
    free: np.ndarray
    prior_values: np.ndarray | None = None
    prior_sigma: np.ndarray | None = None
    regularisation_sigma: np.ndarray | None = None
    names: tuple[str, ...] = ()
    conditions: int = 0

    def __post_init__(self) -> None:
        self.values = np.array(self.values, dtype=float).ravel()
        k = self.values.size
        self.free = np.broadcast_to(np.asarray(self.free, dtype=bool), (k,)).copy()
        if self.prior_sigma is not None:
            self.prior_sigma = np.broadcast_to(np.asarray(self.prior_sigma, float), (k,)).copy()
            if np.any(self.prior_sigma <= 0):
                raise AdjustmentError(f"{self.key.label}: prior sigmas must be positive (use inf for none)")
            pv = self.values if self.prior_values is None else self.prior_values
            self.prior_values = np.broadcast_to(np.asarray(pv, float), (k,)).copy()
        rs = 1.0 if self.regularisation_sigma is None else self.regularisation_sigma
        self.regularisation_sigma = np.broadcast_to(np.asarray(rs, float), (k,)).copy()
        if not self.names:
            self.names = tuple(str(i) for i in range(k))
        elif len(self.names) != k:
            raise AdjustmentError(f"{self.key.label}: {len(self.names)} names for {k} values")

    @property
    def size(self) -> int:
        return self.values.size


class Parameters:
    """An ordered collection of parameter blocks, indexed by key."""

    def __init__(self, blocks: Iterable[ParameterBlock] = ()) -> None:
        self._blocks: dict[Key, ParameterBlock] = {}
        for block in blocks:
            self.insert(block)

    def insert(self, block: ParameterBlock) -> ParameterBlock:
        if block.key in self._blocks:
            raise AdjustmentError(f"parameter block {block.key.label} defined twice")
        self._blocks[block.key] = block
        return block

    def add(self, key: Key, values, free=True, *, prior_sigma=None, prior_values=None,
            regularisation_sigma=None, names: Sequence[str] = (), conditions: int = 0) -> ParameterBlock:
        """Add a block; see :class:`ParameterBlock` for the arguments."""
        return self.insert(ParameterBlock(key, values, free, prior_values, prior_sigma,
                                          regularisation_sigma, tuple(names), conditions))

    def __getitem__(self, key: Key) -> ParameterBlock:
        try:
            return self._blocks[key]
        except KeyError:
            raise AdjustmentError(f"no parameter block {key.label}") from None

    def __contains__(self, key: object) -> bool:
        return key in self._blocks

    def __iter__(self) -> Iterator[ParameterBlock]:
        return iter(self._blocks.values())

    def __len__(self) -> int:
        return len(self._blocks)

    def keys(self) -> list[Key]:
        return list(self._blocks)

    def values(self) -> dict[Key, np.ndarray]:
        """A snapshot ``{key: values}`` (copies)."""
        return {k: b.values.copy() for k, b in self._blocks.items()}

    def set_values(self, values: Mapping[Key, np.ndarray]) -> None:
        for key, v in values.items():
            self[key].values[:] = v

    def copy(self) -> Parameters:
        return Parameters(
            ParameterBlock(b.key, b.values.copy(), b.free.copy(),
                           None if b.prior_values is None else b.prior_values.copy(),
                           None if b.prior_sigma is None else b.prior_sigma.copy(),
                           None if b.regularisation_sigma is None else b.regularisation_sigma.copy(),
                           b.names, b.conditions)
            for b in self
        )


@dataclass
class JacobianPart:
    """Jacobian entries of a group with respect to a list of blocks, as coordinates.

    ``values[e]`` is d(row ``rows[e]``)/d(component ``cols[e]`` of block ``keys[block[e]]``).
    ``block`` may be None when ``keys`` has a single key. All arrays broadcast to one shape.
    """

    keys: Sequence[Key]
    rows: np.ndarray
    cols: np.ndarray
    values: np.ndarray
    block: np.ndarray | None = None


@dataclass
class Layout:
    """Numbering of the free components of a :class:`Parameters` collection (the columns)."""

    keys: list[Key]
    start: dict[Key, int]            # first full index of each block (fixed components included)
    size: dict[Key, int]
    full_to_free: np.ndarray         # full index -> column, -1 for fixed components
    free_to_full: np.ndarray
    conditions: int = 0
    labels: list[tuple[Key, str]] = field(default_factory=list)

    @classmethod
    def of(cls, parameters: Parameters) -> Layout:
        start, size, free = {}, {}, []
        offset = 0
        for b in parameters:
            start[b.key], size[b.key] = offset, b.size
            free.append(b.free)
            offset += b.size
        free_all = np.concatenate(free) if free else np.zeros(0, bool)
        full_to_free = np.full(offset, -1, dtype=np.int64)
        free_to_full = np.flatnonzero(free_all)
        full_to_free[free_to_full] = np.arange(free_to_full.size)
        labels = [(b.key, b.names[i]) for b in parameters for i in np.flatnonzero(b.free)]
        conditions = sum(b.conditions for b in parameters)
        return cls(list(start), start, size, full_to_free, free_to_full, conditions, labels)

    @property
    def n(self) -> int:
        """Number of free unknowns (columns)."""
        return int(self.free_to_full.size)

    def columns(self, key: Key) -> np.ndarray:
        """Column of each component of a block (-1 where fixed)."""
        s = self.start[key]
        return self.full_to_free[s:s + self.size[key]]

    def full_indices(self, keys: Sequence[Key], block: np.ndarray | None, cols: np.ndarray) -> np.ndarray:
        try:
            starts = np.array([self.start[k] for k in keys], dtype=np.int64)
        except KeyError as exc:
            raise AdjustmentError(
                f"an observation refers to {exc.args[0].label}, which has no parameter block"
            ) from None
        base = starts[0] if block is None else starts[block]
        return base + cols

    def matrix(self, parts: Sequence[JacobianPart], n_rows: int) -> sp.csr_matrix:
        """The sparse Jacobian (n_rows x n) of a group from its parts; fixed components dropped."""
        rows, cols, vals = [], [], []
        for part in parts:
            r, c, v, b = np.broadcast_arrays(
                part.rows, part.cols, part.values, part.cols if part.block is None else part.block
            )
            full = self.full_indices(part.keys, None if part.block is None else b.ravel(), c.ravel())
            col = self.full_to_free[full]
            keep = col >= 0
            rows.append(r.ravel()[keep])
            cols.append(col[keep])
            vals.append(v.ravel()[keep])
        if not rows:
            return sp.csr_matrix((n_rows, self.n))
        return sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n_rows, self.n)
        )

    def add_step(self, values: Mapping[Key, np.ndarray], dx: np.ndarray) -> dict[Key, np.ndarray]:
        """``values`` moved by the column vector ``dx`` (fixed components unchanged), as a new dict."""
        out = {}
        for key in self.keys:
            v = np.array(values[key], dtype=float)
            cols = self.columns(key)
            f = cols >= 0
            v[f] += dx[cols[f]]
            out[key] = v
        return out

    def locate(self, column: int) -> tuple[Key, int]:
        """The block key and component index of a column."""
        full = int(self.free_to_full[column])
        starts = np.array([self.start[k] for k in self.keys])
        b = int(np.searchsorted(starts, full, side="right") - 1)
        return self.keys[b], full - int(starts[b])
