"""The body model and its backends: one sagittal 9-DOF multibody model, derived once.

:mod:`~sspinn.model.conventions` (units, signs, frames, orders), :mod:`~sspinn.model.body`
(parameters), :mod:`~sspinn.model.contact` and :mod:`~sspinn.model.passive` (forces),
:mod:`~sspinn.model.derivation` (SymPy's Kane's method) → :mod:`~sspinn.model.codegen` →
``_generated`` (NumPy/torch/CasADi expressions and numba kernels), :mod:`~sspinn.model.backends`
(array namespaces), :mod:`~sspinn.model.dynamics` and :mod:`~sspinn.model.kinematics` (the public
model API), :mod:`~sspinn.model.integrators` and :mod:`~sspinn.model.simulation` (stepping),
:mod:`~sspinn.model.trajectory` (the one motion type and its Kane residual),
:mod:`~sspinn.model.drawing` (stick figures) and :mod:`~sspinn.model.showcase` (a drop landing).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    **{name: f"{__name__}.{name}" for name in ("conventions", "dynamics", "kinematics", "simulation",)},
    **dict.fromkeys(("BodyParameters", "IMUPlacement", "JointLimits", "ParameterError",), "sspinn.model.body"),
    **dict.fromkeys(("ContactParameters",), "sspinn.model.contact"),
    **dict.fromkeys(("Trajectory", "TrajectoryError",), "sspinn.model.trajectory"),
    **dict.fromkeys(("StateError", "forward_dynamics", "inverse_dynamics", "kane_residual", "mass_matrix",), "sspinn.model.dynamics"),
    **dict.fromkeys(("point_kinematics", "virtual_imu",), "sspinn.model.kinematics"),
    **dict.fromkeys(("simulate",), "sspinn.model.simulation"),
    **dict.fromkeys(("COORDINATES", "SEGMENTS", "GRAVITY",), "sspinn.model.conventions"),
}
__all__ = [
    "BodyParameters",
    "COORDINATES",
    "ContactParameters",
    "GRAVITY",
    "IMUPlacement",
    "JointLimits",
    "ParameterError",
    "SEGMENTS",
    "StateError",
    "Trajectory",
    "TrajectoryError",
    "conventions",
    "dynamics",
    "forward_dynamics",
    "inverse_dynamics",
    "kane_residual",
    "kinematics",
    "mass_matrix",
    "point_kinematics",
    "simulate",
    "simulation",
    "virtual_imu",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from sspinn.model import conventions, dynamics, kinematics, simulation
    from sspinn.model.body import BodyParameters, IMUPlacement, JointLimits, ParameterError
    from sspinn.model.contact import ContactParameters
    from sspinn.model.conventions import COORDINATES, GRAVITY, SEGMENTS
    from sspinn.model.dynamics import StateError, forward_dynamics, inverse_dynamics, kane_residual, mass_matrix
    from sspinn.model.kinematics import point_kinematics, virtual_imu
    from sspinn.model.simulation import simulate
    from sspinn.model.trajectory import Trajectory, TrajectoryError

__getattr__, __dir__ = attach(__name__, _EXPORTS)
