"""Quiet standing with postural sway, with exact labels: recordings of subjects who stand still.

The walking and running recordings of :mod:`predictive.synth.pipeline` never stand; real
recordings often begin and end standing. This module makes standing recordings of the same
virtual subjects, labelled like the others:

1. **Posture and sway.** Both feet flat on the ground, side by side (one point in the sagittal
   plane), hips and knees at fixed standing angles; the body above the ankles leans as one
   inverted pendulum by φ(t), a sum of slow sinusoids (:data:`SWAY_HZ`, random phases and
   amplitudes of about :data:`SWAY_RAD` in all, i.e. about 1 cm of travel at the hip: quiet-standing
   posturography). The pelvis tilts by φ and the ankles by −φ, so the feet keep their angle; the
   pelvis translation is what keeps the heels where they are. u and q̈ follow from φ̇ and φ̈
   (analytic) and from the heel's derivatives with respect to φ (central differences, 1e-4 rad).
2. **Ground reaction forces** are those the equations of motion require: the pelvis rows of
   :func:`sspinn.model.dynamics.inverse_dynamics` are affine in the total load (F_x, F_y, M_O)
   on the feet, which is solved for at every sample and shared equally between the feet
   (:func:`sspinn.validation.inverse_dynamics.grf_inputs` turns it into forces and contact points).
3. **Joint torques** by inverse dynamics; the labels then satisfy the equations of motion at every
   sample, as the walking and running labels do (the residual is reported in the provenance).
4. **IMU signals** from :func:`sspinn.data.sensor_noise.measure_imu` with the subject's true body
   and the IMU error model, the estimator told the nominal placement; the speed label is 0.

Usage: ``python scripts/make_standing.py --config configs/synth/default.yaml --split test --out
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
from sspinn.data.sensor_noise import IMUErrorModel
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import GRAVITY, N_Q, index
from sspinn.model.dynamics import inverse_dynamics
from sspinn.model.kinematics import point_index, point_kinematics
from sspinn.model.trajectory import Trajectory
from sspinn.validation.inverse_dynamics import grf_inputs

#: Frequencies of the sway's sinusoids, Hz (quiet standing sways below 1 Hz).
SWAY_HZ: Final = (0.11, 0.23, 0.37, 0.61)
#: Scale of the lean φ, rad: each sinusoid's amplitude is drawn from U(0.25, 1) × this / 2.
SWAY_RAD: Final = math.radians(0.8)
#: Standing joint angles, rad (sspinn signs: hip flexion +, knee flexion −, ankle dorsiflexion +);
#: the pelvis upright and the feet flat.
STANDING_ANGLES: Final = {"hip": math.radians(2.0), "knee": math.radians(-4.0), "ankle": math.radians(2.0)}
#: Step in φ of the central differences of the heel position, rad.
_DPHI: Final = 1e-4


def _posture(phi: np.ndarray) -> np.ndarray:
    """(n, 9) coordinates of the leaning body with the pelvis origin at (0, 0)."""
    q = np.zeros((phi.size, N_Q))
    q[:, index("pelvis_tilt")] = phi
    for side in ("r", "l"):
        q[:, index(f"hip_{side}")] = STANDING_ANGLES["hip"]
        q[:, index(f"knee_{side}")] = STANDING_ANGLES["knee"]
        q[:, index(f"ankle_{side}")] = STANDING_ANGLES["ankle"] - phi
    return q


def _heel(phi: np.ndarray, body: BodyParameters) -> np.ndarray:
    """(n, 2) position of the right heel (the left one is the same point) with the pelvis origin at (0, 0), m."""
    q = _posture(phi)
    zeros = np.zeros_like(q)
    return point_kinematics(q, zeros, zeros, np.full((phi.size, 2), 0.5), body)[:, point_index("heel_r"), :2]


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

    # the heel stays where it is: pelvis position = heel position − heel(φ) relative to the pelvis
    h0, hp, hm = _heel(phi, body), _heel(phi + _DPHI, body), _heel(phi - _DPHI, body)
    dh = (hp - hm) / (2 * _DPHI)
    d2h = (hp - 2 * h0 + hm) / _DPHI**2
    zeros = np.zeros((n, N_Q))
    flat = point_kinematics(_posture(np.zeros(1)), zeros[:1], zeros[:1], np.full((1, 2), 0.5), body)
    sole = min(flat[0, point_index("heel_r"), 1], flat[0, point_index("toe_r"), 1])
    heel_fixed = np.array([0.0, flat[0, point_index("heel_r"), 1] - sole])  # the sole on y = 0
    q = _posture(phi)
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
    })
