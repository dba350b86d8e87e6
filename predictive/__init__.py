"""Predictive gait simulation (direct collocation with CasADi/IPOPT) on the sspinn model.

Builds on :mod:`sspinn` (never the other way round). Main entry point:
:func:`solve_predictive`; results are :class:`GaitSolution` objects. Command line:
``python -m predictive solve --speed 1.3 --out results/ocp/walk_1.3``.
"""

from predictive.ocp.collocation import (
    DEFAULT_STARTS,
    OCPError,
    OCPSettings,
    PredictiveGaitProblem,
    Start,
    default_joint_limits,
    solve_predictive,
    typical_stride_duration,
)
from predictive.ocp.solution import GaitSolution

__all__ = [
    "DEFAULT_STARTS",
    "GaitSolution",
    "OCPError",
    "OCPSettings",
    "PredictiveGaitProblem",
    "Start",
    "default_joint_limits",
    "solve_predictive",
    "typical_stride_duration",
]
