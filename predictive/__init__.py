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

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("DEFAULT_STARTS", "OCPError", "OCPSettings", "PredictiveGaitProblem", "Start", "solve_predictive",), "predictive.ocp.collocation"),
    **dict.fromkeys(("typical_stride_duration",), "predictive.ocp.generic_gait"),
    **dict.fromkeys(("default_joint_limits",), "predictive.ocp.settings"),
    **dict.fromkeys(("GaitSolution",), "predictive.ocp.solution"),
    **dict.fromkeys(("SynthConfig",), "predictive.synth.config"),
    **dict.fromkeys(("generate_dataset",), "predictive.synth.pipeline"),
    **dict.fromkeys(("GaitGenerator", "GeneratorConfig",), "predictive.generator.gait_generator"),
}
__all__ = [
    "DEFAULT_STARTS",
    "GaitGenerator",
    "GaitSolution",
    "GeneratorConfig",
    "OCPError",
    "OCPSettings",
    "PredictiveGaitProblem",
    "Start",
    "SynthConfig",
    "default_joint_limits",
    "generate_dataset",
    "solve_predictive",
    "typical_stride_duration",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from predictive.generator.gait_generator import GaitGenerator, GeneratorConfig
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
    from predictive.synth.config import SynthConfig
    from predictive.synth.pipeline import generate_dataset

__getattr__, __dir__ = attach(__name__, _EXPORTS)
