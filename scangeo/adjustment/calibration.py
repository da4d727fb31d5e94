"""What a variant's calibration found and how well the observations determine it (``report.json``'s
``calibration``).

For every free calibration unknown (boresight, lever arm, time offset, a whiskbroom's scan index and
scale, a pushbroom's across-track offset and scale and along-track offset): the estimate, its
a-posteriori sigma, the t-test against zero, the prior's sigma where it has one, and the share of its
information that comes from the observations rather than from its prior,
``data_share = 1 - sigma_apriori^2 / sigma_prior^2`` (both without sigma0: 1 = determined by the
data alone, 0 = only by its prior). Then the correlation matrix of all of them, and the pairs above
``threshold`` (0.95) with a plain note: a pushbroom's across-track offset and the boresight roll,
its along-track offset and the boresight pitch (and the time offset on straight lines) move the
image alike; the observations fix their sum, the priors decide the split.
"""
from __future__ import annotations

import math

import numpy as np

from scangeo.adjustment.keys import CALIBRATION_KEYS
from scangeo.lsq.keys import Key

#: how a value in the block's unit is shown: factor and unit
_SHOWN = {"rad": (math.degrees(1.0), "deg"), "m": (1.0, "m"), "s": (1.0, "s"), "1": (1.0, "")}


def _num(x) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def _free(result) -> list[tuple[Key, str, str, int, int]]:
    """(key, calibrate name, unit, component, column) of every free calibration component."""
    params, layout = result.adjustment.parameters, result.adjustment.solution.layout
    out = []
    for key, name, unit in CALIBRATION_KEYS:
        if key not in params:
            continue
        for i, col in enumerate(layout.columns(key)):
            if col >= 0:
                out.append((key, name, unit, i, int(col)))
    return out


def label(name: str, component: str) -> str:
    """``boresight.roll``; a one-component block by its own name (``across_offset``)."""
    return name if component == name or component in ("dt", "index", "scale") else f"{name}.{component}"


def calibration_summary(result, threshold: float = 0.95) -> dict:
    """``{"parameters": [...], "correlation": {"names", "matrix"}, "correlated": [...]}`` (module docstring);
    empty lists when the variant calibrates nothing."""
    adj = result.adjustment
    stats, params = adj.statistics, adj.parameters
    free = _free(result)
    if not free:
        return {"parameters": [], "correlation": {"names": [], "matrix": []}, "correlated": []}
    cols = np.array([c for *_, c in free])
    scale = adj.solution.system.scale[cols]
    q = stats.inverse.block(cols) / np.outer(scale, scale)  # a-priori cofactors (sigma0 = 1)
    sd = np.sqrt(np.diag(q))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = q / np.outer(sd, sd)
    sigma0 = stats.sigma0
    significance = {(c.key, c.component): c for key in dict.fromkeys(k for k, *_ in free)
                    for c in stats.significance(key)}
    rows, names = [], []
    for k, (key, name, unit, i, _) in enumerate(free):
        block = params[key]
        comp = block.names[i]
        f, shown = _SHOWN[unit]
        c = significance[(key, comp)]
        prior = None if block.prior_sigma is None or not np.isfinite(block.prior_sigma[i]) else float(
            block.prior_sigma[i])
        share = None if prior is None else max(0.0, 1.0 - float(q[k, k]) / prior**2)
        names.append(label(name, comp))
        rows.append({"name": names[-1], "calibrate": name, "unit": shown, "value": _num(c.value * f),
                     "sigma": _num(c.sigma * f), "t": _num(c.t), "significant": c.significant,
                     "prior_sigma": _num(None if prior is None else prior * f),
                     "data_share": _num(share)})
    pairs = []
    for a in range(len(free)):
        for b in range(a + 1, len(free)):
            r = float(corr[a, b])
            if math.isfinite(r) and abs(r) > threshold:
                pairs.append({"a": names[a], "b": names[b], "r": round(r, 4), "note": (
                    f"{names[a]} and {names[b]} are correlated {r:+.3f}: they move the image alike, the "
                    "observations determine their combination; each one's value comes from the priors "
                    "(see data_share)")})
    matrix = [[_num(round(float(v), 4)) for v in row] for row in corr]
    return {"parameters": rows, "sigma0": _num(sigma0), "correlation": {"names": names, "matrix": matrix},
            "correlated": pairs}


__all__ = ["calibration_summary", "label"]
