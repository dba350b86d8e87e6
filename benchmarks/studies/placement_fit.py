"""Where each sensor sits on its segment, fitted to an estimate's kinematics.

A sensor at position r = (x, y) (m) and angle θ (rad) in its segment's frame reads the specific
force of that point of the segment, turned into the sensor frame:

    f(t) = R(θ)ᵀ · ( a₀(t) + A_x(t)·x + A_y(t)·y ) + b,

with a₀ the specific force of the segment frame's origin and A_x, A_y the rigid-body terms of the
segment's angular rate and acceleration (−ω², ω̇; :class:`SegmentMotion`, whose reading is the
virtual IMU of :func:`sspinn.model.kinematics.virtual_imu`), and b a constant accelerometer bias
(m/s²). Given the coordinates q, u, q̈ of a gait — an SSPINNpose estimate, no
labels needed — the five numbers (x, y, θ, b_x, b_y) of each sensor are a small nonlinear least
squares problem over the recording's accelerometer samples (:func:`fit_placement`, solved by
:func:`scipy.optimize.least_squares` from the recording's nominal placement).

This is not the paper's placement optimisation (the placement as parameters of the network's
training, ``learn_placement``): the network stays as trained, and the placement is fitted
afterwards to the kinematics it estimates. A trained network's kinematics already explain the
signals, so the residual that is left is what the nominal placement cannot explain; on the
synthetic benchmark this recovers the running thighs to about a third of the nominal error (about
half on runners no model was trained on), the walking thighs to about two thirds
(docs/results/paper_claims.md, ``placement``). The estimate's
kinematics errors are what limit it: fitted to the true kinematics the same problem lands within
about 0.3–0.7 cm (thighs and shanks); of the estimate's motion, the walking thighs' angular
acceleration costs the most (the benchmark's ``--decompose``).
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
from sspinn.model.kinematics import imu_kinematics, segment_kinematics

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


@dataclass(frozen=True)
class SegmentMotion:
    """The rigid-body motion of the seven segments that a sensor's reading depends on
    (:func:`segment_motion`), over T samples, SEGMENTS order.

    Attributes:
        origin_acc: (T, 7, 2) acceleration of each segment frame's origin, global frame, m/s².
        angle: (T, 7) global segment angle, rad.
        rate: (T, 7) angular rate, rad/s.
        angular_acc: (T, 7) angular acceleration, rad/s².
        gravity: g, m/s².
    """

    origin_acc: np.ndarray
    angle: np.ndarray
    rate: np.ndarray
    angular_acc: np.ndarray
    gravity: float

    def terms(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(a₀, A_x, A_y), each (T, 7, 2) in the segment frame (m/s², and m/s² per m): a sensor at
        (x, y) of a segment turned by 0 reads a₀ + A_x·x + A_y·y, with a₀ = R(θ)ᵀ(a_O + g·ŷ),
        A_x = (−ω², ω̇) and A_y = (−ω̇, −ω²) (the rigid-body point acceleration ω̇·J·r − ω²·r)."""
        a0 = _rotate_into_sensor(self.origin_acc + [0.0, self.gravity], self.angle)
        w2, alpha = self.rate**2, self.angular_acc
        return a0, np.stack((-w2, alpha), axis=-1), np.stack((-alpha, -w2), axis=-1)


def segment_motion(gait: Kinematics, body: BodyParameters) -> SegmentMotion:
    """The :class:`SegmentMotion` of the coordinates q, u, q̈ of ``gait`` (the generated
    kinematics of :mod:`sspinn.model.kinematics`)."""
    origin = imu_kinematics(gait.q, gait.u, gait.qdd, np.zeros(3 * len(SEGMENTS)), body.vector())
    seg = segment_kinematics(gait.q, gait.u, gait.qdd)
    return SegmentMotion(np.asarray(origin)[..., 4:6], *(np.asarray(seg)[..., i] for i in range(3)), float(body.gravity))


def _rotate_into_sensor(a: np.ndarray, theta: float | np.ndarray) -> np.ndarray:
    """R(θ)ᵀ·a for (..., 2) vectors a, θ one angle or one per vector (the shape of a[..., 0])."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack((c * a[..., 0] + s * a[..., 1], -s * a[..., 0] + c * a[..., 1]), axis=-1)


def fit_sensor(a0: np.ndarray, ax: np.ndarray, ay: np.ndarray, measured: np.ndarray, nominal: np.ndarray,
               angles: bool = True) -> tuple[np.ndarray, np.ndarray, float, float]:
    """One sensor's position, angle and bias fitted to its segment's rigid-body terms.

    Args:
        a0, ax, ay: (T, 2) terms of the sensor's segment (:meth:`SegmentMotion.terms`).
        measured: (T, 2) the sensor's accelerometer samples, m/s².
        nominal: [x (m), y (m), θ (rad)], the start (and the angle kept with ``angles=False``).
        angles: fit the angle too.

    Returns:
        ([x, y, θ], [b_x, b_y], RMS residual after the fit, RMS residual at the nominal placement
        with its mean removed), m, rad, m/s².
    """

    def model(x: float, y: float, theta: float) -> np.ndarray:  # the bias-free reading, (T, 2)
        return _rotate_into_sensor(a0 + ax * x + ay * y, theta)

    def residual(v: np.ndarray) -> np.ndarray:  # v = (x, y, θ, b_x, b_y), or (x, y, b_x, b_y) with the angle kept
        theta = v[2] if angles else nominal[2]
        return (model(v[0], v[1], theta) + v[-2:] - measured).ravel()

    centred = np.mean(measured, axis=0) - np.mean(model(*nominal), axis=0)  # the bias at the nominal placement
    start_v = np.concatenate((nominal if angles else nominal[:2], centred))
    sol = least_squares(residual, start_v, x_scale=np.array([0.01, 0.01, 0.01, 0.1, 0.1])[-len(start_v):])
    found = np.array([*sol.x[:2], sol.x[2] if angles else nominal[2]])
    return (found, sol.x[-2:], float(np.sqrt(np.mean(sol.fun**2))),
            float(np.sqrt(np.mean(residual(start_v) ** 2))))


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
    start = check_fit_inputs(recording, gait, warmup_s)
    body = body if body is not None else BodyParameters.from_anthropometry(recording.height, recording.mass)
    a0, ax, ay = (t[start:] for t in segment_motion(gait, body).terms())
    return fit_to_terms(recording, a0, ax, ay, start, angles)


def check_fit_inputs(recording: Recording, gait: Kinematics, warmup_s: float = WARMUP_S) -> int:
    """The first sample fitted, after checking that ``gait`` has the recording's length, both are
    finite and enough is left after the warm-up (a :class:`PlacementFitError` naming the recording)."""
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
    return start


def fit_to_terms(recording: Recording, a0: np.ndarray, ax: np.ndarray, ay: np.ndarray, start: int,
                 angles: bool = True) -> PlacementFit:
    """:func:`fit_placement` given the segments' rigid-body terms (T − start, 7, 2) from sample
    ``start`` on: each of the recording's sensors fitted by :func:`fit_sensor`."""
    nominal = recording.placement.vector().reshape(len(SEGMENTS), 3)
    fitted, bias = nominal.copy(), np.zeros((len(SEGMENTS), 2))
    rms, rms_nominal = np.full(len(SEGMENTS), np.nan), np.full(len(SEGMENTS), np.nan)
    for j, segment in enumerate(recording.segments):
        k = SEGMENTS.index(segment)
        fitted[k], bias[k], rms[k], rms_nominal[k] = fit_sensor(a0[:, k], ax[:, k], ay[:, k],
                                                                recording.imu[start:, j, :2], nominal[k], angles)
    return PlacementFit(IMUPlacement.from_vector(fitted.ravel()), bias, rms, rms_nominal, tuple(recording.segments))
