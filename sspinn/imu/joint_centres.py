"""Segment axes in a sensor's sagittal plane from walking alone: joint centres and foot-flat.

Without quiet standing there is no moment at which every segment's orientation is known, but the
joints still tie the segments together. A joint centre is one point of two segments, so its
specific force seen from either sensor has the same magnitude at every sample (the two sensor
frames differ by a rotation only):

    | f_A + K_A r_A | = | f_B + K_B r_B |,   K = [[−ω², −ω̇], [ω̇, −ω²]],

with f the sensor's in-plane specific force (m/s²), ω and ω̇ its sagittal angular rate and
acceleration (rad/s, rad/s²) — the rigid-body terms of a point at r from the sensor — and r_A,
r_B the joint's position in each sensor's plane (m). Least squares over the walking samples gives
both (:func:`joint_centre`; the joint-position part of Seel, Raisch & Schauer 2014, *Sensors*
14:6891, in the plane). The shank's long axis is the line from the ankle to the knee in the shank
sensor's plane and the thigh's the line from the knee to the hip (the model's segment y axes:
:mod:`sspinn.model.body`, each joint on its segment's axis). The foot has no joint line: its y
axis is vertical while the foot is flat on the ground, which it is while its sensor rests in
mid-stance — the mean specific force over the foot's zero-velocity samples
(:func:`foot_flat_up`) plays the part that quiet standing plays for every segment.

Written here because no maintained library fits planar joint centres to two IMUs; the fit is
:func:`scipy.optimize.least_squares`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import butter, sosfiltfilt

from sspinn.data.gait_events import runs_at_least
from sspinn.model.conventions import GRAVITY

#: Low-pass cut-off (Hz) of the rates and specific forces before ω̇ is differentiated from ω:
#: walking's segment motion lies below it, differentiated sensor noise above it.
CUTOFF_HZ: Final = 8.0
#: A fitted joint centre is accepted when the joint-to-joint distance it implies lies in this
#: range (m; thigh and shank lengths of adults are 0.3–0.55 m) ...
SEGMENT_LENGTH_RANGE_M: Final = (0.2, 0.7)
#: ... and the fit's RMS residual is below this share of the mean joint specific force.
MAX_RELATIVE_RESIDUAL: Final = 0.25
#: Fewest mid-stance rest samples of a foot for its flat-foot direction ...
MIN_FOOT_FLAT_SAMPLES: Final = 50
#: ... and the shortest rest, s (mid-stance foot-flat lasts 0.2–0.4 s in walking).
FOOT_FLAT_MIN_S: Final = 0.1
#: |specific force| tolerance of a rest sample around the rests' median, m/s², and the angular
#: rate below which a foot rests, rad/s: the foot ZUPT detector's
#: (:class:`sspinn.estimator.zupt.SagittalZuptKalman`; 34°/s is gaitmap's).
ZUPT_ACC_THRESHOLD: Final = 1.0
ZUPT_GYRO_THRESHOLD: Final = math.radians(34.0)


@dataclass(frozen=True)
class JointFit:
    """A joint centre fitted to two sensors (:func:`joint_centre`).

    Attributes:
        r_a, r_b: (2,) the joint's position in sensor A's and sensor B's plane, m.
        rms: RMS of | f_A + K_A r_A | − | f_B + K_B r_B | over the samples used, m/s².
        relative_rms: ``rms`` over the mean | f_A + K_A r_A |.
    """

    r_a: np.ndarray
    r_b: np.ndarray
    rms: float
    relative_rms: float


def plane_signals(acc: np.ndarray, gyr: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray,
                  rate_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """In-plane specific force f (T, 2) on the axes ``x``, ``y`` and the rate ω and angular
    acceleration ω̇ (T,) about ``z`` of a 3D sensor's acc (T, 3, m/s²) and bias-free gyr (T, 3,
    rad/s), low-passed at :data:`CUTOFF_HZ`."""
    sos = butter(2, CUTOFF_HZ, fs=rate_hz, output="sos")
    f = sosfiltfilt(sos, np.column_stack((acc @ x, acc @ y)), axis=0)
    omega = sosfiltfilt(sos, gyr @ z)
    return f, omega, np.gradient(omega) * rate_hz


def _point(f: np.ndarray, omega: np.ndarray, domega: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Specific force (T, 2) at the point r (2,) of the sensor's rigid body."""
    w2 = omega**2
    return np.column_stack((f[:, 0] - w2 * r[0] - domega * r[1], f[:, 1] + domega * r[0] - w2 * r[1]))


def joint_centre(a: tuple[np.ndarray, np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray, np.ndarray],
                 r_a0: np.ndarray, r_b0: np.ndarray, step: int = 2) -> JointFit:
    """The joint centre of two sensors' segments (module docstring) from their
    :func:`plane_signals` ``a`` and ``b`` over the same samples (every ``step``-th used), starting
    from the guesses ``r_a0``, ``r_b0`` (2,) m."""
    fa, wa, dwa = (v[::step] for v in a)
    fb, wb, dwb = (v[::step] for v in b)

    def residual(x: np.ndarray) -> np.ndarray:
        return np.linalg.norm(_point(fa, wa, dwa, x[:2]), axis=1) - np.linalg.norm(_point(fb, wb, dwb, x[2:]), axis=1)

    sol = least_squares(residual, np.concatenate((r_a0, r_b0)), x_scale=0.1)
    rms = float(np.sqrt(np.mean(sol.fun**2)))
    scale = float(np.mean(np.linalg.norm(_point(fa, wa, dwa, sol.x[:2]), axis=1)))
    return JointFit(sol.x[:2].copy(), sol.x[2:].copy(), rms, rms / scale)


def segment_axis(proximal: JointFit | None, distal: JointFit | None, proximal_side: str, distal_side: str) -> np.ndarray | None:
    """Unit (2,) direction from the distal to the proximal joint in the plane of the sensor
    between them (``*_side``: which sensor of each fit it is, ``"a"`` or ``"b"``), or None when a
    fit is missing or implausible (:data:`SEGMENT_LENGTH_RANGE_M`, :data:`MAX_RELATIVE_RESIDUAL`)."""
    if proximal is None or distal is None:
        return None
    if max(proximal.relative_rms, distal.relative_rms) > MAX_RELATIVE_RESIDUAL:
        return None
    top = proximal.r_a if proximal_side == "a" else proximal.r_b
    bottom = distal.r_a if distal_side == "a" else distal.r_b
    d = top - bottom
    length = float(np.linalg.norm(d))
    low, high = SEGMENT_LENGTH_RANGE_M
    return d / length if low <= length <= high else None


def sensor_placement(r_proximal: np.ndarray, r_distal: np.ndarray) -> tuple[np.ndarray, float]:
    """A sensor's position (x, y; m) and angle θ (rad) in its segment's frame from the segment's
    proximal and distal joint centres seen from the sensor (each (2,) m, e.g. a :class:`JointFit`'s
    ``r_a`` or ``r_b``). In a segment frame the proximal joint is the origin and the distal joint
    lies on the −y axis (:mod:`sspinn.model.body`), so θ is the rotation that takes the
    distal→proximal direction to +y and the position is −R(θ)·r_proximal (the
    :class:`~sspinn.model.body.IMUPlacement` convention: segment point = position + R(θ)·sensor point)."""
    up = np.asarray(r_proximal, dtype=float) - np.asarray(r_distal, dtype=float)
    theta = float(np.arctan2(up[0], up[1]))
    c, s = math.cos(theta), math.sin(theta)
    return -np.array([[c, -s], [s, c]]) @ np.asarray(r_proximal, dtype=float), theta


def foot_flat_up(f: np.ndarray, omega: np.ndarray, rate_hz: float, mask: np.ndarray) -> np.ndarray | None:
    """Unit (2,) direction of gravity (the foot's y axis) in a foot sensor's plane: the mean
    specific force over its mid-stance rests within ``mask`` — runs of at least
    :data:`FOOT_FLAT_MIN_S` below :data:`ZUPT_GYRO_THRESHOLD` (a swing's turning point is shorter), whose |specific force| is within its acceleration
    threshold of their median (the sensor's own gravity reading: an accelerometer gain error
    does not hide its rests); None with fewer than :data:`MIN_FOOT_FLAT_SAMPLES`."""
    rests = runs_at_least(np.abs(omega) < ZUPT_GYRO_THRESHOLD, max(1, round(FOOT_FLAT_MIN_S * rate_hz))) & mask
    if rests.sum() < MIN_FOOT_FLAT_SAMPLES:
        return None
    norm = np.linalg.norm(f, axis=1)
    rests &= np.abs(norm - np.median(norm[rests])) < ZUPT_ACC_THRESHOLD
    if rests.sum() < MIN_FOOT_FLAT_SAMPLES:
        return None
    mean = f[rests].mean(axis=0)
    length = float(np.linalg.norm(mean))
    return mean / length if length > 0.5 * GRAVITY else None


__all__ = ["CUTOFF_HZ", "FOOT_FLAT_MIN_S", "JointFit", "MAX_RELATIVE_RESIDUAL", "MIN_FOOT_FLAT_SAMPLES", "SEGMENT_LENGTH_RANGE_M",
           "ZUPT_ACC_THRESHOLD", "ZUPT_GYRO_THRESHOLD", "foot_flat_up", "joint_centre", "plane_signals", "segment_axis"]
