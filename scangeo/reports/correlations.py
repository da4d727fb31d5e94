"""Pairs of unknowns the observations cannot tell apart: correlations above 0.95, with a plain note.

For every GPS/IMU model (``Correction`` key) the correlation matrix of its coefficients, and of the
calibration unknowns a variant frees (boresight, lever arm, time offset, a whiskbroom's scan index and
scale, a pushbroom's across-track offset and scale and along-track offset) with
them, comes from the adjustment's selected inverse (``Statistics.covariance`` of the columns
together; pairs outside the factor's pattern are not available and not flagged). A pair with
``|r| > threshold`` (0.95) is listed with a note in plain language: a shift across track and a roll
of a strip with control only in narrow bands at its ends move the footprint alike; the
observations determine their combination, not each one.
"""
from __future__ import annotations

import numpy as np

from scangeo.adjustment.calibration import block_calibration
from scangeo.orientation.models import Correction

_KIND = {"x": "shift in x", "y": "shift in y", "z": "height shift", "roll": "roll", "pitch": "pitch",
         "heading": "heading", "omega": "rotation"}


def _describe(name: str) -> str:
    base = name.rstrip("0123456789")
    degree = name[len(base):]
    kind = next((v for k, v in _KIND.items() if base.startswith(k)), name)
    if not degree:
        return kind
    return kind if degree == "0" else f"{kind} (degree {degree} term)"


_MEANING = ("move the footprint alike (one can stand in for the other), so the observations fix their "
            "combination, not each one; control across the strip or in more bands separates them (or leave one "
            "out: a degree, the rotation, a calibration unknown)")


def note(a: str, b: str, r: float, model: str) -> str:
    """A plain-language note for a correlated pair of model ``model``."""
    return f"the {_describe(a)} and the {_describe(b)} of {model} are correlated {r:+.3f}: they {_MEANING}"


def pair_kind(a: str, b: str) -> str:
    """The kind of a correlated pair, whatever its model: ``shift in x ~ roll``."""
    return f"{_describe(a)} ~ {_describe(b)}"


def explanation(a: str, b: str) -> str:
    """What a correlation of the kind of pair (``a``, ``b``) means, said once for all its models."""
    return f"The {_describe(a)} and the {_describe(b)} of a GPS/IMU model {_MEANING}."


def correlated_pairs(result, threshold: float = 0.95) -> list[dict]:
    """``[{model, a, b, r, note}]`` for every pair of unknowns with ``|r| > threshold`` (module docstring)."""
    adj = result.adjustment
    stats, layout, params = adj.statistics, adj.solution.layout, adj.parameters
    calib = [k for k, *_ in block_calibration(result.block.project) if k in params and params[k].free.any()]
    out = []
    for block in params:
        key = block.key
        if not isinstance(key, Correction):
            continue
        keys = [key] + calib
        cols: list[int] = []
        names: list[str] = []
        own = int((layout.columns(key) >= 0).sum())
        for k in keys:
            c = layout.columns(k)
            blk = params[k]
            for i, col in enumerate(c):
                if col >= 0:
                    cols.append(int(col))
                    prefix = "" if k == key else f"{type(k).__name__.lower()} "
                    names.append(prefix + blk.names[i])
        if len(cols) < 2:
            continue
        cols_a = np.asarray(cols)
        scale = adj.solution.system.scale[cols_a]
        cov = stats.inverse.block(cols_a) / np.outer(scale, scale)
        sd = np.sqrt(np.diag(cov))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(sd, sd)
        for i in range(len(cols)):
            for j in range(i + 1, len(cols)):
                r = corr[i, j]
                if np.isfinite(r) and abs(r) > threshold and not (i >= own and j >= own):
                    out.append({"model": key.model, "a": names[i], "b": names[j], "r": round(float(r), 4),
                                "note": note(names[i], names[j], float(r), f"model {key.model}")})
    return out


__all__ = ["correlated_pairs", "explanation", "note", "pair_kind"]
