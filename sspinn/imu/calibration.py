"""Sensor-to-segment calibration onto the sagittal plane, from the walking data itself.

Input: per mapped segment, a sensor's raw 3D specific force ``acc`` (n, 3, m/s², gravity
included) and angular rate ``gyr`` (n, 3, rad/s) in its own frame, on one 100 Hz grid. Output:
per sensor a rotation whose rows are the segment's x (anterior), y (proximal) and z (the
subject's right, :mod:`sspinn.model.conventions`) axes in the sensor frame, so that
``acc_x, acc_y, gyr_z = x·acc, y·acc, z·(gyr − bias)`` are the signals of a sagittal IMU aligned
with its segment (placement angle 0).

Method (per sensor; ``up`` is the direction of the specific force in quiet standing when there is
a standing phase, else its mean while walking):

1. **Standing** (:func:`detect_standing`): the longest span ≥ :data:`MIN_STANDING_S` where
   every sensor's angular-rate norm (0.1 s mean) stays below :data:`STANDING_GYRO_RAD_S`; its
   mean angular rate is the gyroscope bias. **Walking** (:func:`detect_walking`): 1 s windows
   whose largest angular-rate RMS exceeds :data:`WALKING_GYRO_RMS_RAD_S`. The stride period is
   the autocorrelation peak of a leg sensor's rate norm (:func:`stride_period`). **Turns**
   (:mod:`sspinn.imu.turns`, from the pelvis sensor's rate about the vertical) are left out of
   the walking and named in a warning: turning is not sagittal walking.
2. **Medio-lateral axis** z, constrained perpendicular to ``up`` (gravity lies in the sagittal
   plane): for leg segments the principal axis of the angular rate while walking (largest
   eigenvector of its second moment, projected into the plane ⟂ ``up``). The pelvis (HAT) turns
   most about the vertical and anterior axes while walking, so its axis comes from the
   accelerometer: the anterior direction is the horizontal direction whose specific force leads
   the vertical one by a quarter cycle at the step frequency 2/T (braking after heel strike while
   the vertical force peaks, propulsion before the next; :func:`anterior_direction`), and
   z = anterior × up, sign included. Reported: the out-of-plane energy fraction
   ``1 − Σ(z·ω)² / Σ|ω|²`` while walking, and ``axis_check_deg``, the angle between z and an
   independent estimate — the unconstrained principal axis (legs), or for the pelvis the axis of
   the rotation that repeats every step (the largest eigenvector of sym(E[ω(t + T/2) ω(t)ᵀ]) ⟂
   up: sagittal tilt is symmetric between left and right steps, obliquity and axial rotation
   change sign; it fails in asymmetric gaits such as the CMU stiff-knee trials, hence only a check).
3. **Sign of z** (it must point to the subject's right, so that rotations are counter-clockwise
   seen from the right): a ``right_axis`` hint of the sensor map decides; otherwise votes on
   the candidate frame (x = y × z), each ``tanh(feature / 0.3)``, and the sign combination of a
   leg's sensors with the largest sum wins: pelvis — the anterior specific force leads the
   vertical one by a quarter cycle at the step frequency (braking after heel strike while the
   vertical force peaks; phase of their cross-spectrum at 2/T); thigh — the same at 2/T and a
   positively skewed angular rate (fast forward swing, slow stance); shank — a positively
   skewed angular rate; foot — the phase at 1/T; pairs — shank and foot rates correlate
   positively, and the knee angle (integral of shank − thigh rate, high-passed) is skewed
   negative (flexion is negative and one-sided). The phase votes are empirical: they hold with
   the same sign in the averaged real stride of ``dorschky_P03_walking`` (1.37 m/s), a predicted
   1.3 m/s gait and the standing-calibrated CMU treadmill trials (0.77 m/s). Each sensor's margin
   (score lost by flipping it) is reported; below :data:`SIGN_MARGIN_WARN` the report flags it.
4. **In-plane angle**: y is ``up`` projected into the plane when there is a standing phase
   (assumption: quiet standing is the model's zero pose: every segment upright, feet flat).
   Otherwise from the walking itself (:mod:`sspinn.imu.joint_centres`): a thigh's or shank's y
   is the line between its two joint centres (hip–knee, knee–ankle), fitted to the sensors on
   either side of each joint; a foot's y is gravity while it rests flat in mid-stance. Where
   that fails (a sensor missing, an implausible fit, no rest) and for the pelvis: the mean
   specific force while walking, rotated by the segment's typical walking value
   :data:`WALKING_MEAN_FORCE_ANGLE_DEG` (the angle of the mean specific force from the
   segment's y towards its x axis in real walking; its spread between people and speeds,
   several degrees, is the error of this fallback). The reported angle φ is the in-plane angle
   of the sensor axis nearest to y (``reference_axis``) from y, counter-clockwise seen from the
   right (the placement-angle convention of :class:`sspinn.model.body.IMUPlacement`).
5. **Checks**: an ``up_axis`` hint whose gravity reading is below −0.5 g is a sensor mounted
   upside down (:class:`SensorCalibrationError` naming it). Without hints nothing here depends on
   how a sensor is mounted; :mod:`sspinn.imu.cross_sensor_checks` compares the sensors with each other
   (upside down, legs mixed up in the map) and adds warnings.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import product
from typing import Final

import numpy as np
from scipy.signal import butter, sosfiltfilt
from scipy.stats import skew

from sspinn.data.gait_events import true_runs
from sspinn.data.signal_checks import cross_spectrum
from sspinn.errors import UserError
from sspinn.imu import joint_centres
from sspinn.imu.sensor_map import SensorAssignment
from sspinn.imu.turns import Turn, detect_turns
from sspinn.model.body import WINTER, IMUPlacement
from sspinn.model.conventions import GRAVITY

STANDING_GYRO_RAD_S: Final = 0.2
MIN_STANDING_S: Final = 0.3
WALKING_GYRO_RMS_RAD_S: Final = 0.3
MIN_WALKING_S: Final = 4.0
SIGN_MARGIN_WARN: Final = 0.5
VOTE_SCALE: Final = 0.3
#: Angle (deg) of the mean specific force while walking from the segment's y axis towards its x
#: axis (atan2(mean acc_x, mean acc_y) of a segment-aligned sensor) in level walking, rounded
#: means of two real data sets: the averaged stride of Dorschky et al. 2019 (1.37 m/s; pelvis
#: 2.9, thigh 11.2, shank −4.1, instep −16.3) and the standing-calibrated CMU treadmill baseline
#: trials (0.77 m/s, 5 subjects; pelvis −1.2, thigh 7.8, shank −5.4, forefoot −10.2, SD between
#: subjects 1–4). A predicted 1.3 m/s gait of the model gives 1.0, 3.4, −11.7, −5.0: expect
#: errors of several degrees from this fallback (docs/imu_import.md).
WALKING_MEAN_FORCE_ANGLE_DEG: Final[dict[str, float]] = {"pelvis": 1.0, "femur": 9.5, "tibia": -5.0, "foot": -13.0}
_AXIS_NAMES: Final = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")


class SensorCalibrationError(UserError):
    """The walking data cannot calibrate a sensor (no walking, too short, upside down…)."""


#: Relative deviation of the standing |specific force| from g above which the accelerometer's
#: gain is corrected (:attr:`SensorCalibration.acc_gain`).
ACC_GAIN_TOLERANCE: float = 0.03


@dataclass
class SensorCalibration:
    """One sensor's calibration (module docstring).

    Attributes:
        sensor, segment: names. rotation: (3, 3) rows = segment x, y, z axes in the sensor frame.
        gyro_bias: (3,) rad/s, removed before projection (zeros without a standing phase).
        out_of_plane_fraction: share of the angular-rate energy outside z while walking.
        axis_check_deg: angle between z and the independent axis estimate (module docstring).
        angle_deg: in-plane angle φ of ``reference_axis`` from the segment's y axis.
        axis_method, sign_method, angle_method: how each was found.
        sign_votes: the votes (positive: z as found points right). sign_margin: score lost by flipping.
        standing_acc_norm: |specific force| in standing, m/s² (None without standing).
        acc_gain: factor applied to the accelerometer by :meth:`project`: g / ``standing_acc_norm``
            when that is off g by more than :data:`ACC_GAIN_TOLERANCE`, else 1. (The CMU data's
            left forefoot sensor reads 12.1–12.4 m/s² standing in every trial; uncorrected, the
            foot's zero-velocity detection never fired. One standing posture cannot tell a gain
            error from a bias; a gain is assumed.)
    """

    sensor: str
    segment: str
    rotation: np.ndarray
    gyro_bias: np.ndarray
    out_of_plane_fraction: float
    axis_check_deg: float
    angle_deg: float
    reference_axis: str
    axis_method: str
    sign_method: str
    angle_method: str
    sign_votes: dict[str, float] = field(default_factory=dict)
    sign_margin: float = float("inf")
    standing_acc_norm: float | None = None
    acc_gain: float = 1.0

    @property
    def axis(self) -> np.ndarray:
        """The medio-lateral axis z (to the subject's right) in the sensor frame."""
        return self.rotation[2]

    def project(self, acc: np.ndarray, gyr: np.ndarray) -> np.ndarray:
        """(n, 3) ``acc_x, acc_y, gyr_z`` (m/s², rad/s) in the segment frame."""
        acc = self.acc_gain * acc
        return np.column_stack([acc @ self.rotation[0], acc @ self.rotation[1], (gyr - self.gyro_bias) @ self.rotation[2]])

    def to_dict(self) -> dict:
        return {
            "sensor": self.sensor, "segment": self.segment, "rotation_rows_xyz": self.rotation.round(6).tolist(),
            "gyro_bias_rad_s": self.gyro_bias.round(6).tolist(), "out_of_plane_fraction": round(self.out_of_plane_fraction, 4),
            "axis_check_deg": round(self.axis_check_deg, 2), "angle_deg": round(self.angle_deg, 2), "reference_axis": self.reference_axis,
            "axis_method": self.axis_method, "sign_method": self.sign_method, "angle_method": self.angle_method,
            "sign_votes": {k: round(v, 3) for k, v in self.sign_votes.items()}, "sign_margin": round(self.sign_margin, 3),
            "standing_acc_norm_m_s2": None if self.standing_acc_norm is None else round(self.standing_acc_norm, 3),
            "acc_gain": round(self.acc_gain, 5),
        }


@dataclass
class Calibration:
    """All sensors' calibrations plus the gait context they were found in.

    Attributes:
        sensors: segment → :class:`SensorCalibration`. rate_hz: sample rate, Hz.
        standing: (start, stop) samples of quiet standing, or None.
        walking_s: walking used, s. stride_period_s: s.
        walking_runs: (start, stop) samples of the walking spans used (turns left out).
        turns: the turns found in the pelvis sensor's yaw rate (:mod:`sspinn.imu.turns`).
        notes: how the calibration went (for the report).
        warnings: what the user must check (uncertain signs here; :mod:`sspinn.imu.cross_sensor_checks`
            adds upside-down sensors and legs mixed up in the map, ``sspinn import`` the readers'
            and the GRF file's warnings); ``sspinn import`` prints them.
    """

    sensors: dict[str, SensorCalibration]
    rate_hz: float
    standing: tuple[int, int] | None
    walking_s: float
    stride_period_s: float
    notes: list[str] = field(default_factory=list)
    walking_runs: list[tuple[int, int]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    turns: list[Turn] = field(default_factory=list)

    def uncertain_signs(self) -> list[str]:
        return [s for s, c in self.sensors.items() if c.sign_margin < SIGN_MARGIN_WARN]


# ---------------------------------------------------------------------------------- gait context
def moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean of ``x`` over ``n`` samples (clipped to 1…len(x); same length)."""
    n = max(1, min(n, len(x)))
    return np.convolve(x, np.ones(n) / n, mode="same")


def detect_standing(gyr: list[np.ndarray], rate_hz: float) -> tuple[int, int] | None:
    """(start, stop) samples of the longest quiet-standing span (module docstring), trimmed by
    0.05 s at each end, or None."""
    still = np.ones(len(gyr[0]), dtype=bool)
    for g in gyr:
        still &= moving_mean(np.linalg.norm(g, axis=1), int(0.1 * rate_hz)) < STANDING_GYRO_RAD_S
    runs = [(a, b) for a, b in true_runs(still) if b - a >= MIN_STANDING_S * rate_hz]
    if not runs:
        return None
    a, b = max(runs, key=lambda r: r[1] - r[0])
    trim = int(0.05 * rate_hz)
    return a + trim, b - trim


def detect_walking(gyr: list[np.ndarray], rate_hz: float) -> np.ndarray:
    """Samples in 1 s windows whose largest angular-rate RMS over the sensors exceeds
    :data:`WALKING_GYRO_RMS_RAD_S`."""
    window = int(rate_hz)
    rms = np.max([np.sqrt(moving_mean(np.sum(g**2, axis=1), window)) for g in gyr], axis=0)
    return rms > WALKING_GYRO_RMS_RAD_S


def _autocorr(x: np.ndarray) -> np.ndarray:
    x = x - x.mean()
    f = np.fft.rfft(x, 2 * len(x))
    r = np.fft.irfft(f * np.conj(f))[: len(x)]
    return r / r[0] if r[0] > 0 else r


def stride_period(signal: np.ndarray, rate_hz: float, step: bool = False) -> float:
    """Stride period (s) from the autocorrelation peak of a leg signal in 0.6–2.5 s, or twice the
    step period (peak in 0.3–1.25 s) of a trunk signal when ``step``."""
    lo, hi = (0.3, 1.25) if step else (0.6, 2.5)
    r = _autocorr(signal)
    a, b = int(lo * rate_hz), min(int(hi * rate_hz), len(r) - 1)
    if b <= a + 2:
        raise SensorCalibrationError(f"walking too short to find the stride period ({len(signal) / rate_hz:.1f} s)")
    k = a + int(np.argmax(r[a:b]))
    return (2.0 if step else 1.0) * k / rate_hz


# ---------------------------------------------------------------------------------- features
def harmonic_phase(ax: np.ndarray, ay: np.ndarray, rate_hz: float, freq_hz: float, runs: list[tuple[int, int]],
                   window_s: float) -> float:
    """sin of the phase lead of ``ax`` over ``ay`` at ``freq_hz``: Im(Σ X·conj(Y)) / √(Σ|X|² Σ|Y|²)
    over Hann windows of ``window_s`` (half overlap) inside the walking ``runs``."""
    sxy, sxx, syy = cross_spectrum(ax[:, None], ay, rate_hz, freq_hz, runs, window_s)
    return float(np.imag(sxy[0]) / np.sqrt(sxx[0] * syy)) if sxx[0] > 0 and syy > 0 else 0.0


def anterior_direction(acc: np.ndarray, up: np.ndarray, rate_hz: float, freq_hz: float, runs: list[tuple[int, int]],
                       window_s: float) -> np.ndarray:
    """The horizontal direction (unit, ⟂ ``up``, sensor frame) whose specific force leads the
    vertical one by the largest quarter-cycle component at ``freq_hz`` (the step frequency):
    the walking direction of a trunk sensor (braking after heel strike, when the vertical force
    peaks; propulsion before the next)."""
    sab, _, _ = cross_spectrum(acc, acc @ up, rate_hz, freq_hz, runs, window_s)
    lead = np.imag(sab)
    return _unit(lead - (lead @ up) * up)


def _high_passed_integral(rate: np.ndarray, runs: list[tuple[int, int]], rate_hz: float) -> np.ndarray:
    sos = butter(2, 0.3, btype="high", fs=rate_hz, output="sos")
    parts = [sosfiltfilt(sos, np.cumsum(rate[a:b]) / rate_hz) for a, b in runs if b - a > 3 * rate_hz]
    return np.concatenate(parts) if parts else np.zeros(1)


def _vote(x: float) -> float:
    return float(np.tanh(x / VOTE_SCALE))


# ---------------------------------------------------------------------------------- calibration
def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _plane_basis(normal: np.ndarray) -> np.ndarray:
    """(3, 2) orthonormal basis of the plane perpendicular to the unit vector ``normal``."""
    return np.linalg.svd(np.eye(3) - np.outer(normal, normal))[0][:, :2]


def _top_eigenvector(m: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, float]:
    """The unit vector perpendicular to ``up`` maximising vᵀ·m·v, and that maximum."""
    basis = _plane_basis(up)
    w, v = np.linalg.eigh(basis.T @ ((m + m.T) / 2) @ basis)
    return _unit(basis @ v[:, int(np.argmax(w))]), float(w.max())


def _rotate_about(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    return v * np.cos(angle) + np.cross(axis, v) * np.sin(angle) + axis * (axis @ v) * (1 - np.cos(angle))


@dataclass
class _Raw:
    a: SensorAssignment
    acc: np.ndarray
    gyr: np.ndarray
    bias: np.ndarray
    up: np.ndarray
    axis: np.ndarray
    tilt: float
    method: str


def calibrate(
    signals: dict[str, tuple[np.ndarray, np.ndarray]],
    assignments: dict[str, SensorAssignment],
    rate_hz: float = 100.0,
    standing: str | tuple[int, int] | None = "auto",
    source: str = "<stream>",
    walking_angles: str = "joints",
) -> Calibration:
    """Calibrate every sensor (module docstring).

    Args:
        signals: segment → (acc (n, 3) m/s², gyr (n, 3) rad/s) in the sensor frame, one grid.
        assignments: segment → its :class:`SensorAssignment` (names and hints).
        rate_hz: sample rate, Hz.
        standing: ``"auto"`` (:func:`detect_standing`), a (start, stop) sample span, or None
            (calibrate from walking alone).
        source: the files, for messages.
        walking_angles: without standing, the in-plane angles from ``"joints"`` (thigh and shank:
            joint centres; foot: its mid-stance rests; :mod:`sspinn.imu.joint_centres`; the
            typical walking orientation where those fail) or ``"typical"`` (every segment's
            typical walking orientation, :data:`WALKING_MEAN_FORCE_ANGLE_DEG`).
    """
    if walking_angles not in ("joints", "typical"):
        raise ValueError(f"walking_angles must be 'joints' or 'typical', got {walking_angles!r}")
    segments = list(signals)
    gyr_all = [signals[s][1] for s in segments]
    notes: list[str] = []
    span = detect_standing(gyr_all, rate_hz) if standing == "auto" else standing
    if span is not None:
        notes.append(f"quiet standing {span[0] / rate_hz:.2f}–{span[1] / rate_hz:.2f} s: gravity gives the in-plane angle, "
                     "its mean rate the gyroscope bias")
    elif walking_angles == "joints":
        notes.append("no quiet standing: in-plane angles of thighs and shanks from the joint centres fitted while walking, "
                     "of feet from their mid-stance rests, of the others from the mean specific force while walking and the "
                     f"typical walking orientation of each segment ({WALKING_MEAN_FORCE_ANGLE_DEG} deg)")
    else:
        notes.append("no quiet standing: in-plane angles from the mean specific force while walking and the typical walking "
                     f"orientation of each segment ({WALKING_MEAN_FORCE_ANGLE_DEG} deg)")
    walking = detect_walking(gyr_all, rate_hz)
    if span is not None:
        walking[span[0]:span[1]] = False
    runs = [r for r in true_runs(walking) if r[1] - r[0] >= 2 * rate_hz]
    walking_s = sum(b - a for a, b in runs) / rate_hz
    if walking_s < MIN_WALKING_S:
        raise SensorCalibrationError(f"{source}: {walking_s:.1f} s of walking found (angular-rate RMS above "
                                     f"{WALKING_GYRO_RMS_RAD_S} rad/s); calibration needs at least {MIN_WALKING_S:g} s")
    longest = max(runs, key=lambda r: r[1] - r[0])
    legs = [s for s in segments if not s.startswith("pelvis")]
    if legs:
        lead = max(legs, key=lambda s: float(np.var(np.linalg.norm(signals[s][1][longest[0]:longest[1]], axis=1))))
        period = stride_period(np.linalg.norm(signals[lead][1][longest[0]:longest[1]], axis=1), rate_hz)
    else:
        period = stride_period(np.linalg.norm(signals[segments[0]][0][longest[0]:longest[1]], axis=1), rate_hz, step=True)
    turns = _turns(signals, assignments, span, walking, rate_hz, period)
    if turns:  # turning is not sagittal walking: left out of every walking-based step below
        for t in turns:
            walking[t.start:t.stop] = False
        runs = [r for r in true_runs(walking) if r[1] - r[0] >= 2 * rate_hz]
        walking_s = sum(b - a for a, b in runs) / rate_hz
        if walking_s < MIN_WALKING_S:
            raise SensorCalibrationError(f"{source}: {walking_s:.1f} s of straight walking found once the turns "
                                         f"({', '.join(t.describe(rate_hz) for t in turns)}) are left out; calibration needs at "
                                         f"least {MIN_WALKING_S:g} s")
    notes.append(f"{walking_s:.1f} s of walking, stride period {period:.2f} s")
    mask = np.zeros(len(walking), dtype=bool)
    for a, b in runs:
        mask[a:b] = True
    window = min(max(4 * period, 2.0), max(b - a for a, b in runs) / rate_hz)

    raw: dict[str, _Raw] = {}
    for seg in segments:
        acc, gyr = signals[seg]
        a = assignments[seg]
        bias = gyr[span[0]:span[1]].mean(axis=0) if span is not None else np.zeros(3)
        up = _unit(acc[span[0]:span[1]].mean(axis=0) if span is not None else acc[mask].mean(axis=0))
        g = gyr[mask] - bias
        if a.kind == "pelvis":
            forward = anterior_direction(acc, up, rate_hz, 2 / period, runs, window)
            axis, method = _unit(np.cross(forward, up)), "anterior × up; anterior: horizontal force leading the vertical at 2/T"
            h = int(round(period / 2 * rate_hz))
            lagged = sum((gyr[ra + h:rb] - bias).T @ (gyr[ra:rb - h] - bias) for ra, rb in runs)
            check = _top_eigenvector(lagged, up)[0]  # the step-symmetric rotation axis
        else:
            (axis, _), method = _top_eigenvector(g.T @ g, up), "principal axis of the angular rate, ⟂ gravity"
            w, v = np.linalg.eigh(g.T @ g)
            check = v[:, int(np.argmax(w))]  # the unconstrained principal axis
        tilt = float(np.degrees(np.arccos(min(1.0, abs(check @ axis)))))
        raw[seg] = _Raw(a, acc, gyr, bias, up, axis, tilt, method)

    signs, votes, margins, how = _choose_signs(raw, mask, runs, rate_hz, period, window)
    from_walking = _axes_from_walking(raw, signs, mask, rate_hz) if span is None and walking_angles == "joints" else {}
    out: dict[str, SensorCalibration] = {}
    for seg, r in raw.items():
        z = signs[seg] * r.axis
        f = _unit(r.up - (r.up @ z) * z)
        if span is not None:
            y, angle_method = f, "gravity in quiet standing (standing = zero pose)"
        elif seg in from_walking:
            y, angle_method = from_walking[seg]
        else:
            theta = np.radians(WALKING_MEAN_FORCE_ANGLE_DEG[r.a.kind])
            y = _unit(np.cos(theta) * f + np.sin(theta) * np.cross(z, f))
            angle_method = f"mean specific force while walking, typical {r.a.kind} value {np.degrees(theta):+.1f} deg"
        x = np.cross(y, z)
        rotation = np.vstack([x, y, z])
        axes = np.vstack([np.eye(3), -np.eye(3)])[[0, 3, 1, 4, 2, 5]]
        k = int(np.argmax(axes @ y))
        ref = _unit(axes[k] - (axes[k] @ z) * z)
        angle = float(np.degrees(np.arctan2(np.cross(y, ref) @ z, y @ ref)))
        g = r.gyr[mask] - r.bias
        oop = float(1.0 - np.sum((g @ z) ** 2) / np.sum(g**2))
        _check_up_axis(r, span, mask, source)
        norm = float(np.linalg.norm(r.acc[span[0]:span[1]].mean(axis=0))) if span is not None else None
        gain = GRAVITY / norm if norm is not None and abs(norm / GRAVITY - 1) > ACC_GAIN_TOLERANCE else 1.0
        out[seg] = SensorCalibration(
            r.a.sensor, seg, rotation, r.bias, oop, r.tilt, angle, _AXIS_NAMES[k], r.method, how[seg], angle_method,
            votes[seg], margins[seg], norm, gain,
        )
    cal = Calibration(out, rate_hz, span, walking_s, period, notes, runs, turns=turns)
    for t in turns:
        cal.warnings.append(f"turning at {t.describe(rate_hz)}: left out of the calibration; a sagittal model does not "
                            "describe a turn, so the estimate there is not one of the gait (see the recording's turning_s)")
    for seg in cal.uncertain_signs():
        cal.warnings.append(f"sensor {out[seg].sensor!r} ({seg}): the medio-lateral sign is uncertain "
                            f"(margin {out[seg].sign_margin:.2f}); give right_axis in the sensor map")
    for seg, c in out.items():
        if c.acc_gain != 1.0:
            cal.warnings.append(f"sensor {c.sensor!r} ({seg}): |specific force| {c.standing_acc_norm:.2f} m/s² in quiet standing, "
                                f"not g: accelerometer scaled by {c.acc_gain:.3f}; check or recalibrate the sensor")
    return cal


#: The joints the walking-only in-plane angles use (:mod:`sspinn.imu.joint_centres`): name →
#: (proximal segment kind, distal segment kind).
_JOINTS: Final = {"hip": ("pelvis", "femur"), "knee": ("femur", "tibia"), "ankle": ("tibia", "foot")}
#: The joint at each segment frame's origin: the proximal one.
_JOINT_AT_ORIGIN: Final = {distal: joint for joint, (_, distal) in _JOINTS.items()}


def _turns(signals: dict[str, tuple[np.ndarray, np.ndarray]], assignments: dict[str, SensorAssignment],
           span: tuple[int, int] | None, walking: np.ndarray, rate_hz: float, period: float) -> list[Turn]:
    """The turns (:func:`sspinn.imu.turns.detect_turns`) in the pelvis sensor's rate, its up
    direction and gyroscope bias from quiet standing, or from the mean specific force while
    walking without one; none without a pelvis sensor."""
    pelvis = next((seg for seg in signals if assignments[seg].kind == "pelvis"), None)
    if pelvis is None:
        return []
    acc, gyr = signals[pelvis]
    if span is not None:
        up, bias = acc[span[0]:span[1]].mean(axis=0), gyr[span[0]:span[1]].mean(axis=0)
    else:
        up, bias = acc[walking].mean(axis=0), np.zeros(3)
    return detect_turns(gyr - bias, up, rate_hz, period)


def _joint_guess(kind: str, segment: str, joint: str) -> np.ndarray:
    """Position (2,) m of ``joint`` relative to the typical sensor position on ``segment`` (a
    1.75 m body; the start of the joint-centre fit)."""
    sensor = np.array(IMUPlacement.default(1.75).positions[segment])
    if kind == "pelvis" or joint == _JOINT_AT_ORIGIN[kind]:
        return -sensor  # segment frames have their origin at the proximal joint (the HAT's: the hip)
    return np.array([0.0, -WINTER[kind][1] * 1.75]) - sensor



def _axes_from_walking(raw: dict[str, _Raw], signs: dict[str, int], mask: np.ndarray, rate_hz: float) -> dict[str, tuple[np.ndarray, str]]:
    """The segment y axis (3,) in the sensor frame and how it was found, for the thigh and shank
    sensors whose joint centres fit and the foot sensors that rest flat in mid-stance
    (:mod:`sspinn.imu.joint_centres`); the others are left to the typical walking orientation."""
    planes, signals = {}, {}
    for seg, r in raw.items():
        z = signs[seg] * r.axis
        y0 = _unit(r.up - (r.up @ z) * z)
        planes[seg] = (np.cross(y0, z), y0)
        signals[seg] = joint_centres.plane_signals(r.acc, r.gyr - r.bias, planes[seg][0], y0, z, rate_hz)
    walking = {seg: tuple(v[mask] for v in sig) for seg, sig in signals.items()}
    out: dict[str, tuple[np.ndarray, str]] = {}
    for side in "rl":
        seg = {kind: (kind if kind == "pelvis" else f"{kind}_{side}") for kind in ("pelvis", "femur", "tibia", "foot")}
        fits: dict[str, joint_centres.JointFit | None] = {}
        for joint, (a, b) in _JOINTS.items():
            if seg[a] in raw and seg[b] in raw:
                fits[joint] = joint_centres.joint_centre(walking[seg[a]], walking[seg[b]], _joint_guess(a, seg[a], joint),
                                                         _joint_guess(b, seg[b], joint))
        for kind, (top, bottom) in (("femur", ("hip", "knee")), ("tibia", ("knee", "ankle"))):
            if seg[kind] not in raw:
                continue
            axis = joint_centres.segment_axis(fits.get(top), fits.get(bottom), "b", "a")
            if axis is not None:
                x0, y0 = planes[seg[kind]]
                out[seg[kind]] = (_unit(axis[0] * x0 + axis[1] * y0), f"the line from the {bottom} to the {top} centre (joint centres fitted while walking)")
        if seg["foot"] in raw:
            f, omega, _ = signals[seg["foot"]]
            up = joint_centres.foot_flat_up(f, omega, rate_hz, mask)
            if up is not None:
                x0, y0 = planes[seg["foot"]]
                out[seg["foot"]] = (_unit(up[0] * x0 + up[1] * y0), "gravity while the foot rests flat in mid-stance")
    return out


def _check_up_axis(r: _Raw, span: tuple[int, int] | None, mask: np.ndarray, source: str) -> None:
    if r.a.up_axis is None:
        return
    acc = r.acc[span[0]:span[1]] if span is not None else r.acc[mask]
    reading = float(np.mean(acc @ r.a.up_axis))
    where = "in quiet standing" if span is not None else "on average while walking"
    if reading < -0.5 * GRAVITY:
        raise SensorCalibrationError(
            f"{source}, sensor {r.a.sensor!r} ({r.a.segment}): mounted upside down: its up_axis reads {reading:.3g} m/s² of gravity "
            f"{where}, but an axis pointing up the segment reads about +{GRAVITY} m/s²; remount it or fix up_axis in the sensor map"
        )


def _choose_signs(raw: dict[str, _Raw], mask: np.ndarray, runs: list[tuple[int, int]], rate_hz: float, period: float,
                  window: float) -> tuple[dict[str, int], dict[str, dict[str, float]], dict[str, float], dict[str, str]]:
    """Signs of the axes (+1 keeps the axis as found): hints, else the votes of the module docstring."""
    omega, ax, ay = {}, {}, {}
    for seg, r in raw.items():
        y = _unit(r.up - (r.up @ r.axis) * r.axis)
        x = np.cross(y, r.axis)
        omega[seg], ax[seg], ay[seg] = (r.gyr - r.bias) @ r.axis, r.acc @ x, r.acc @ y
    votes: dict[str, dict[str, float]] = {}
    for seg, r in raw.items():
        v: dict[str, float] = {}
        if r.a.kind in ("pelvis", "femur"):
            v["step phase"] = _vote(harmonic_phase(ax[seg], ay[seg], rate_hz, 2 / period, runs, window))
        if r.a.kind in ("femur", "tibia"):
            v["rate skewness"] = _vote(float(skew(omega[seg][mask])))
        if r.a.kind == "foot":
            v["stride phase"] = _vote(harmonic_phase(ax[seg], ay[seg], rate_hz, 1 / period, runs, window))
        votes[seg] = v
    groups = [[s for s in raw if s == "pelvis"]] + [[s for s in raw if s.endswith(f"_{side}")] for side in "rl"]
    signs: dict[str, int] = {}
    margins: dict[str, float] = {}
    how: dict[str, str] = {}
    for group in (g for g in groups if g):
        fixed = {s: int(np.sign(raw[s].a.right_axis @ raw[s].axis) or 1) for s in group if raw[s].a.right_axis is not None}
        pairs = _pairs(group)

        def score(combo: dict[str, int], group: list[str] = group, pairs: dict = pairs) -> float:
            own = sum(combo[s] * sum(votes[s].values()) for s in group)
            return own + sum(_pair_votes(combo, pairs, omega, mask, runs, rate_hz).values())

        combos = [dict(zip(group, c)) for c in product((1, -1), repeat=len(group))]
        scores = {tuple(c.values()): score(c) for c in combos}
        allowed = [c for c in combos if all(c[s] == v for s, v in fixed.items())]
        best = max(allowed, key=lambda c: scores[tuple(c.values())])
        data_best = max(combos, key=lambda c: scores[tuple(c.values())])
        best_score = scores[tuple(best.values())]
        for s in group:
            signs[s] = best[s]
            flipped = [scores[tuple(c.values())] for c in allowed if c[s] != best[s]]
            margins[s] = float(best_score - max(flipped)) if flipped else float("inf")
            if s in fixed:
                how[s] = f"right_axis hint of the sensor map (the gait votes {'agree' if data_best[s] == best[s] else 'DISAGREE'})"
            else:
                how[s] = "gait votes" + (f" with {', '.join(o for o in group if o != s)}" if len(group) > 1 else "")
            votes[s] = {k: best[s] * val for k, val in votes[s].items()}
        for (a, b, name), value in _pair_votes(best, pairs, omega, mask, runs, rate_hz).items():
            votes[a][name] = votes[b][name] = value
    return signs, votes, margins, how


def _pairs(group: list[str]) -> dict[str, str]:
    """The femur, tibia and foot of one leg's group that are present (kind → segment)."""
    return {k: s for k in ("femur", "tibia", "foot") for s in group if s.startswith(k)}


def _pair_votes(combo: dict[str, int], leg: dict[str, str], omega: dict[str, np.ndarray], mask: np.ndarray,
                runs: list[tuple[int, int]], rate_hz: float) -> dict[tuple[str, str, str], float]:
    """Votes of sensor pairs of one leg for the signs ``combo``: shank and foot rates correlate
    positively; the knee angle (∫ shank − thigh rate, high-passed) is skewed negative."""
    out = {}
    if "tibia" in leg and "foot" in leg:
        t, f = leg["tibia"], leg["foot"]
        corr = float(np.corrcoef(omega[t][mask], omega[f][mask])[0, 1])
        out[(t, f, "shank-foot rate correlation")] = combo[t] * combo[f] * _vote(corr)
    if "femur" in leg and "tibia" in leg:
        t, th = leg["tibia"], leg["femur"]
        knee = _high_passed_integral(combo[t] * omega[t] - combo[th] * omega[th], runs, rate_hz)
        out[(th, t, "knee angle skewness")] = -_vote(float(skew(knee)))
    return out
