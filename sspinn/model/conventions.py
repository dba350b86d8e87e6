"""Physics conventions of sspinn: the single code source of units, signs, frames and orderings.

Every other module refers to the names defined here; the prose version is ``docs/conventions.md``.

Frames and units
----------------
* SI units throughout: m, s, kg, N, N·m, rad. Forces may additionally be reported in body
  weights (BW = m·g) and torques in %BW·BH (body weight times body height), as the literature does.
* Global frame N: x forward (walking direction), y up, z = x × y pointing to the subject's right.
  The ground is the line y = 0.
* Every angle is a rotation about z, positive counter-clockwise when seen from the subject's right
  side (the OpenSim / BioMAC convention of ``$SSPINN_SHARED_DATA/README.md``). Hence hip flexion is
  positive, **knee flexion is negative**, ankle dorsiflexion is positive and a positive pelvis tilt
  lifts the front of the pelvis (the trunk leans back).
* Segment frames: origin at the proximal joint (the hip for the HAT segment), y axis along the
  segment pointing proximally (up when standing), x axis anterior. With all coordinates zero the
  body stands upright with the feet flat (foot x axis along the sole, pointing forward).
* Generalized coordinates ``q`` (order below): the hip joint centre's global position
  (pelvis_tx, pelvis_ty, m), the HAT segment's global angle (pelvis_tilt) and six relative joint
  angles. Generalized speeds are ``u = dq/dt``; ``qdd = d²q/dt²``.
* Joint torque τ_j acts on the distal segment (+τ_j about z) and on the proximal segment (−τ_j),
  so τ_j is the generalized force of coordinate j: a positive hip torque flexes the hip.
* Ground reaction forces per foot: (F_x, F_y) in N in the global frame, applied at the foot's
  contact point, which lies on the heel–toe line at fraction ``w`` from the toe (``w = 1`` is the
  heel); see :mod:`sspinn.model.contact`.
* IMU signals (sensor frame s, rotated from its segment frame by the placement angle φ):
  ``acc_x`` (anterior) and ``acc_y`` (along the segment, proximal) are the specific force
  a − g expressed in s (so a sensor at rest reads acc_y = +9.81 m/s² when upright), and ``gyr_z``
  is the segment's angular rate about z (rad/s, same sign on both sides).
"""

from __future__ import annotations

from typing import Final

#: Generalized coordinates, in the order used by every backend.
COORDINATES: Final[tuple[str, ...]] = (
    "pelvis_tx",
    "pelvis_ty",
    "pelvis_tilt",
    "hip_r",
    "knee_r",
    "ankle_r",
    "hip_l",
    "knee_l",
    "ankle_l",
)
N_Q: Final[int] = len(COORDINATES)

#: Actuated joints (the last six coordinates), in torque-vector order.
JOINTS: Final[tuple[str, ...]] = COORDINATES[3:]
N_TAU: Final[int] = len(JOINTS)

SIDES: Final[tuple[str, ...]] = ("r", "l")

#: Rigid segments, in the order used for segment angles and IMUs.
SEGMENTS: Final[tuple[str, ...]] = ("pelvis", "femur_r", "tibia_r", "foot_r", "femur_l", "tibia_l", "foot_l")
N_SEGMENTS: Final[int] = len(SEGMENTS)

#: Ground reaction force vector order: (Fx_r, Fy_r, Fx_l, Fy_l), N, global frame.
GRF: Final[tuple[str, ...]] = ("grf_x_r", "grf_y_r", "grf_x_l", "grf_y_l")
N_GRF: Final[int] = len(GRF)


def other_side(name: str) -> str:
    """The name of the same quantity on the other leg (``_r`` ↔ ``_l``); names without a side unchanged."""
    side = name[-2:]
    return name[:-2] + {"_r": "_l", "_l": "_r"}[side] if side in ("_r", "_l") else name


def mirror_index(names: tuple[str, ...]) -> tuple[int, ...]:
    """The permutation that swaps the right and left leg in a vector ordered by ``names``."""
    index = {name: i for i, name in enumerate(names)}
    return tuple(index[other_side(name)] for name in names)


#: Left/right swaps of q (and u, q̈), of τ and of the GRF vector.
MIRROR_Q: Final[tuple[int, ...]] = mirror_index(COORDINATES)
MIRROR_TAU: Final[tuple[int, ...]] = mirror_index(JOINTS)
MIRROR_GRF: Final[tuple[int, ...]] = mirror_index(GRF)

#: Named points with generated kinematics (global x, y and their derivatives).
POINTS: Final[tuple[str, ...]] = (
    "hip",
    "knee_r",
    "ankle_r",
    "heel_r",
    "toe_r",
    "contact_r",
    "knee_l",
    "ankle_l",
    "heel_l",
    "toe_l",
    "contact_l",
)

#: IMU channels per sensor, in order.
IMU_CHANNELS: Final[tuple[str, ...]] = ("acc_x", "acc_y", "gyr_z")

#: Standard gravity, m/s².
GRAVITY: Final[float] = 9.81


def imu_columns(segments: tuple[str, ...] = SEGMENTS) -> list[str]:
    """Column names ``<segment>_<channel>`` of the IMU signals, as in ``$SSPINN_SHARED_DATA``."""
    return [f"{seg}_{ch}" for seg in segments for ch in IMU_CHANNELS]


def index(name: str, names: tuple[str, ...] = COORDINATES) -> int:
    """Position of ``name`` in an ordering, with a clear error for unknown names."""
    try:
        return names.index(name)
    except ValueError:
        raise KeyError(f"unknown name {name!r}; expected one of {', '.join(names)}") from None
