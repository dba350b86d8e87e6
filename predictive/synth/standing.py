"""Quiet standing with postural sway, with exact labels: recordings of subjects who stand still.

The walking and running recordings of :mod:`predictive.synth.pipeline` never stand; real
recordings often begin and end standing. This module makes standing recordings of the same
virtual subjects, labelled like the others:

1. **Posture and sway.** Both feet flat on the ground, side by side (one point in the sagittal
   plane), hips and knees at fixed standing angles (the longer leg bent so that both soles are
   on the floor, :func:`leg_angles`: the legs of a subject differ in length); the body above the ankles leans as one
   inverted pendulum by φ(t), a sum of slow sinusoids (:data:`SWAY_HZ`, random phases and
   amplitudes of about :data:`SWAY_RAD` in all, i.e. about 1 cm of travel at the hip: quiet-standing
   posturography). The pelvis tilts by φ and the ankles by −φ, so the feet keep their angle; the
   pelvis translation is what keeps the heels where they are. u and q̈ follow from φ̇ and φ̈
   (analytic) and from the heel's derivatives with respect to φ (central differences, 1e-4 rad).
2. **Ground reaction forces** are those the equations of motion require: the pelvis rows of
   :func:`sspinn.model.dynamics.inverse_dynamics` are affine in the total load (F_x, F_y, M_O)
   on the feet, which is solved for at every sample and shared equally between the feet
   (:func:`sspinn.data.measured_loads.grf_inputs` turns it into forces and contact points).
3. **Joint torques** by inverse dynamics; the labels then satisfy the equations of motion at every
   sample, as the walking and running labels do (the residual is reported in the provenance).
4. **IMU signals** from :func:`sspinn.data.sensor_noise.measure_imu` with the subject's true body
   and the IMU error model, the estimator told the nominal placement, and no soft-tissue artefact
   (movement drives it; the body rests); the speed label is 0.

Usage: ``python -m predictive synth-standing --config configs/synth/default.yaml --split test --out
data/standing``.
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np

from predictive.synth.cache import GENERATOR_NAME
from predictive.synth.recording import synthetic_recording
from predictive.synth.subjects import VirtualSubject
from sspinn.data.dataset import SAMPLE_RATE_HZ, Recording
from sspinn.data.measured_loads import grf_inputs
from sspinn.data.sensor_noise import IMUErrorModel
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import GRAVITY, N_Q, index
from sspinn.model.dynamics import inverse_dynamics
from sspinn.model.kinematics import point_index, point_kinematics
from sspinn.model.trajectory import Trajectory

#: Frequencies of the sway's sinusoids, Hz (quiet standing sways below 1 Hz).
SWAY_HZ: Final = (0.11, 0.23, 0.37, 0.61)
#: Scale of the lean φ, rad: each sinusoid's amplitude is drawn from U(0.25, 1) × this / 2.
SWAY_RAD: Final = math.radians(0.8)
#: Standing joint angles, rad (sspinn signs: hip flexion +, knee flexion −, ankle dorsiflexion +);
#: the pelvis upright and the feet flat.
STANDING_ANGLES: Final = {"hip": math.radians(2.0), "knee": math.radians(-4.0), "ankle": math.radians(2.0)}
#: Step in φ of the central differences of the heel position, rad.
_DPHI: Final = 1e-4


Angles = tuple[float, float, float]
#: The standing leg's (hip, knee, ankle) angles, rad.
_STANDING_LEG: Final = (STANDING_ANGLES["hip"], STANDING_ANGLES["knee"], STANDING_ANGLES["ankle"])


def _posture(phi: np.ndarray, legs: dict[str, Angles] | None = None) -> np.ndarray:
    """(n, 9) coordinates of the leaning body with the pelvis origin at (0, 0); ``legs``: each
    side's (hip, knee, ankle) angles at φ = 0 (default: :data:`STANDING_ANGLES` on both)."""
    q = np.zeros((phi.size, N_Q))
    q[:, index("pelvis_tilt")] = phi
    for side in ("r", "l"):
        hip, knee, ankle = (legs or {}).get(side, _STANDING_LEG)
        q[:, index(f"hip_{side}")] = hip
        q[:, index(f"knee_{side}")] = knee
        q[:, index(f"ankle_{side}")] = ankle - phi
    return q


def _points(q: np.ndarray, body: BodyParameters, *names: str) -> np.ndarray:
    """(n, len(names), 2) positions of the named points of :func:`point_kinematics` at rest, m."""
    zeros = np.zeros_like(q)
    xy = point_kinematics(q, zeros, zeros, np.full((q.shape[0], 2), 0.5), body)[..., :2]
    return xy[:, [point_index(name) for name in names]]


def leg_angles(body: BodyParameters) -> dict[str, Angles]:
    """Each leg's (hip, knee, ankle) angles, rad, that stand both soles side by side on the floor.

    The two legs of a virtual subject differ in length by up to about a centimetre (its drawn
    asymmetry); :data:`STANDING_ANGLES` on both would leave one sole that far above or in the floor
    while it carries half the weight. The shorter leg keeps them; the longer one bends so that its
    heel is where the other heel is (x and height), its foot at the other foot's angle (hip + knee
    + ankle equal), by Newton's method on the two heel coordinates (hip, knee; central
    differences). The sway turns the body about the right ankle; the ankles are within a
    millimetre of each other (the feet's heel offsets differ that little), so the left heel moves
    by micrometres."""
    standing = {"r": _STANDING_LEG, "l": _STANDING_LEG}
    gap0 = _points(_posture(np.zeros(1)), body, "heel_l", "heel_r")[0]
    bent, other = ("l", "r") if gap0[0, 1] < gap0[1, 1] else ("r", "l")  # the lower heel: the longer leg
    foot_angle = sum(_STANDING_LEG)

    def legs(x: np.ndarray) -> dict[str, Angles]:
        return {**standing, bent: (float(x[0]), float(x[1]), float(foot_angle - x[0] - x[1]))}

    def gap(x: np.ndarray) -> np.ndarray:
        heels = _points(_posture(np.zeros(1), legs(x)), body, f"heel_{bent}", f"heel_{other}")[0]
        return heels[0] - heels[1]

    x = np.array(_STANDING_LEG[:2])
    for _ in range(20):
        r = gap(x)
        if np.abs(r).max() < 1e-10:
            return legs(x)
        jac = np.column_stack([(gap(x + d) - gap(x - d)) / 2e-6 for d in np.eye(2) * 1e-6])
        x = x - np.linalg.solve(jac, r)
    raise ValueError(f"no standing posture puts both heels on the floor for this body (heel gap {gap(x).tolist()} m)")


def standing_trajectory(body: BodyParameters, duration_s: float, rng: np.random.Generator) -> Trajectory:
    """Quiet standing with sway of ``body`` for ``duration_s`` at 100 Hz, with exact labels
    (module docstring, steps 1–3)."""
    n = int(round(duration_s * SAMPLE_RATE_HZ)) + 1
    t = np.arange(n) / SAMPLE_RATE_HZ
    amplitude = rng.uniform(0.25, 1.0, len(SWAY_HZ)) * SWAY_RAD / 2
    phase = rng.uniform(0.0, 2 * math.pi, len(SWAY_HZ))
    omega = 2 * math.pi * np.asarray(SWAY_HZ)
    arg = np.outer(t, omega) + phase
    phi = np.sin(arg) @ amplitude
    dphi = np.cos(arg) @ (amplitude * omega)
    ddphi = -np.sin(arg) @ (amplitude * omega**2)

    # the right heel stays where it is: pelvis position = heel position − heel(φ) relative to the pelvis
    legs = leg_angles(body)
    h0, hp, hm = (_points(_posture(p, legs), body, "heel_r")[:, 0] for p in (phi, phi + _DPHI, phi - _DPHI))
    dh = (hp - hm) / (2 * _DPHI)
    d2h = (hp - 2 * h0 + hm) / _DPHI**2
    heel, toe = _points(_posture(np.zeros(1), legs), body, "heel_r", "toe_r")[0]
    heel_fixed = np.array([0.0, heel[1] - min(heel[1], toe[1])])  # the sole on y = 0
    q = _posture(phi, legs)
    q[:, 0:2] = heel_fixed - h0
    u = np.zeros_like(q)
    u[:, 0:2] = -dh * dphi[:, None]
    u[:, index("pelvis_tilt")] = dphi
    for side in ("r", "l"):
        u[:, index(f"ankle_{side}")] = -dphi
    qdd = np.zeros_like(q)
    qdd[:, 0:2] = -(d2h * dphi[:, None] ** 2 + dh * ddphi[:, None])
    qdd[:, index("pelvis_tilt")] = ddphi
    for side in ("r", "l"):
        qdd[:, index(f"ankle_{side}")] = -ddphi

    # the total load (F_x, F_y, M_O) on the feet that zeroes the pelvis rows (affine in the load)
    x_heel = heel_fixed[0]
    weight = body.mass * GRAVITY
    base = np.column_stack((np.zeros(n), np.full(n, weight), np.full(n, (x_heel + 0.1) * weight)))

    def pelvis_residual(load: np.ndarray) -> np.ndarray:
        grf, w = grf_inputs(q, body, {"r": load / 2, "l": load / 2})
        return np.asarray(inverse_dynamics(q, u, qdd, grf, w, body)[1])

    r0 = pelvis_residual(base)
    columns = []
    for k, step in enumerate((10.0, 10.0, 1.0)):  # N, N, N·m
        delta = np.zeros(3)
        delta[k] = step
        columns.append((pelvis_residual(base + delta) - r0) / step)
    jacobian = np.stack(columns, axis=-1)  # (n, 3 residual rows, 3 load components)
    load = base - np.linalg.solve(jacobian, r0[..., None])[..., 0]
    grf, w = grf_inputs(q, body, {"r": load / 2, "l": load / 2})
    tau, _ = inverse_dynamics(q, u, qdd, grf, w, body)
    return Trajectory(time=t, q=q, u=u, qdd=qdd, tau=np.asarray(tau), grf=grf, w=w)


def standing_recording(subject: VirtualSubject, duration_s: float, seed: int,
                       error_model: IMUErrorModel | None = None) -> Recording:
    """``<subject>_stand``: ``subject`` standing for ``duration_s`` (module docstring); the sway
    and the IMU errors drawn from ``[seed, 6, subject.index]``."""
    model = IMUErrorModel() if error_model is None else error_model
    rng = np.random.default_rng([seed, 6, subject.index])
    trajectory = standing_trajectory(subject.body, duration_s, rng)
    if not np.all((trajectory.w > 0.0) & (trajectory.w < 1.0)):
        raise ValueError(f"{subject.id}: the centre of pressure left the feet while standing (w outside 0…1)")
    return synthetic_recording(f"{subject.id}_stand", subject, trajectory, np.zeros(trajectory.q.shape[0]), model, rng, {
        "generator": GENERATOR_NAME,
        "method": "quiet standing with sway (predictive.synth.standing)",
        "program": {"name": "stand", "speeds_mps": [0.0]},
        "sway": {"frequencies_hz": list(SWAY_HZ), "scale_rad": SWAY_RAD, "seed": [seed, 6, subject.index]},
    }, rest=np.ones(trajectory.q.shape[0], dtype=bool))
