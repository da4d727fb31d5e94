"""Control and check patches of a laser project: surveyed points on planar surfaces (ground.csv).

``point,patch,x,y,z,sigma_xy,sigma_z,role``: several surveyed points per patch (at least three, on a
roof face or flat ground). Each point's role:

- ``control``: the point lies in its patch's adjusted plane (normal distance 0, sigma ``sigma_z``);
  a roof patch of the paper has four points, three of them control;
- ``height``: a height-only control plane (a sports field): the plane's height above the point's
  x, y is the point's z (vertical distance 0), its horizontal position is free;
- ``check``: the point stays out of the adjustment and is compared with the adjusted plane after it
  (the paper's fourth roof point). A patch whose points are all ``check`` is a check patch: compared
  with every strip's corrected plane there.

A patch holds control or height points, not both. Each patch's footprint is the box around its
points (principal axes of their x, y) grown by a margin; the strips' returns inside it give the
strip's plane there.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scangeo.errors import ProjectFileError
from scangeo.io.points import column_floats, read_rows


@dataclass
class GivenPatches:
    """Control and check patches of ground.csv; each patch's footprint is the box around its surveyed
    points (principal axes of their x, y) grown by a margin."""

    ids: list[str]
    role: list[str]
    centre: np.ndarray  # (m, 2) map
    axes: np.ndarray  # (m, 2, 2) unit axes (rows) of the footprint box
    half: np.ndarray  # (m, 2) half extents along them
    point_ids: np.ndarray
    point_patch: np.ndarray
    xyz: np.ndarray  # (k, 3) map
    sigma: np.ndarray
    point_role: np.ndarray  # (k,) control, height or check


ROLES = ("control", "height", "check")


def read_patch_ground(path: Path, margin: float = 1.0) -> GivenPatches:
    """ground.csv of a laser project: ``point,patch,x,y,z,sigma_xy,sigma_z,role`` (roles above)."""
    header, body, numbers = read_rows(path, ["point", "patch", "x", "y", "z"], ["sigma_xy", "sigma_z", "role"])
    xyz = np.column_stack([column_floats(path, header, body, numbers, c) for c in "xyz"])
    sig = column_floats(path, header, body, numbers, "sigma_z", 0.01)
    for column in ("sigma_xy", "sigma_z"):
        values = column_floats(path, header, body, numbers, column, 0.01)
        bad = np.flatnonzero(~(values > 0.0))
        if bad.size:
            raise ProjectFileError(
                f"{path} line {numbers[bad[0]]}: {column} = {values[bad[0]]:g}: expected a positive number of metres"
            )
    roles = [r[header.index("role")] if "role" in header else "control" for r in body]
    for r, line in zip(roles, numbers):
        if r not in ROLES:
            raise ProjectFileError(
                f"{path} line {line}: role {r!r}: expected control, height or check for a laser project"
            )
    pid = np.array([r[header.index("patch")] for r in body])
    ids = list(dict.fromkeys(pid))
    role, centre, axes, half = [], [], [], []
    for p in ids:
        sel = np.flatnonzero(pid == p)
        if sel.size < 3:
            raise ProjectFileError(
                f"{path} line {numbers[sel[0]]}: patch {p} has {sel.size} points (at least 3 needed)"
            )
        kinds = {roles[i] for i in sel} - {"check"}
        if len(kinds) > 1:
            raise ProjectFileError(f"{path} line {numbers[sel[0]]}: patch {p} mixes the roles control and height")
        if kinds and sum(roles[i] != "check" for i in sel) < 3:
            raise ProjectFileError(f"{path} line {numbers[sel[0]]}: patch {p} has fewer than 3 {kinds.pop()} points "
                                   "(its check points do not count)")
        role.append(kinds.pop() if kinds else "check")
        c = xyz[sel, :2].mean(axis=0)
        _, vec = np.linalg.eigh(np.cov((xyz[sel, :2] - c).T))
        ax = vec.T[::-1]
        centre.append(c)
        axes.append(ax)
        half.append(np.abs((xyz[sel, :2] - c) @ ax.T).max(axis=0) + margin)
    point_patch = np.array([ids.index(p) for p in pid])
    return GivenPatches(
        ids,
        role,
        np.array(centre),
        np.array(axes),
        np.array(half),
        np.array([r[header.index("point")] for r in body]),
        point_patch,
        xyz,
        sig,
        np.array(roles),
    )
