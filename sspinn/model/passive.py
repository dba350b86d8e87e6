"""Passive joint moments of the sagittal model: soft joint limits and viscous joint damping.

The rigid-body model of :mod:`sspinn.model.derivation` has no joint limits: a few N·m/kg applied to a
1 kg foot spins it at hundreds of rad/s within a fraction of a second. As in the gait2d model
family (van den Bogert's sagittal models, on whose parameters :mod:`sspinn.model.body` is built), a
passive moment is therefore added to the actuator torque of every joint (hip, knee, ankle of
each leg)::

    τ_passive(θ, θ̇) = k·(max(lower − θ, 0)² − max(θ − upper, 0)²) − b·θ̇

in N·m, with θ the joint angle (rad, signs of :mod:`sspinn.model.conventions`: hip flexion +, knee
flexion −, ankle dorsiflexion +), θ̇ its rate (rad/s), [lower, upper] the joint range (rad), k the
stiffness of the quadratic soft limits (N·m/rad²) and b the viscous damping (N·m·s/rad). Inside the range only the damping acts; the
moment and its first derivative are continuous at the range ends.

Parameter vector (:func:`passive_parameters`), shape (14,)::

    [lower (6, rad), upper (6, rad), stiffness k (N·m/rad²), damping b (N·m·s/rad)]

in joint order :data:`sspinn.model.conventions.JOINTS`. All zeros is exactly the bare model (no passive
moment). Used by the numba stepper (:func:`sspinn.model.simulation.advance`, compiled from
:func:`passive_torque`) and by the environments in ``envs/`` (single and batched).

Defaults (introduced with the Gymnasium environment, ``envs/sagittal_walker.py``):

* joint ranges :data:`DEFAULT_JOINT_RANGE` (rad): hip [−0.6, 2.0], knee [−2.4, 0.05],
  ankle [−0.9, 0.6] (knee flexion negative), chosen for the environment; no literature table of
  joint ranges was checked for these numbers.
* stiffness :data:`DEFAULT_LIMIT_STIFFNESS` = 10⁴ N·m/rad²: the default actuator strength of the
  environment (3 N·m/kg, i.e. 210 N·m at 70 kg) is balanced 0.145 rad beyond a limit
  (√(210/10⁴) rad).
* damping :data:`DEFAULT_JOINT_DAMPING` = 1 N·m·s/rad: chosen for the environment, not fitted to
  data; small against the actuators (10 N·m at 10 rad/s).
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from typing import Any, Final

import numpy as np

from sspinn.model.conventions import JOINTS, N_TAU

#: Length of the passive parameter vector: lower (6), upper (6), stiffness, damping.
N_PASSIVE: Final[int] = 2 * N_TAU + 2

#: Default joint ranges (rad) of the soft limits, (lower, upper) per joint type; knee flexion is
#: negative. See the module docstring for the justification.
DEFAULT_JOINT_RANGE: Final[dict[str, tuple[float, float]]] = {
    "hip": (-0.6, 2.0),
    "knee": (-2.4, 0.05),
    "ankle": (-0.9, 0.6),
}
#: Default stiffness of the quadratic soft joint limits, N·m/rad² (210 N·m — 3 N·m/kg at 70 kg —
#: is balanced 0.145 rad beyond a limit).
DEFAULT_LIMIT_STIFFNESS: Final[float] = 10000.0
#: Default viscous joint damping, N·m·s/rad.
DEFAULT_JOINT_DAMPING: Final[float] = 1.0


def passive_torque(angle: Any, rate: Any, lower: Any, upper: Any, stiffness: Any, damping: Any) -> Any:
    """Passive joint moment (N·m): quadratic soft limits outside [lower, upper] (rad) plus viscous
    damping, ``k·(max(lower − θ, 0)² − max(θ − upper, 0)²) − b·θ̇`` with k in N·m/rad² and b in
    N·m·s/rad (see the module docstring).

    Written with arithmetic operators and the built-in ``abs`` only, so the same function runs on
    Python/numba scalars (compiled into :func:`sspinn.model.simulation.advance`), NumPy arrays and torch
    tensors (broadcasting as usual).
    """
    over = 0.5 * ((angle - upper) + abs(angle - upper))
    under = 0.5 * ((lower - angle) + abs(lower - angle))
    return stiffness * (under * under - over * over) - damping * rate


def is_real(value: Any) -> bool:
    """True for a real number (int, float, NumPy scalar), False for bools and everything else."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def passive_parameters(
    joint_range: Mapping[str, Sequence[float]] | None = None,
    stiffness: float = DEFAULT_LIMIT_STIFFNESS,
    damping: float = DEFAULT_JOINT_DAMPING,
) -> np.ndarray:
    """The (14,) vector [lower (6, rad), upper (6, rad), stiffness (N·m/rad²), damping (N·m·s/rad)]
    of :func:`passive_torque`, in joint order; ``joint_range`` maps joint types ("hip", "knee",
    "ankle") to (lower, upper) in rad, missing types take :data:`DEFAULT_JOINT_RANGE`. Each range
    must contain the standing pose (0 rad). ``stiffness=0, damping=0`` gives no passive moment.

    Raises:
        ValueError: naming the argument and the expected units.
    """
    ranges = dict(DEFAULT_JOINT_RANGE)
    if joint_range is not None:
        if not isinstance(joint_range, Mapping):
            raise ValueError(f"joint_range must be a mapping {{'hip': (lo, hi), ...}} in rad or None, got {joint_range!r}")
        unknown = set(joint_range) - set(ranges)
        if unknown:
            raise ValueError(f"joint_range: unknown joint type(s) {sorted(unknown)}; use {sorted(ranges)}")
        for key, value in joint_range.items():
            if not (isinstance(value, Sequence) and len(value) == 2 and all(is_real(v) for v in value)):
                raise ValueError(f"joint_range[{key!r}] must be a (low, high) pair of numbers in rad, got {value!r}")
            if not value[0] < 0.0 < value[1]:
                raise ValueError(f"joint_range[{key!r}] must contain the standing pose 0 rad, got {tuple(value)}")
            ranges[key] = (float(value[0]), float(value[1]))
    for name, value in (("joint_limit_stiffness", stiffness), ("joint_damping", damping)):
        if not is_real(value) or not 0 <= value < 1e6:
            raise ValueError(f"{name} must be a number >= 0 (N·m/rad² or N·m·s/rad), got {value!r}")
    lower = [ranges[j.split("_")[0]][0] for j in JOINTS]
    upper = [ranges[j.split("_")[0]][1] for j in JOINTS]
    return np.asarray([*lower, *upper, float(stiffness), float(damping)], dtype=np.float64)


__all__ = [
    "DEFAULT_JOINT_DAMPING",
    "DEFAULT_JOINT_RANGE",
    "DEFAULT_LIMIT_STIFFNESS",
    "N_PASSIVE",
    "is_real",
    "passive_parameters",
    "passive_torque",
]
