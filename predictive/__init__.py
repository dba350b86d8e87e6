"""Predictive gait simulation on the sspinn model: trajectory optimisation, synthetic data, a
self-supervised gait generator and the experiments that compare them.

Builds on :mod:`sspinn` (never the other way round). Rooms: :mod:`predictive.ocp` (direct
collocation with CasADi/IPOPT, tracking, the stride NLP, solutions and their analysis),
:mod:`predictive.synth` (physically exact synthetic datasets), :mod:`predictive.generator` (the
self-supervised gait generator and closed-loop deployment) and :mod:`predictive.experiments`
(comparison harness, robustness, solutions against labels); :mod:`predictive.controller` is the
one controller protocol (SB3's ``predict`` convention) they all share. Main entry point: :func:`solve_predictive`;
results are :class:`GaitSolution` objects. Command line:
``python -m predictive solve --speed 1.3 --out results/ocp/walk_1.3`` (``--help`` lists the others).
"""

from predictive.ocp.collocation import (
    DEFAULT_STARTS,
    OCPError,
    OCPSettings,
    PredictiveGaitProblem,
    Start,
    solve_predictive,
)
from predictive.ocp.generic_gait import typical_stride_duration
from predictive.ocp.settings import default_joint_limits
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
