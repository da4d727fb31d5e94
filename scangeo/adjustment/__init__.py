"""The least-squares adjustment engine: keyed unknowns, observation groups, solver, statistics.

Typical use::

    params = Parameters()
    params.add(Ground("P1"), [0.0, 0.0, 0.0])
    result = adjust(params, [my_group], SolverOptions(), SnoopingOptions(critical_value=3.29))
    result.statistics.sigma0, result.statistics.sigmas(Ground("P1"))
"""
from scangeo.adjustment.engine import Adjustment, Rejection, SnoopingOptions, adjust
from scangeo.adjustment.keys import (
                                     Boresight,
                                     Correction,
                                     Ground,
                                     Key,
                                     Knots,
                                     LeverArm,
                                     ScanIndex,
                                     ScanScale,
                                     TimeOffset,
                                     Unknown,
)
from scangeo.adjustment.observations import Linearisation, ObservationGroup, PseudoObservations
from scangeo.adjustment.parameters import JacobianPart, Layout, ParameterBlock, Parameters
from scangeo.adjustment.solver import RegularisationNote, Solution, Solver, SolverOptions
from scangeo.adjustment.statistics import Accounting, Coefficient, Statistics

__all__ = [
    "Accounting", "Adjustment", "Boresight", "Coefficient", "Correction", "Ground", "JacobianPart", "Key",
    "Knots", "Layout", "LeverArm", "Linearisation", "ObservationGroup", "ParameterBlock", "Parameters",
    "PseudoObservations", "RegularisationNote", "Rejection", "ScanIndex", "ScanScale", "SnoopingOptions",
    "Solution", "Solver", "SolverOptions", "Statistics", "TimeOffset", "Unknown", "adjust",
]
