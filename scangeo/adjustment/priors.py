"""Priors, regularisation and data snooping of a variant, for both sensors (images and laser strips).

One set of constants and one function each, used by the line-scanner block
(:mod:`scangeo.adjustment.block`) and the laser block (:mod:`scangeo.lidar.adjust`):

- :func:`correction_sigmas`: the prior "= 0" (preventive regularisation) and the regularisation sigma
  of every coefficient of a GPS/IMU correction model, from the variant's sigmas;
- :func:`add_calibration`: the calibration unknowns with their regularisation sigmas
  (``*_REGULARISATION_*``);
- :func:`snooping_options`: the engine's data snooping settings of a variant.

A regularisation sigma is the sigma of the pseudo-observation ``x = current value`` that the solver
adds on the fly to an unknown no observation determines (:mod:`scangeo.lsq.solver`). It bounds what
is plausible for that unknown, so that a numerically weak combination is held without pulling the
determined ones: for angles 0.01 rad (0.57 deg, the size of a gross boresight misalignment, ten times
the largest IMU attitude error), for GPS positions 10 m, for a lever arm 0.5 m. A coefficient's own
prior, when tighter, is used instead.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from scangeo.adjustment.variants import Variant
from scangeo.lsq.engine import SnoopingOptions
from scangeo.lsq.keys import Key
from scangeo.lsq.parameters import Parameters
from scangeo.orientation.models import GpsImuModel, coefficient_priors

#: Regularisation sigma of angles: attitude corrections, boresight, scan-angle index error (radians).
ANGLE_REGULARISATION_RAD = 0.01
#: Regularisation sigma of the GPS/IMU position corrections (metres).
POSITION_REGULARISATION_M = 10.0
#: Regularisation sigma of a component a model leaves out (degree -1): held at zero (its unit).
UNMODELLED_REGULARISATION = 1e-3
#: Regularisation sigma of the lever arm (metres).
LEVER_ARM_REGULARISATION_M = 0.5
#: Regularisation sigma of the sensor's time offset (seconds).
TIME_OFFSET_REGULARISATION_S = 0.01
#: Regularisation sigma of a whiskbroom's scan-angle scale error (1).
SCALE_REGULARISATION = 0.01
#: Regularisation sigma of a laser's range offset (metres).
RANGE_OFFSET_REGULARISATION_M = 0.05


def correction_sigmas(model: GpsImuModel, variant: Variant, unit: float = 1.0,
                      constant_sigma_m: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Prior sigmas (``inf``: none) and regularisation sigmas of a correction model's coefficients.

    Parameters
    ----------
    model : the GPS/IMU correction model (its coefficients' degrees and which are angles).
    variant : the sigmas ``coefficient_sigma_m`` / ``_deg`` (degree >= 1) and ``constant_sigma_m`` /
        ``_deg`` (degree 0) of the priors "= 0".
    unit : metres per unit of the position coefficients (1; a map CRS's unit in the laser's
        trajectory-free mode, where positions are corrected in map units).
    constant_sigma_m : the constant terms' position prior when the variant gives none (the laser's
        trajectory-free mode: 0.3 m).

    Returns
    -------
    prior, regularisation : (k,) arrays, radians for angles and ``unit`` for positions.
    """
    const_m = variant.constant_sigma_m if variant.constant_sigma_m is not None else constant_sigma_m
    prior = coefficient_priors(model, variant.coefficient_sigma_m / unit, variant.coefficient_sigma_deg,
                               None if const_m is None else const_m / unit, variant.constant_sigma_deg)
    deg, angular = model.degrees(), model.angular()
    coefficient = np.where(angular, np.radians(variant.coefficient_sigma_deg), variant.coefficient_sigma_m / unit)
    bound = np.where(angular, ANGLE_REGULARISATION_RAD, POSITION_REGULARISATION_M / unit)
    return prior, np.where(deg < 0, UNMODELLED_REGULARISATION, np.minimum(coefficient, bound))


def add_calibration(params: Parameters, blocks: Sequence[tuple[str, Key, ArrayLike, Sequence[str], float]],
                    calibrate: Iterable[str]) -> None:
    """The calibration unknowns, in the order given: ``(name, key, nominal values, component names,
    regularisation sigma)`` each, free when its name is in ``calibrate`` (else held at its nominal value)."""
    free = set(calibrate)
    for name, key, values, names, sigma in blocks:
        params.add(key, np.asarray(values, float), name in free, regularisation_sigma=sigma, names=list(names))


def snooping_options(variant: Variant, enabled: bool | None = None) -> SnoopingOptions:
    """The data snooping of a variant (``enabled``: None as the variant says, else on or off)."""
    return SnoopingOptions(enabled=variant.snooping if enabled is None else enabled,
                           critical_value=variant.critical_value, per_round=max(1, variant.rejections_per_round),
                           independent=variant.independent_rejections, method=variant.snooping_method)


__all__ = ["ANGLE_REGULARISATION_RAD", "LEVER_ARM_REGULARISATION_M", "POSITION_REGULARISATION_M",
           "RANGE_OFFSET_REGULARISATION_M", "SCALE_REGULARISATION", "TIME_OFFSET_REGULARISATION_S",
           "UNMODELLED_REGULARISATION", "add_calibration", "correction_sigmas", "snooping_options"]
