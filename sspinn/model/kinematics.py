"""Global kinematics of the sagittal model and virtual IMUs, for NumPy, torch and CasADi inputs.

Generated from the same derivation as the dynamics (:mod:`sspinn.model.derivation`). Shapes and the
meaning of the inputs as in :mod:`sspinn.model.dynamics`; ``imu`` is the 21-vector of
:class:`~sspinn.model.body.IMUPlacement` ([x, y, angle] per segment in SEGMENTS order).
"""

from __future__ import annotations

from typing import Any

from sspinn.model._generated import model_expr as gen
from sspinn.model.body import N_IMU_PARAMETERS, IMUPlacement
from sspinn.model.conventions import N_Q, POINTS, SEGMENTS, index
from sspinn.model.dynamics import Array, as_vector, check_input, prepare_inputs

#: Columns of :func:`point_kinematics` and :func:`segment_kinematics`.
POINT_COLUMNS = ("x", "y", "vx", "vy", "ax", "ay")
SEGMENT_COLUMNS = ("angle", "rate", "acceleration")


def point_kinematics(q: Array, u: Array, qdd: Array, w: Array, p: Any) -> Array:
    """(..., 11, 6): [x, y, vx, vy, ax, ay] (m, m/s, m/s²) of each point in
    :data:`~sspinn.model.conventions.POINTS` (hip, knee, ankle, heel, toe, contact point per side).
    The contact point is the foot-fixed point at fraction ``w`` (toe 0 … heel 1)."""
    ops, q, p, v = prepare_inputs(q, p, u=(u, N_Q), qdd=(qdd, N_Q), w=(w, 2))
    return gen.point_kinematics(ops, q, v["u"], v["qdd"], v["w"], p)


def point_index(name: str) -> int:
    """Row of a named point in :func:`point_kinematics`."""
    return index(name, POINTS)


def segment_kinematics(q: Array, u: Array, qdd: Array) -> Array:
    """(..., 7, 3): global [angle, angular rate, angular acceleration] (rad, rad/s, rad/s²)
    of each segment in :data:`~sspinn.model.conventions.SEGMENTS` order."""
    ops, q, _, v = prepare_inputs(q, None, u=(u, N_Q), qdd=(qdd, N_Q))
    return gen.segment_kinematics(ops, q, v["u"], v["qdd"])


def virtual_imu(q: Array, u: Array, qdd: Array, imu: Any, p: Any) -> Array:
    """(..., 7, 3): [acc_x, acc_y, gyr_z] of a sensor on each segment, in its own frame.

    acc is the specific force a − g (m/s², reads +g on acc_y when upright at rest), gyr_z the
    segment's angular rate (rad/s). ``imu`` is an :class:`IMUPlacement` or its 21-vector.
    """
    return _imu_function(gen.virtual_imu, q, u, qdd, imu, p)


def imu_kinematics(q: Array, u: Array, qdd: Array, imu: Any, p: Any) -> Array:
    """(..., 7, 6): global [x, y, vx, vy, ax, ay] of each sensor's origin (SEGMENTS order).
    The sensor frame's global angle is the segment angle (:func:`segment_kinematics`) + φ."""
    return _imu_function(gen.imu_kinematics, q, u, qdd, imu, p)


def _imu_function(fn: Any, q: Array, u: Array, qdd: Array, imu: Any, p: Any) -> Array:
    if isinstance(imu, IMUPlacement):
        imu = imu.vector()
    ops, q, p, v = prepare_inputs(q, p, u=(u, N_Q), qdd=(qdd, N_Q))
    imu = check_input("imu placement", as_vector(imu, q), N_IMU_PARAMETERS)
    return fn(ops, q, v["u"], v["qdd"], imu, p)


__all__ = [
    "imu_kinematics",
    "POINTS",
    "SEGMENTS",
    "POINT_COLUMNS",
    "SEGMENT_COLUMNS",
    "point_kinematics",
    "point_index",
    "segment_kinematics",
    "virtual_imu",
]
