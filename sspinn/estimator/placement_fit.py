"""Where each sensor sits on its segment, fitted to an estimate's kinematics.

A sensor at position r = (x, y) (m) and angle θ (rad) in its segment's frame reads the specific
force of that point of the segment, turned into the sensor frame:

    f(t) = R(θ)ᵀ · ( a₀(t) + A_x(t)·x + A_y(t)·y ) + b,

with a₀ the specific force of the segment frame's origin and A_x, A_y the rigid-body terms of the
segment's angular rate and acceleration (−ω², ω̇; the virtual IMU of
:func:`sspinn.model.kinematics.virtual_imu` is affine in the position), and b a constant
accelerometer bias (m/s²). Given the coordinates q, u, q̈ of a gait — an SSPINNpose estimate, no
labels needed — the five numbers (x, y, θ, b_x, b_y) of each sensor are a small nonlinear least
squares problem over the recording's accelerometer samples (:func:`fit_placement`, solved by
:func:`scipy.optimize.least_squares` from the recording's nominal placement).

This is not the paper's placement optimisation (the placement as parameters of the network's
training, ``learn_placement``): the network stays as trained, and the placement is fitted
afterwards to the kinematics it estimates. A trained network's kinematics already explain the
signals, so the residual that is left is what the nominal placement cannot explain; on the
synthetic benchmark this recovers the running thighs to about a third of the nominal error, the
walking thighs to about two thirds (docs/paper_claims.md, ``placement``). The estimate's
kinematics errors are what limit it: fitted to the true kinematics the same problem lands within
about 0.3–0.7 cm (thighs and shanks).
On real recordings the fit needs a model adapted to them: on the CMU treadmill trials the
positions fitted to a zero-shot estimate differed between a subject's two trials by up to 17 cm on
the thighs, those fitted to the adapted model's estimate by up to 6 cm.

Written here because the model is the project's own (its virtual IMU); the solver is SciPy's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, Protocol

import numpy as np
from scipy.optimize import least_squares

from sspinn.data.dataset import SAMPLE_RATE_HZ, Recording
from sspinn.errors import UserError
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.conventions import SEGMENTS
from sspinn.model.kinematics import virtual_imu

#: Samples left out at the start of a recording, s: a causal network's estimate settles there.
WARMUP_S: Final = 1.0
#: Fewest seconds fitted after the warm-up (about a stride).
MIN_FIT_S: Final = 1.0


class Kinematics(Protocol):
    """What the fit reads of a gait: (T, 9) coordinates q (m, rad), rates u and accelerations q̈
    (a :class:`~sspinn.estimator.inference.GaitEstimate`, a recording's labels, a trajectory)."""

    q: np.ndarray
    u: np.ndarray
    qdd: np.ndarray


class PlacementFitError(UserError):
    """The placement cannot be fitted (an estimate of another length, too few samples)."""


@dataclass(frozen=True)
class PlacementFit:
    """The result of :func:`fit_placement`.

    Attributes:
        placement: the fitted placement: position (m) and angle (rad) of each sensor of the
            recording in its segment frame; segments without a sensor keep the nominal values.
        bias: (7, 2) fitted constant accelerometer bias per segment (x, y in the sensor frame),
            m/s²; 0 for segments without a sensor.
        rms: (7,) RMS of the accelerometer residual after the fit, m/s² (NaN without a sensor).
        rms_nominal: (7,) the same at the nominal placement (its bias the mean residual there), m/s².
        segments: the segments whose sensor was fitted.
    """

    placement: IMUPlacement
    bias: np.ndarray
    rms: np.ndarray
    rms_nominal: np.ndarray
    segments: tuple[str, ...]


def _rotate_into_sensor(a: np.ndarray, theta: float) -> np.ndarray:
    """R(θ)ᵀ·a for (T, 2) vectors a in the segment frame."""
    c, s = np.cos(theta), np.sin(theta)
    return np.column_stack((c * a[:, 0] + s * a[:, 1], -s * a[:, 0] + c * a[:, 1]))


def fit_placement(recording: Recording, gait: Kinematics, body: BodyParameters | None = None,
                  warmup_s: float = WARMUP_S, angles: bool = True) -> PlacementFit:
    """Fit each sensor's position, angle and accelerometer bias to the kinematics of ``gait``
    (module docstring).

    Args:
        recording: the recording (its ``imu``, ``segments`` and nominal ``placement``).
        gait: its kinematics over the same samples (q, u, q̈; e.g. ``SSPINNpose.predict(recording)``).
        body: segment lengths and frames (default: Winter-scaled from the recording's height and mass,
            what the estimator assumes).
        warmup_s: seconds left out at the start (0 for exact kinematics such as labels).
        angles: fit the angles too (False: keep the recording's, e.g. a standing calibration's).
    """
    n = recording.n_samples
    if gait.q.shape[0] != n:
        raise PlacementFitError(f"{recording.name}: the gait has {gait.q.shape[0]} samples, the recording {n}; "
                                "fit the placement to an estimate of this recording")
    for what, values in (("q", gait.q), ("u", gait.u), ("qdd", gait.qdd), ("IMU signals", recording.imu[..., :2])):
        if values is None or not np.isfinite(values).all():
            raise PlacementFitError(f"{recording.name}: its {what} {'are missing' if values is None else 'are not all finite'}; "
                                    "the placement is fitted to finite kinematics and signals only")
    start = int(round(warmup_s * SAMPLE_RATE_HZ))
    if n - start < MIN_FIT_S * SAMPLE_RATE_HZ:
        raise PlacementFitError(f"{recording.name}: {n / SAMPLE_RATE_HZ:.2f} s is too short to fit a placement "
                                f"(at least {warmup_s + MIN_FIT_S:g} s)")
    body = body if body is not None else BodyParameters.from_anthropometry(recording.height, recording.mass)
    p = body.vector()
    nominal = recording.placement.vector().reshape(len(SEGMENTS), 3)
    sl = slice(start, None)
    at_origin = np.zeros_like(nominal)  # every sensor at its segment origin, turned by 0
    a0 = virtual_imu(gait.q[sl], gait.u[sl], gait.qdd[sl], at_origin.ravel(), p)[:, :, :2]
    ax = virtual_imu(gait.q[sl], gait.u[sl], gait.qdd[sl], (at_origin + [1.0, 0.0, 0.0]).ravel(), p)[:, :, :2] - a0
    ay = virtual_imu(gait.q[sl], gait.u[sl], gait.qdd[sl], (at_origin + [0.0, 1.0, 0.0]).ravel(), p)[:, :, :2] - a0

    fitted, bias = nominal.copy(), np.zeros((len(SEGMENTS), 2))
    rms, rms_nominal = np.full(len(SEGMENTS), np.nan), np.full(len(SEGMENTS), np.nan)
    for j, segment in enumerate(recording.segments):
        k = SEGMENTS.index(segment)
        measured = recording.imu[sl, j, :2]

        def model(x: float, y: float, theta: float, k: int = k) -> np.ndarray:  # the bias-free reading, (T, 2)
            return _rotate_into_sensor(a0[:, k] + ax[:, k] * x + ay[:, k] * y, theta)

        def residual(v: np.ndarray, k: int = k, measured: np.ndarray = measured) -> np.ndarray:
            # v = (x, y, θ, b_x, b_y), or (x, y, b_x, b_y) with the angle kept
            theta = v[2] if angles else nominal[k, 2]
            return (model(v[0], v[1], theta) + v[-2:] - measured).ravel()

        centred = np.mean(measured, axis=0) - np.mean(model(*nominal[k]), axis=0)  # the bias at the nominal placement
        start_v = np.concatenate((nominal[k] if angles else nominal[k, :2], centred))
        sol = least_squares(residual, start_v, x_scale=np.array([0.01, 0.01, 0.01, 0.1, 0.1][-len(start_v):]))
        fitted[k, : len(start_v) - 2], bias[k] = sol.x[:-2], sol.x[-2:]
        rms[k] = float(np.sqrt(np.mean(sol.fun**2)))
        rms_nominal[k] = float(np.sqrt(np.mean(residual(start_v) ** 2)))
    placement = IMUPlacement.from_vector(fitted.ravel())
    return PlacementFit(placement, bias, rms, rms_nominal, tuple(recording.segments))
