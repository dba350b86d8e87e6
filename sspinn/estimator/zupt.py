"""Zero-velocity-update (ZUPT) Kalman filter with RTS smoothing for a foot IMU in the sagittal plane.

SSPINNpose's foot-speed loss L_FS compares the foot IMU's horizontal speed with a ZUPT estimate
"as in gaitmap's RTS Kalman" (:class:`gaitmap.trajectory_reconstruction.RtsKalman`: an
error-state Kalman filter on strapdown integration, zero-velocity pseudo-measurements during
detected stance, a Rauch–Tung–Striebel smoother, results in ``velocity_``, ``position_``,
``zupts_``). gaitmap needs numpy < 2.1, so this module is the **2D sagittal equivalent**
(:class:`SagittalZuptKalman`), validated against motion capture by ``benchmarks/accuracy/validate_zupt.py``.

Conventions (:mod:`sspinn.model.conventions`)
--------------------------------------
* Global frame: x forward, y up (the foot's sagittal plane; the 2D filter does not track heading,
  so after a turn "forward" is still along the foot). Gravity 9.81 m/s² along −y.
* Sensor signals: ``acc_xy[:, 0]`` = acc_x (anterior, along the sole for the foot sensor),
  ``acc_xy[:, 1]`` = acc_y (proximal: up when the foot is flat), both **specific force** a − g in
  m/s² in the sensor frame (a flat foot at rest reads (0, +9.81)); ``gyr_z`` in **rad/s**,
  positive counter-clockwise seen from the subject's right (toe up).
* Sensor angle θ (rad, same sign): the rotation from the sensor frame to the global frame,
  R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]; at rest the specific force is R(θ)ᵀ·(0, g), so
  θ = atan2(acc_x, acc_y).

Method (one :meth:`SagittalZuptKalman.estimate` call)
----------------------------------------------------
1. **Stance detection** (:func:`detect_stance`): a sample is *quiet* when |gyr_z| is below
   ``zupt_gyro_threshold`` and (optionally) | ‖acc‖ − g | is below ``zupt_acc_threshold``; stance
   (ZUPT) samples are runs of quiet samples lasting at least ``zupt_window_s``. This is gaitmap's
   ``NormZuptDetector`` (maximum of the gyro norm over 0.05 s windows below 34 °/s) with windows
   sliding by one sample; in 2D only the sagittal rate enters the norm.
2. **Initial angle**: from the median specific-force direction during the first stance phase,
   carried back to sample 0 with the gyro integral (or ``initial_angle`` if given).
3. **Strapdown integration** (nominal state, trapezoidal rule): θ += ω·dt; global specific force
   R(θ)·f; acceleration R(θ)·f − (0, g); velocity and position integrated from zero.
4. **Error-state Kalman filter**, open loop as in gaitmap: error state δx = nominal − true =
   (δθ, δv_x, δv_y, δp_x, δp_y[, b]) with b the gyro bias (rad/s) when ``estimate_gyro_bias``.
   Linearised transition per sample: δθ' = δθ + b·dt, δv' = δv + dt·J·f_g·δθ (J = 90° rotation:
   an angle error tilts the global specific force f_g), δp' = δp + dt·δv (+ second-order terms);
   process noise per sample on δθ, δv and b. During stance the nominal velocity is a measurement
   of δv (the true velocity is zero); with ``level_walking`` the nominal height is a measurement
   of δp_y (stance at the starting height); with the bias state the stance gyro reading is a
   measurement of b (zero angular-rate update).
5. **RTS smoother** backward over the filtered error states, then the smoothed errors are
   subtracted from the nominal states. With ``n_iterations`` > 1 the smoothed initial angle and
   gyro bias become the next pass's nominal (relinearisation; the error-state prior is re-centred).

The defaults follow gaitmap (huge velocity process noise: between stance phases the velocity drift
is removed linearly in time, and the angle is essentially the gyro integral), except for a smaller
angle process noise and an accelerometer criterion in the stance detector (see the parameters). For a good angle
and gyro-bias estimate as well, use ``estimate_gyro_bias=True, velocity_error_variance=1e-4,
orientation_error_variance=1e-8, n_iterations=3`` (tested on synthetic data; the stride speeds of
the real validation recording are equally good with both).

Real 3D foot IMUs: project them onto the foot's sagittal plane first, e.g. with
:func:`benchmarks.accuracy.zupt_gaitmap.sagittal_from_gaitmap_frame` (gravity and heading
alignment, as gaitmap's preprocessing); that module also holds the validation on gaitmap's
example recording.

Steps 4 and 5 run in numba-compiled forward and backward loops (:mod:`sspinn.estimator._zupt_kernels`, with
the filter and smoother equations and their cost: O(T), about 30 ms per pass over 8 k samples; the
first call in a fresh checkout compiles them, ≈ 8 s on a slow 2-core machine, then numba's disk
cache loads them in well under a second).
"""

from __future__ import annotations

import inspect
import math
from typing import Self

import numpy as np

from sspinn.data.gait_events import runs_at_least, true_runs
from sspinn.estimator._zupt_kernels import eskf_rts
from sspinn.model.conventions import GRAVITY

#: Above this |gyr| (rad/s) the gyro is assumed to be in deg/s: 40 rad/s ≈ 2300 °/s, beyond the
#: peak foot rate of sprinting (≈ 25–35 rad/s) while walking in deg/s already reaches 300–700.
MAX_PLAUSIBLE_GYRO_RAD_S = 40.0

#: Error-state order (columns of ``state_std_``; the last one only with ``estimate_gyro_bias``).
ERROR_STATES: tuple[str, ...] = ("angle", "vel_x", "vel_y", "pos_x", "pos_y", "gyro_bias")


# --------------------------------------------------------------------------------------------
# Input checks and stance detection
# --------------------------------------------------------------------------------------------

class NoStanceError(ValueError):
    """The detector found no zero-velocity phase (wrong units, or no quiet stance, e.g. running
    with a rolling foot)."""

def _check_inputs(acc_xy: np.ndarray, gyr_z: np.ndarray, sample_rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Validate and convert the sensor signals; raise ``ValueError`` with a clear message."""
    if not np.isfinite(sample_rate_hz) or sample_rate_hz <= 0:
        raise ValueError(f"sample_rate_hz must be a positive number (Hz), got {sample_rate_hz!r}")
    acc = np.asarray(acc_xy, dtype=float)
    gyr = np.asarray(gyr_z, dtype=float)
    if acc.ndim != 2 or acc.shape[1] != 2:
        raise ValueError(f"acc_xy must have shape (T, 2) = (acc_x, acc_y) in m/s², got {acc.shape}")
    if gyr.ndim == 2 and gyr.shape[1] == 1:
        gyr = gyr[:, 0]
    if gyr.ndim != 1:
        raise ValueError(f"gyr_z must have shape (T,) in rad/s, got {gyr.shape}")
    if len(gyr) != len(acc):
        raise ValueError(f"acc_xy has {len(acc)} samples but gyr_z has {len(gyr)}")
    if len(acc) < 2:
        raise ValueError(f"need at least 2 samples, got {len(acc)}")
    for name, arr in (("acc_xy", acc), ("gyr_z", gyr)):
        bad = ~np.isfinite(arr)
        if bad.any():
            first = int(np.argwhere(bad)[0][0])
            raise ValueError(
                f"{name} contains {int(bad.sum())} NaN/inf value(s) (first at sample {first}); "
                "interpolate or cut gaps before the ZUPT filter"
            )
    peak = float(np.max(np.abs(gyr)))
    if peak > MAX_PLAUSIBLE_GYRO_RAD_S:
        raise ValueError(
            f"|gyr_z| reaches {peak:.0f}, above {MAX_PLAUSIBLE_GYRO_RAD_S:.0f} rad/s: the unit looks like deg/s; "
            "convert with np.deg2rad(gyr_z)"
        )
    typical = float(np.median(np.linalg.norm(acc, axis=1)))
    if typical < 2.0:
        raise ValueError(
            f"median |acc| is {typical:.2f}, expected about {GRAVITY} m/s² (specific force): "
            "the unit looks like g; multiply by 9.81"
        )
    return acc, gyr


def detect_stance(
    acc_xy: np.ndarray,
    gyr_z: np.ndarray,
    sample_rate_hz: float,
    gyro_threshold: float = math.radians(34.0),
    acc_threshold: float | None = 1.0,
    window_s: float = 0.05,
    gravity: float = GRAVITY,
) -> np.ndarray:
    """Stance (zero-velocity) mask, (T,) bool.

    A sample is quiet when ``|gyr_z| < gyro_threshold`` (rad/s) and, unless ``acc_threshold`` is
    None, ``| ‖acc_xy‖ − gravity | < acc_threshold`` (m/s²). Stance samples are the runs of quiet
    samples lasting at least ``window_s`` seconds (at least one sample). With ``acc_threshold=None``
    this equals gaitmap's ``NormZuptDetector(metric="maximum")`` with windows sliding by one sample.
    Defaults as in :class:`SagittalZuptKalman`.
    """
    acc, gyr = _check_inputs(acc_xy, gyr_z, sample_rate_hz)
    quiet = np.abs(gyr) < gyro_threshold
    if acc_threshold is not None:
        quiet &= np.abs(np.linalg.norm(acc, axis=1) - gravity) < acc_threshold
    return runs_at_least(quiet, max(1, int(round(window_s * sample_rate_hz))))


#: Shortest whole-body rest, s: walking never rests every segment this long (double support
#: lasts 0.1–0.2 s, and the swing leg moves through it).
STILL_WINDOW_S = 0.5


def whole_body_still(imu: np.ndarray, sample_rate_hz: float, window_s: float = STILL_WINDOW_S) -> np.ndarray:
    """(T,) bool: the samples where every IMU of ``imu`` (T, n_imu, 3) [acc_x, acc_y, gyr_z] is
    quiet by :func:`detect_stance`'s per-sample test (its default thresholds) at once, for at least
    ``window_s`` seconds — standing or sitting still, where the whole body, the pelvis included,
    has no velocity (a zero-velocity update of the whole body, as the foot's in stance)."""
    imu = np.asarray(imu, dtype=float)
    if imu.ndim != 3 or imu.shape[2] != 3 or imu.shape[1] < 1:
        raise ValueError(f"imu must be (T, n_imu >= 1, 3), got {imu.shape}")
    quiet = np.ones(imu.shape[0], dtype=bool)
    for k in range(imu.shape[1]):
        quiet &= detect_stance(imu[:, k, :2], imu[:, k, 2], sample_rate_hz, window_s=0.0)
    return runs_at_least(quiet, max(1, int(round(window_s * sample_rate_hz))))


#: Time constant, s, with which the network's own speed returns after a whole-body rest (and before
#: one): about one step, since gait initiation reaches its steady speed by the end of the first
#: step (Brenière & Do 1986, J Biomech 19:1035).
REST_EDGE_TAU_S = 0.5


def speed_at_rest(vx: np.ndarray, still: np.ndarray, sample_rate_hz: float, tau_s: float = REST_EDGE_TAU_S) -> np.ndarray:
    """The forward velocity ``vx`` (T,) with the whole-body rests ``still`` (T,) bool
    (:func:`whole_body_still`) applied: 0 during a rest, and continuous at its edges.

    The body's velocity is continuous, so a walk that follows a rest starts from 0. The network's
    speed is not: trained on steady walking and running, it carries the speed it reported during
    the rest (0.3–0.6 m/s in real quiet standing) into the first steps. After a rest that ends at
    t_e its offset v(t_e) is removed with a decay, v(t) − v(t_e)·exp(−(t − t_e)/τ); before a rest
    that starts at t_s, mirrored: v(t) − v(t_s)·exp(−(t_s − t)/τ). Samples τ·ln 10⁶ (7 s at the
    default) or farther from every rest keep the network's speed to within 10⁻⁶ of that offset;
    a recording without a rest is returned unchanged (a copy).
    """
    vx = np.asarray(vx, dtype=float)
    still = np.asarray(still, dtype=bool)
    if vx.shape != still.shape or vx.ndim != 1:
        raise ValueError(f"vx and still must be (T,) arrays of one length, got {vx.shape} and {still.shape}")
    if not tau_s > 0:
        raise ValueError(f"tau_s must be > 0 s, got {tau_s}")
    out = vx.copy()
    t = np.arange(len(vx)) / sample_rate_hz
    for start, end in stance_phases(still):
        if end < len(vx):  # the walk after the rest starts from 0
            out[end:] -= vx[end] * np.exp(-(t[end:] - t[end]) / tau_s)
        if start > 0:  # and the walk before it ends at 0
            out[:start] -= vx[start - 1] * np.exp(-(t[start - 1] - t[:start]) / tau_s)
    out[still] = 0.0
    return out


def speed_with_rests(vx: np.ndarray, imu: np.ndarray, sample_rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The forward velocity the estimate reports and the rests: ``(vx', still)``, ``still`` (T,)
    bool the whole-body rests of ``imu`` (:func:`whole_body_still`) and ``vx'`` the network's
    ``vx`` (T,) with them applied (:func:`speed_at_rest`; ``vx`` itself where there is none)."""
    still = whole_body_still(imu, sample_rate_hz)
    return (speed_at_rest(vx, still, sample_rate_hz) if still.any() else vx), still


def stance_phases(stance: np.ndarray) -> np.ndarray:
    """(n, 2) int array of [start, end) sample indices of the True runs of a boolean mask."""
    return np.array(true_runs(stance), dtype=np.int64).reshape(-1, 2)


# --------------------------------------------------------------------------------------------
# Strapdown integration of the nominal state (the error state is filtered in sspinn.estimator._zupt_kernels)
# --------------------------------------------------------------------------------------------
def _cumtrapz(y: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative trapezoidal integral along axis 0, starting at zero (same length as y)."""
    out = np.zeros_like(y, dtype=float)
    out[1:] = np.cumsum(0.5 * dt * (y[1:] + y[:-1]), axis=0)
    return out


def _rotate(angle: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """R(angle)·vec row-wise (sensor → global), angle (T,) rad, vec (T, 2)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack((c * vec[:, 0] - s * vec[:, 1], s * vec[:, 0] + c * vec[:, 1]))


# --------------------------------------------------------------------------------------------
# The estimator
# --------------------------------------------------------------------------------------------
class SagittalZuptKalman:
    """2D (sagittal) ZUPT-aided error-state Kalman filter with RTS smoothing (gaitmap ``RtsKalman`` style).

    Configure in ``__init__``, run :meth:`estimate`, read the trailing-underscore attributes.
    Variances are **per sample** (as in gaitmap), so they depend on the sample rate; the defaults
    are gaitmap's (tuned there on 204.8 Hz NilsPod foot sensors) except where noted. As gaitmap
    notes, the ratios between the variances matter more than their absolute values.

    Parameters
    ----------
    zupt_gyro_threshold
        Stance requires |gyr_z| below this, rad/s. Default 34 °/s = 0.593 rad/s (gaitmap's
        ``NormZuptDetector`` threshold on the 3D gyro norm).
    zupt_acc_threshold
        Stance additionally requires | ‖acc‖ − g | below this, m/s²; None disables the criterion.
        Default 1.0 (not in gaitmap's default detector: with only the sagittal rate, the pitch-rate
        zero crossings of swing can look quiet; the accelerometer criterion rejects them).
    zupt_window_s
        Minimum duration of a stance run, s. Default 0.05 (gaitmap's window length).
    zupt_variance
        Variance of the zero-velocity pseudo-measurement, (m/s)². Default 1e-7 (gaitmap 10e-8).
    velocity_error_variance
        Process noise of the velocity error per sample, (m/s)². Default 1e6 (gaitmap 10e5): the
        velocity error is essentially free during swing, so the smoother removes the drift linearly
        in time between stance phases. Lower it (≈ 1e-4) to make the angle and gyro bias
        observable from the stance-phase velocity drift.
    orientation_error_variance
        Process noise of the angle error per sample, rad². Default 1e-6 (≈ 1 mrad per sample; not
        gaitmap's 10e-2 = 0.1: in 2D that lets the angle of a stationary sensor wander by ~0.4 rad
        in 20 s and its position by 8 cm, see ``tests/test_zupt.py``; the stride speeds of the
        validation recording change by < 0.01 m/s RMSE between 1e-2 and 1e-8).
    level_walking
        If True (default, as gaitmap), the sensor height in stance is also a measurement (zero: all
        stance phases at one level, the origin of the height). Switch off for stairs or slopes.
    level_walking_variance
        Variance of the level-walking height measurement, m². Default 1e-7 (gaitmap 10e-8).
    estimate_gyro_bias
        Add a gyro bias b (rad/s; measured rate = true rate + b) to the error state. Default False
        (gaitmap has none).
    gyro_bias_variance
        Random-walk variance of the bias per sample, (rad/s)². Default 1e-12.
    initial_gyro_bias_std
        Prior standard deviation of the bias, rad/s. Default 0.02 (≈ 1.1 °/s).
    zaru_variance
        With ``estimate_gyro_bias``: during stance the gyro reading is a measurement of the bias
        (zero angular-rate update) with this variance, (rad/s)² per sample; None disables it.
        Default 1e-2 (the detector lets through rates up to ``zupt_gyro_threshold``).
    initial_angle
        Sensor angle at sample 0, rad (see module docstring). None (default): from the median
        specific-force direction in the first stance phase.
    initial_angle_std
        Prior standard deviation of the initial angle, rad. Default 0.05.
    n_iterations
        Filter passes; passes after the first relinearise about the previous smoothed initial angle
        and gyro bias (the error-state prior is re-centred there). Default 1.
    gravity
        m/s². Default :data:`sspinn.model.conventions.GRAVITY` = 9.81.

    Attributes
    ----------
    angle_
        (T,) global sensor angle, rad (counter-clockwise seen from the right; 0 = sensor x axis
        horizontal).
    velocity_
        (T, 2) global velocity (forward, up), m/s.
    position_
        (T, 2) global position (forward, up), m: forward relative to sample 0; up relative to the
        stance height with ``level_walking``, else to sample 0.
    zupts_
        (T,) bool, the stance samples used as zero-velocity updates.
    zupt_phases_
        (n, 2) int, [start, end) samples of the stance phases.
    gyro_bias_
        (T,) estimated gyro bias, rad/s (zeros when ``estimate_gyro_bias`` is False).
    state_std_
        (T, n) smoothed standard deviations of the error states, in the order of
        :data:`ERROR_STATES` (angle rad, velocity m/s, position m[, bias rad/s]).
    initial_angle_
        The (last pass's) angle at sample 0, rad.
    sample_rate_hz
        The sample rate passed to :meth:`estimate`, Hz.
    """

    def __init__(
        self,
        *,
        zupt_gyro_threshold: float = math.radians(34.0),
        zupt_acc_threshold: float | None = 1.0,
        zupt_window_s: float = 0.05,
        zupt_variance: float = 1e-7,
        velocity_error_variance: float = 1e6,
        orientation_error_variance: float = 1e-6,
        level_walking: bool = True,
        level_walking_variance: float = 1e-7,
        estimate_gyro_bias: bool = False,
        gyro_bias_variance: float = 1e-12,
        initial_gyro_bias_std: float = 0.02,
        zaru_variance: float | None = 1e-2,
        initial_angle: float | None = None,
        initial_angle_std: float = 0.05,
        n_iterations: int = 1,
        gravity: float = GRAVITY,
    ) -> None:
        self.zupt_gyro_threshold = zupt_gyro_threshold
        self.zupt_acc_threshold = zupt_acc_threshold
        self.zupt_window_s = zupt_window_s
        self.zupt_variance = zupt_variance
        self.velocity_error_variance = velocity_error_variance
        self.orientation_error_variance = orientation_error_variance
        self.level_walking = level_walking
        self.level_walking_variance = level_walking_variance
        self.estimate_gyro_bias = estimate_gyro_bias
        self.gyro_bias_variance = gyro_bias_variance
        self.initial_gyro_bias_std = initial_gyro_bias_std
        self.zaru_variance = zaru_variance
        self.initial_angle = initial_angle
        self.initial_angle_std = initial_angle_std
        self.n_iterations = n_iterations
        self.gravity = gravity

    def get_params(self) -> dict[str, object]:
        """The ``__init__`` parameters by name (gaitmap / tpcp style)."""
        names = [name for name in inspect.signature(type(self).__init__).parameters if name != "self"]
        return {name: getattr(self, name) for name in names}

    def clone(self) -> SagittalZuptKalman:
        """A new, unfitted estimator with the same parameters."""
        return type(self)(**self.get_params())

    def _check_parameters(self) -> None:
        positive: dict[str, float | None] = {
            "zupt_gyro_threshold": self.zupt_gyro_threshold,
            "zupt_acc_threshold": self.zupt_acc_threshold,
            "zupt_variance": self.zupt_variance,
            "velocity_error_variance": self.velocity_error_variance,
            "orientation_error_variance": self.orientation_error_variance,
            "level_walking_variance": self.level_walking_variance,
            "gyro_bias_variance": self.gyro_bias_variance,
            "initial_gyro_bias_std": self.initial_gyro_bias_std,
            "zaru_variance": self.zaru_variance,
            "initial_angle_std": self.initial_angle_std,
            "gravity": self.gravity,
        }
        optional = {"zupt_acc_threshold", "zaru_variance"}
        for name, value in positive.items():
            if value is None and name in optional:
                continue
            if value is None or not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if not (np.isfinite(self.zupt_window_s) and self.zupt_window_s >= 0):
            raise ValueError(f"zupt_window_s must be ≥ 0 s, got {self.zupt_window_s!r}")
        if self.initial_angle is not None and not np.isfinite(self.initial_angle):
            raise ValueError(f"initial_angle must be finite (rad) or None, got {self.initial_angle!r}")
        if int(self.n_iterations) != self.n_iterations or self.n_iterations < 1:
            raise ValueError(f"n_iterations must be a positive integer, got {self.n_iterations!r}")

    def estimate(
        self,
        acc_xy: np.ndarray,
        gyr_z: np.ndarray,
        sample_rate_hz: float,
        zupts: np.ndarray | None = None,
    ) -> Self:
        """Estimate angle, velocity and position of the sensor.

        Parameters
        ----------
        acc_xy
            (T, 2) specific force (acc_x anterior, acc_y proximal/up), m/s², sensor frame.
        gyr_z
            (T,) sagittal angular rate, rad/s, counter-clockwise seen from the right (toe up +).
        sample_rate_hz
            Hz, > 0.
        zupts
            Optional (T,) bool stance mask to use instead of :func:`detect_stance` (e.g. from a 3D
            detector).

        Returns
        -------
        self, with the result attributes set.

        Notes
        -----
        Before the first stance phase the velocity starts from an unknown value (nominal zero)
        that no zero-velocity update constrains, and after the last one nothing corrects the
        drift: the estimates outside the first … last stance phase are not usable unless the
        recording starts and ends at rest (as gaitmap assumes).
        """
        self._check_parameters()
        acc, gyr = _check_inputs(acc_xy, gyr_z, sample_rate_hz)
        fs = float(sample_rate_hz)
        dt = 1.0 / fs
        T = len(gyr)
        if zupts is None:
            stance = detect_stance(
                acc, gyr, fs, self.zupt_gyro_threshold, self.zupt_acc_threshold, self.zupt_window_s, self.gravity
            )
        else:
            stance = np.asarray(zupts)
            if stance.shape != (T,):
                raise ValueError(f"zupts must have shape ({T},), got {stance.shape}")
            stance = stance.astype(bool)
        phases = stance_phases(stance)
        if len(phases) == 0:
            raise NoStanceError(
                "no stance (zero-velocity) phase detected: check the units (rad/s, m/s²) or the "
                f"thresholds (zupt_gyro_threshold = {self.zupt_gyro_threshold:.3f} rad/s, "
                f"zupt_acc_threshold = {self.zupt_acc_threshold} m/s²)"
            )

        if self.initial_angle is None:
            s, e = phases[0]
            f_rest = np.median(acc[s:e], axis=0)
            theta0 = math.atan2(f_rest[0], f_rest[1]) - float(np.median(_cumtrapz(gyr[:e], dt)[s:e]))
        else:
            theta0 = float(self.initial_angle)

        # error state (θ, v_x, v_y, p_x, p_y[, b]); measurement rows: v_x, v_y[, p_y][, b]
        n = 6 if self.estimate_gyro_bias else 5
        q = np.zeros(n)
        q[0] = self.orientation_error_variance
        q[1:3] = self.velocity_error_variance
        p0 = np.zeros(n)
        p0[0] = self.initial_angle_std**2
        p0[1:3] = self.velocity_error_variance  # the initial velocity (nominal zero) is free, as in gaitmap
        p0[3:5] = 1e-12  # the origin is the sensor position at sample 0 ...
        if self.level_walking:
            p0[4] = 1.0  # ... except the height, which is the stance level (the start may be in swing)
        rows: list[tuple[int, float]] = [(1, self.zupt_variance), (2, self.zupt_variance)]
        if self.level_walking:
            rows.append((4, self.level_walking_variance))
        use_zaru = self.estimate_gyro_bias and self.zaru_variance is not None
        if self.estimate_gyro_bias:
            q[5] = self.gyro_bias_variance
            p0[5] = self.initial_gyro_bias_std**2
            if use_zaru:
                rows.append((5, self.zaru_variance))
        H = np.zeros((len(rows), n))
        for i, (state, _) in enumerate(rows):
            H[i, state] = 1.0
        r = np.array([var for _, var in rows], dtype=float)

        bias = np.zeros(T)
        gravity_vec = np.array([0.0, self.gravity])
        for _ in range(int(self.n_iterations)):
            angle = theta0 + _cumtrapz(gyr - bias, dt)
            f_global = _rotate(angle, acc)
            vel = _cumtrapz(f_global - gravity_vec, dt)
            pos = _cumtrapz(vel, dt)
            # what each row observes: nominal − true, with the true values of stance
            observed = [vel[:, 0], vel[:, 1]]
            if self.level_walking:
                observed.append(pos[:, 1])
            if use_zaru:
                observed.append(gyr - bias)
            err, var = eskf_rts(
                np.ascontiguousarray(f_global),
                np.ascontiguousarray(np.column_stack(observed)),
                stance,
                dt,
                q,
                p0,
                H,
                r,
            )
            angle = angle - err[:, 0]
            vel = vel - err[:, 1:3]
            pos = pos - err[:, 3:5]
            if self.estimate_gyro_bias:
                bias = bias + err[:, 5]
            theta0 = float(angle[0])
        self.sample_rate_hz = fs
        self.initial_angle_ = theta0
        self.angle_ = angle
        self.velocity_ = vel
        self.position_ = pos
        self.zupts_ = stance
        self.zupt_phases_ = phases
        self.gyro_bias_ = bias
        self.state_std_ = np.sqrt(np.maximum(var, 0.0))
        return self


def foot_speed(
    acc_xy: np.ndarray,
    gyr_z: np.ndarray,
    sample_rate_hz: float,
    estimator: SagittalZuptKalman | None = None,
    max_gap_s: float | None = 2.0,
) -> np.ndarray:
    """Horizontal foot-sensor speed |v_x| (T,), m/s, from a ZUPT Kalman estimate.

    ``acc_xy`` (T, 2) m/s² specific force and ``gyr_z`` (T,) rad/s in the sensor frame (module
    docstring); ``estimator`` (fitted in place) defaults to ``SagittalZuptKalman()``. The signed
    forward velocity is ``estimator.velocity_[:, 0]``.

    Without zero-velocity updates the estimate drifts quadratically, so samples that are not
    enclosed by two detected stance phases at most ``max_gap_s`` seconds apart (end to start) are
    NaN (``max_gap_s=None`` keeps every sample): before the first and after the last stance, and in
    stretches where the detector misses stances (e.g. fast gait with a rolling foot).
    """
    est = SagittalZuptKalman() if estimator is None else estimator
    est.estimate(acc_xy, gyr_z, sample_rate_hz)
    speed = np.abs(est.velocity_[:, 0])
    if max_gap_s is not None:
        valid = np.zeros(len(speed), dtype=bool)
        phases = est.zupt_phases_
        for (s0, e0), (s1, e1) in zip(phases[:-1], phases[1:]):
            if (s1 - e0) / sample_rate_hz <= max_gap_s:
                valid[s0:e1] = True
        if len(phases):
            valid[phases[-1, 0] : phases[-1, 1]] = True
        speed[~valid] = np.nan
    return speed
