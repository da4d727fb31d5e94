"""What a variant's calibration found and how well the observations determine it (``report.json``'s
``calibration``).

For every free calibration unknown (boresight, lever arm, time offset, a whiskbroom's scan index and
scale, a pushbroom's across-track offset and scale and along-track offset): the estimate, its
a-posteriori sigma, the t-test against zero, its start value (project.toml's) with the change from it
and that change's t-test (``t_change``, at the variant's ``calibration_alpha``: did the calibration
move it significantly?), the prior's sigma where it has one, and the share of its
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
import scipy.stats

from scangeo.adjustment.keys import calibration_keys
from scangeo.lsq.keys import Key

#: how a value in the block's unit is shown: factor and unit
_SHOWN = {"rad": (math.degrees(1.0), "deg"), "m": (1.0, "m"), "s": (1.0, "s"), "1": (1.0, "")}


def _num(x) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def block_calibration(project) -> list[tuple[Key, str, str, str]]:
    """Every calibration block of a project's line scanners: (key, name in ``calibrate``, unit, sensor id),
    sensor by sensor in the file's order (a one-sensor project's: ``calibration_keys()``)."""
    return [(key, name, unit, sid) for sid in project.line_scanners for key, name, unit in calibration_keys(sid)]


def _free(result) -> list[tuple[Key, str, str, int, int, str]]:
    """(key, calibrate name, unit, component, column, sensor id) of every free calibration component."""
    params, layout = result.adjustment.parameters, result.adjustment.solution.layout
    out = []
    for key, name, unit, sensor in block_calibration(result.block.project):
        if key not in params:
            continue
        for i, col in enumerate(layout.columns(key)):
            if col >= 0:
                out.append((key, name, unit, i, int(col), sensor))
    return out


def label(name: str, component: str) -> str:
    """``boresight.roll``; a one-component block by its own name (``across_offset``)."""
    return name if component == name or component in ("dt", "index", "scale") else f"{name}.{component}"


def shown(unit: str, value: float) -> tuple[float, str]:
    """A value in the block's unit (rad, m, s, 1) as shown in reports: (value, unit)."""
    f, name = _SHOWN[unit]
    return value * f, name


def describe_change(name: str, component: str, unit: str, change: float, sigma: float) -> str:
    """``across_scale changed by 0.00086 +- 0.00055``, in the units reports show (deg for angles)."""
    c, u = shown(unit, change)
    s, _ = shown(unit, sigma)
    return f"{label(name, component)} changed by {c:.3g} +- {s:.2g}{' ' + u if u else ''}"


def calibration_summary(result, threshold: float = 0.95) -> dict:
    """``{"parameters": [...], "correlation": {"names", "matrix"}, "correlated": [...]}`` (module docstring);
    empty lists when the variant calibrates nothing."""
    adj = result.adjustment
    stats, params = adj.statistics, adj.parameters
    free = _free(result)
    if not free:
        return {"parameters": [], "correlation": {"names": [], "matrix": []}, "correlated": [],
                "tests": tests_shown(result)}
    cols = np.array([c for *_, c, _ in free])
    scale = adj.solution.system.scale[cols]
    q = stats.inverse.block(cols) / np.outer(scale, scale)  # a-priori cofactors (sigma0 = 1)
    sd = np.sqrt(np.diag(q))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = q / np.outer(sd, sd)
    sigma0 = stats.sigma0
    critical = float(scipy.stats.t.ppf(1 - result.variant.calibration_alpha / 2, max(stats.redundancy, 1)))
    significance = {(c.key, c.component): c for key in dict.fromkeys(k for k, *_ in free)
                    for c in stats.significance(key)}
    rows, names = [], []
    for k, (key, name, unit, i, _, sensor) in enumerate(free):
        block = params[key]
        comp = block.names[i]
        f, unit_shown = _SHOWN[unit]
        c = significance[(key, comp)]
        prior = None if block.prior_sigma is None or not np.isfinite(block.prior_sigma[i]) else float(
            block.prior_sigma[i])
        share = None if prior is None else max(0.0, 1.0 - float(q[k, k]) / prior**2)
        names.append(f"{sensor} {label(name, comp)}" if sensor else label(name, comp))
        start = result.block.calibration_start.get(key)
        x0 = float(start[i]) if start is not None else 0.0
        t_change = abs(c.value - x0) / c.sigma if c.sigma > 0 else None
        rows.append({"name": names[-1], "calibrate": name, **({"sensor": sensor} if sensor else {}),
                     "unit": unit_shown, "value": _num(c.value * f),
                     "sigma": _num(c.sigma * f), "t": _num(c.t), "significant": c.significant,
                     "start": _num(x0 * f), "change": _num((c.value - x0) * f), "t_change": _num(t_change),
                     "significant_change": bool(t_change is not None and t_change > critical),
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
            "correlated": pairs, "tests": tests_shown(result)}


def tests_shown(result) -> list[dict]:
    """The variant's ``test_calibration`` decisions in the units reports show."""
    out = []
    for t in getattr(result.block, "calibration_tests", []):
        f, unit = _SHOWN[t["unit"]]
        out.append({"name": label(t["unknown"], t["component"]), "unit": unit, "value": _num(t["value"] * f),
                    "start": _num(t["start"] * f), "sigma": _num(t["sigma"] * f), "t": _num(t["t"]),
                    "critical": _num(t["critical"]), "kept": t["kept"]})
    return out


__all__ = ["calibration_summary", "label"]
