"""The domain-free least-squares engine: keyed unknowns, observation groups, solver, statistics,
data snooping, reliability and separability.

It imports nothing from scangeo but ``errors`` and ``progress``; the line-scanner block
(:mod:`scangeo.adjustment`) and the laser strips (:mod:`scangeo.lidar`) build on it.

Typical use::

    params = Parameters()
    params.add(Unknown("P1"), [0.0, 0.0, 0.0])
    result = adjust(params, [my_group], SolverOptions(), SnoopingOptions(critical_value=3.29))
    result.statistics.sigma0, result.statistics.sigmas(Unknown("P1"))
"""
from scangeo.lsq.engine import Adjustment, Rejection, SnoopingOptions, adjust
from scangeo.lsq.keys import Key, PointKey, Unknown
from scangeo.lsq.observations import Linearisation, ObservationGroup, PseudoObservations
from scangeo.lsq.parameters import JacobianPart, Layout, ParameterBlock, Parameters
from scangeo.lsq.solver import RegularisationNote, Solution, Solver, SolverOptions
from scangeo.lsq.statistics import Accounting, Coefficient, Statistics

__all__ = [
    "Accounting", "Adjustment", "Coefficient", "JacobianPart", "Key", "Layout", "Linearisation", "ObservationGroup",
    "ParameterBlock", "Parameters", "PointKey", "PseudoObservations", "RegularisationNote", "Rejection",
    "SnoopingOptions", "Solution", "Solver", "SolverOptions", "Statistics", "Unknown", "adjust",
]
