"""Trajectory optimisation (CasADi + IPOPT) on the sspinn model: problems, solutions, checks.

* :mod:`~predictive.ocp.settings` — settings, bounds, scales and effort terms shared by the NLPs;
* :mod:`~predictive.ocp.generic_gait` — typical stride duration and the data-free textbook gait;
* :mod:`~predictive.ocp.collocation` — the periodic predictive gait OCP (:func:`solve_predictive`);
* :mod:`~predictive.ocp.tracking` — the same OCP with tracking terms; :mod:`~predictive.ocp.tracking_data`
  turns recordings into tracked signals; :mod:`~predictive.ocp.imu_tracking` is the label-free
  IMU-tracking baseline;
* :mod:`~predictive.ocp.stride_nlp` — the single-stride NLP of the synthetic-data stride chain;
* :mod:`~predictive.ocp.solution` — :class:`GaitSolution`, its persistence and physical checks;
* :mod:`~predictive.ocp.limits` — what the model can be asked and what a solution must satisfy;
* :mod:`~predictive.ocp.perturbation` — floating-point-path perturbations for robustness checks;
* :mod:`~predictive.ocp.gait_analysis` — Winter comparison, normalised cycles, plots;
* :mod:`~predictive.ocp.cli` — ``python -m predictive solve``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("DEFAULT_STARTS", "OCPError", "OCPSettings", "PredictiveGaitProblem", "Start", "solve_predictive",), "predictive.ocp.collocation"),
    **dict.fromkeys(("generic_gait", "typical_stride_duration",), "predictive.ocp.generic_gait"),
    **dict.fromkeys(("default_joint_limits",), "predictive.ocp.settings"),
    **dict.fromkeys(("GaitSolution",), "predictive.ocp.solution"),
    **dict.fromkeys(("TrackingSettings", "solve_tracking",), "predictive.ocp.tracking"),
    **dict.fromkeys(("solve_imu_tracking",), "predictive.ocp.imu_tracking"),
    **dict.fromkeys(("RequestError",), "predictive.ocp.limits"),
}
__all__ = [
    "DEFAULT_STARTS",
    "GaitSolution",
    "OCPError",
    "OCPSettings",
    "PredictiveGaitProblem",
    "RequestError",
    "Start",
    "TrackingSettings",
    "default_joint_limits",
    "generic_gait",
    "solve_imu_tracking",
    "solve_predictive",
    "solve_tracking",
    "typical_stride_duration",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from predictive.ocp import generic_gait
    from predictive.ocp.collocation import (
        DEFAULT_STARTS,
        OCPError,
        OCPSettings,
        PredictiveGaitProblem,
        Start,
        solve_predictive,
    )
    from predictive.ocp.generic_gait import typical_stride_duration
    from predictive.ocp.imu_tracking import solve_imu_tracking
    from predictive.ocp.limits import RequestError
    from predictive.ocp.settings import default_joint_limits
    from predictive.ocp.solution import GaitSolution
    from predictive.ocp.tracking import TrackingSettings, solve_tracking

__getattr__, __dir__ = attach(__name__, _EXPORTS)
