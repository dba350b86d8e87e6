"""Signal-level physics checks of a 2D recording (acc_x, acc_y, gyr_z per segment at 100 Hz) that
need no labels, of its GRF labels and of an estimate: the one module every path into the
estimator calls (a recording CSV + sidecar, a dataset folder, an averaged stride, a CSV read with
a column map, ``sspinn import``, and :meth:`SSPINNpose.fit` / ``predict``).

:mod:`sspinn.data.plausibility` refuses what no working sensor gives (units, ranges, constant or
clipped channels); this module judges whether working sensors are *where and how* the recording
says: signs, axes, sides, the sample rate. Findings are :class:`SignalWarning` s (the CLIs print
them as ``WARNING: ...``) naming the source, the sensor and the number; only what is physically
impossible is an error (:class:`ImpossibleSignalError`).

Per sensor (every recording of ≥ 10 samples):

* **Gravity direction** — the mean specific force of a sensor points along its segment's long axis
  rotated by the placement angle (standing, walking and running keep the segments within ≈ 30° of
  upright on average; the mean over a recording is gravity plus centripetal terms along the
  segment). The angle between the measured mean direction and the stated placement angle above
  :data:`GRAVITY_ANGLE_WARN_DEG` is a warning (an accelerometer axis negated, x/y swapped, a
  sensor mounted or declared at another angle, ``angle_rad`` given in degrees). Gravity pointing
  more than :data:`GRAVITY_ANGLE_ERROR_DEG` away on *every* sensor is an error (accelerometers
  negated: acceleration instead of specific force).

Gait checks (recordings of ≥ :data:`MIN_GAIT_S` with a periodic leg movement, :func:`gait_rhythm`):

* **Cadence at the stated rate** — the stride period is the lag of the strongest peak of the
  leg gyroscopes' autocorrelation. Steps per second outside :data:`CADENCE_STEPS_HZ` (slow walking
  ≈ 0.7 to fast running ≈ 3.3 steps/s; a sprint at 4–5 steps/s would be warned about too) at
  100 Hz mean the stated rate is wrong (a 10 Hz or 1 kHz recording stamped as 100 Hz); the
  message names the rate that would give a typical cadence. More than ten times outside the band
  is an error. A mislabel by less than ≈ 2× (60 Hz as 100 Hz) moves walking into the running range
  and is *not* detectable from the cadence.
* **Dead but noisy / not on a moving body** — while the legs walk, a sensor whose angular rate
  has the flat spectrum of noise (correlation between neighbouring samples below
  :data:`MIN_SMOOTHNESS`) or, on a leg, does not repeat with the stride (normalised
  autocorrelation at the stride period below :data:`MIN_PERIODICITY`; the pelvis's sagittal
  rate is too small and irregular in running for that): a noise-only gyroscope, or a sensor
  lying on a table (then its rate is also below :data:`STILL_GYRO_RMS_RAD_S`).
* **Leg pairing** (:func:`leg_phase_findings`, also used by ``sspinn import``): the thigh, shank and
  foot of one leg swing nearly in phase, the two legs half a stride apart; a stride-frequency
  phase more than 90° from :data:`LEG_PHASE_DEG` means a sensor of another leg (a left/right
  swap of one segment) or a negated gyroscope on one sensor.
* **Gyroscope sign** — the knee angle (shank minus thigh rate, integrated and high-passed) is
  skewed towards flexion in any gait (knee flexion is negative here, and the knee is near
  extension most of the stride): skewness above :data:`KNEE_SKEW_WARN` on every side with a thigh
  and a shank means the gyroscopes are negated (the twelve CMU trials: −1.3…−0.5; predicted
  walking and running: −0.6…+0.1).
* **Joint constraints** (:func:`joint_stats`, :func:`joint_findings`): two sensors on segments
  joined at a hip, knee or ankle must agree on the joint's specific force once each is carried to
  the joint (tangential and centripetal terms from the gyroscope, the frames turned by the
  integrated difference of the two gyroscopes; the sensor positions and the frames' offset are
  fitted per 3 s window, so no placement is assumed). This ties the time base to the gyroscopes
  and accelerometers: the speed-up of the motion that fits the joints best must lie within
  :data:`JOINT_RATE_OK` (a recording at 60 Hz or 200 Hz stamped as 100 Hz, which the cadence
  cannot tell: the message names the likely rate); a sensor whose joints fit better with acc_x
  negated (gain above :data:`JOINT_MIRROR_WARN`) has a mirrored acc_x — what a negated 3D
  gyroscope or two swapped accelerometer axes become after ``sspinn import``'s calibration; a leg
  sensor whose joints fit best with its gyr_z scaled outside :data:`JOINT_SCALE_OK` has a
  mis-scaled gyroscope (× 0.5). Margins measured by ``benchmarks/accuracy/joint_check_margins.py`` are given
  at the thresholds.
* **Scale, bias, legs in phase** (:func:`scale_and_bias_findings`, :func:`cross_leg_findings`):
  the pelvis accelerometer's 1 s mean specific force outside :data:`ACC_SCALE_RANGE` g (a scaled
  accelerometer), a mean gyr_z beyond :data:`GYRO_BIAS_ALL_RAD_S` on every sensor or
  :data:`GYRO_BIAS_ONE_RAD_S` on one (a bias), and the two legs' thighs, shanks or feet in phase
  instead of half a stride apart (one leg's sensors turned 180° about their long axis).
* **Speed label** (:func:`speed_label_findings`): the stride a ``speed`` label gives with the
  IMU's stride period against Alexander's (:data:`SPEED_LABEL_STRIDE_RANGE`).
* Not detectable without labels and thus not claimed: swapping *all* sensors of the two legs (the
  sagittal signals are the same up to half a stride; ``sspinn import`` judges it from the
  medio-lateral force, and GRF labels from the stance, below), and thigh/shank swaps that keep
  the phases within 90°.

GRF labels (:func:`label_findings`; ``sspinn import --grf`` and a labelled dataset): vertical force
≥ −:data:`NEGATIVE_GRF_TOLERANCE_BW` body weights (noise), the mean summed vertical force over the
recording within :data:`LABEL_MEAN_BW_RANGE` of body weight when both feet are labelled, the
stride period of the vertical force equal to the IMU's (a time unit or rate of the labels), and
the labelled stance of each foot when its sensor is still (left/right labels swapped).

Estimates (:func:`estimate_findings`): the mean vertical GRF over whole strides below
:data:`MIN_MEAN_VERTICAL_BW` of body weight, and a stride length (speed / stride frequency)
outside a factor :data:`STRIDE_LENGTH_FACTOR` of Alexander's relation λ/h = 2.3 (v²/(g h))^0.3
(R. McN. Alexander, "The gaits of bipedal and quadrupedal animals", Int J Robotics Res 3(2):49–59,
1984; h the leg length, 0.53 × height after Winter).
"""

from __future__ import annotations

import warnings
import weakref
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from itertools import combinations
from typing import TYPE_CHECKING, Final

import numpy as np
from scipy.signal import butter, sosfiltfilt
from scipy.stats import skew

from sspinn.errors import DataFormatError, InputWarning
from sspinn.model.conventions import GRAVITY

if TYPE_CHECKING:  # dataset.py calls this module
    from sspinn.data.dataset import Recording

#: Sample rate of a recording, Hz.
RATE_HZ: Final = 100.0
#: Mean specific force more than this far from the stated placement angle: a warning, deg.
GRAVITY_ANGLE_WARN_DEG: Final = 60.0
#: Mean specific force more than this far from the placement angle on every sensor: an error, deg.
GRAVITY_ANGLE_ERROR_DEG: Final = 120.0
#: Shortest recording the gait checks judge, s (four slow strides).
MIN_GAIT_S: Final = 5.0
#: Largest normalised autocorrelation of the leg rates at the stride lag below which there is no gait.
MIN_GAIT_PERIODICITY: Final = 0.3
#: RMS angular rate of the most moving leg sensor below which the subject does not walk, rad/s.
MIN_GAIT_GYRO_RMS: Final = 0.5
#: Plausible steps per second at the stated rate (slow walking to sprinting).
CADENCE_STEPS_HZ: Final = (0.5, 3.5)
#: A sensor whose rate's normalised autocorrelation at the stride period is below this does not move with the gait.
MIN_PERIODICITY: Final = 0.2
#: A rate whose correlation between neighbouring samples (10 ms) is below this has the flat
#: spectrum of sensor noise (body rates are smooth at 100 Hz: above 0.85 on every sensor of the
#: CMU and predicted recordings).
MIN_SMOOTHNESS: Final = 0.5
#: Below this RMS angular rate a sensor lies still, rad/s.
STILL_GYRO_RMS_RAD_S: Final = 0.05
#: Expected phase lead (deg) at the stride frequency of the first segment's sagittal rate over
#: the second's, within one leg (measured on the twelve CMU trials: +3…+83°, +4…+22°, +57…+104°;
#: a predicted 1.3 m/s gait: +41°, +12°, +53°); more than 90° off is flagged.
LEG_PHASE_DEG: Final[dict[tuple[str, str], float]] = {("femur", "tibia"): 45.0, ("tibia", "foot"): 15.0, ("femur", "foot"): 65.0}
#: Pairs whose coherence at the stride frequency is below this are not judged.
MIN_COHERENCE: Final = 0.5
#: Knee-angle skewness above which the gyroscopes look negated.
KNEE_SKEW_WARN: Final = 0.5
#: Vertical GRF label tolerated below zero, body weights.
NEGATIVE_GRF_TOLERANCE_BW: Final = 0.1
#: Accepted mean summed vertical GRF (labels, or a GRF file on import) over a recording, body
#: weights (:func:`mean_vertical_force_findings`). The twelve CMU trials: 0.95–1.00.
LABEL_MEAN_BW_RANGE: Final = (0.85, 1.15)
#: Outside this range the force is not in newtons (or not vertical, or not both feet): impossible.
MEAN_VERTICAL_BW_PLAUSIBLE: Final = (0.5, 2.0)
#: Units a vertical force may be in instead of newtons: name → newtons per unit.
_FORCE_UNITS: Final = {"kN": 1000.0, "mN": 1e-3, "kgf (kilograms)": GRAVITY}
#: Label and IMU stride periods differing by more than this fraction: a warning.
PERIOD_MISMATCH: Final = 0.2
#: Mean estimated vertical GRF below this fraction of body weight: a warning.
MIN_MEAN_VERTICAL_BW: Final = 0.7
#: Accepted factor between the estimated stride length and Alexander's relation.
STRIDE_LENGTH_FACTOR: Final = 2.0
#: Leg length / body height (Winter).
LEG_PER_HEIGHT: Final = 0.53
#: Accepted ratio of a speed label's stride (mean speed × the IMU's stride period) to Alexander's
#: stride at that speed. Measured untouched: 0.81–1.12 on the 12 CMU treadmill trials and 60 of
#: their 20 s excerpts, 1.15 on the predicted 1.3 m/s walk, 1.06 on the semi-real running. The
#: ratio grows as v^0.4, so a label × 3.6 (km/h as m/s) gives ≥ 1.35, × 10 ≥ 2.0.
SPEED_LABEL_STRIDE_RANGE: Final = (0.7, 1.33)
#: Joint constraints (:func:`joint_stats`): low-pass before the fit, Hz; window, s; longest stretch judged, s.
JOINT_LOWPASS_HZ: Final = 8.0
JOINT_WINDOW_S: Final = 3.0
JOINT_MAX_S: Final = 60.0
#: Time-base factors and gyroscope scales searched.
JOINT_FACTOR_RANGE: Final = (0.3, 3.0)
JOINT_SCALE_RANGE: Final = (0.3, 3.0)
#: Best-fitting time-base factor accepted as the stated rate. Measured (``benchmarks/accuracy/joint_check_margins.py``):
#: untouched 0.883–1.082 on the twelve CMU trials and their 20 s excerpts, 0.870–1.049 on the 40
#: predicted recordings, the averaged stride, the predicted walk and the semi-real running; with the
#: motion × 0.4–0.8 or × 1.25–2 the estimate is 0.76–1.07 × the true factor, so mislabels near × 0.8
#: and × 1.25 are caught only in part (see ``docs/bad_input.md``).
JOINT_RATE_OK: Final = (0.85, 1.12)
#: Best-fitting gyroscope scale accepted per segment kind. Measured untouched: femur 0.59–1.49 (CMU;
#: soft tissue and the hip fit), tibia 0.75–1.07, foot 0.82–1.38; with gyr_z × 0.5 the estimate is
#: ≥ 1.22 (femur), ≥ 1.55 (tibia), ≥ 1.64 (foot). The pelvis turns too little to judge.
JOINT_SCALE_OK: Final[dict[str, tuple[float, float]]] = {"femur": (0.5, 1.6), "tibia": (0.6, 1.3), "foot": (0.65, 1.5)}
#: Residual gain with acc_x (or a leg sensor's gyr_z) negated above which a sensor looks mirrored.
#: Measured: untouched ≤ 0.79 with acc_x negated, ≤ 0.54 with a leg gyr_z negated (every sensor,
#: every recording above); acc_x negated ≥ 1.26 (pelvis), ≥ 1.78 (femur), ≥ 2.83 (tibia), ≥ 3.21 (foot).
JOINT_MIRROR_WARN: Final = 1.1
#: Gravity read by the pelvis accelerometer (median 1 s mean in-plane specific force, in g)
#: accepted. Measured: 1.00–1.03 on the 12 CMU trials (whole and 20 s excerpts), 1.002 on the
#: predicted 1.3 m/s walk, 1.012 on the semi-real running.
ACC_SCALE_RANGE: Final = (0.85, 1.15)
#: Mean gyr_z (rad/s) accepted while walking: measured on the same recordings ≤ 0.124 on one
#: sensor, ≤ 0.07 as the median over the sensors.
GYRO_BIAS_ALL_RAD_S: Final = 0.2
GYRO_BIAS_ONE_RAD_S: Final = 0.3
#: Stride-frequency phase between the right and left thighs, shanks and feet: measured 109°–180°
#: in magnitude on the same recordings (stiff-knee thighs the least).
CROSS_LEG_MIN_DEG: Final = 109.0
_KINDS: Final = ("femur", "tibia", "foot")


class SignalWarning(InputWarning):
    """A recording, its labels or an estimate that working sensors on the stated segments would
    hardly give; the message names the source, the sensor and the number."""


class ImpossibleSignalError(DataFormatError):
    """Signals no sensor on a human gives at the stated rate and orientation."""


@dataclass(frozen=True)
class GaitRhythm:
    """The stride of a recording's leg sensors: ``period_s`` (s, at the stated rate), the mean
    normalised autocorrelation at that lag of the leg rates (``periodicity``) and per segment."""

    period_s: float
    periodicity: float
    by_segment: dict[str, float]


def warn(findings: Iterable[str]) -> None:
    """Issue every finding as a :class:`SignalWarning`."""
    for text in findings:
        warnings.warn(text, SignalWarning, stacklevel=2)


#: IMU arrays already checked (by id; weak, so a freed array's id may be reused by a new one).
_CHECKED: weakref.WeakValueDictionary[int, np.ndarray] = weakref.WeakValueDictionary()


def check_recording(rec: Recording, source: str) -> None:
    """The checks of the module docstring on a :class:`~sspinn.data.dataset.Recording` (labels
    included): raise :class:`ImpossibleSignalError` or warn. Nothing is changed; a recording
    whose IMU array was checked already (read from a file, then given to ``predict``) is not
    checked again."""
    imu = rec.imu
    if _CHECKED.get(id(imu)) is imu:
        return
    findings = [*recording_findings(rec, source), *label_findings(rec, source)]
    _CHECKED[id(imu)] = imu
    warn(findings)


def recording_findings(rec: Recording, source: str, leg_pairing: bool = True, joints_judged: bool = True) -> list[str]:
    """Warnings about the IMU signals of ``rec`` (module docstring; without the leg pairing
    where the caller ran :func:`leg_phase_findings` itself, and then ``joints_judged=False`` where
    it found the legs mixed up); raises for the impossible."""
    imu, segments = rec.imu, tuple(rec.segments)
    if imu.shape[0] < 10:
        return []
    angles = rec.placement.angles
    found = _gravity_findings(imu, segments, angles, source)
    rhythm = gait_rhythm(imu, segments)
    if rhythm is None:
        return found
    cadence = _cadence_findings(rhythm, source)
    if cadence:  # at a wrong rate the other gait checks judge nonsense
        return found + cadence
    found += _periodicity_findings(imu, segments, rhythm, source)
    found += scale_and_bias_findings(imu, segments, source)
    found += cross_leg_findings(imu, segments, rhythm, source) if leg_pairing else []
    rates = {s: imu[:, i, 2] for i, s in enumerate(segments)} if leg_pairing else {}
    window = min(max(4 * rhythm.period_s, 2.0), imu.shape[0] / RATE_HZ)
    legs = []
    for side, bad in leg_phase_findings(rates, RATE_HZ, 1 / rhythm.period_s, [(0, imu.shape[0])], window).items():
        pairs = "; ".join(f"{a} leads {b} by {phase:+.0f}° (one leg: {expected:+.0f}° ± 90°)" for a, b, phase, expected in bad)
        legs.append(f"{source}: the {side}-leg sensors do not move like one leg (stride-frequency phase of their gyr_z: "
                    f"{pairs}): a sensor of the other leg (left/right columns swapped) or a negated gyroscope")
    legs += _knee_skew_findings(imu, segments, source)
    # sensors on another leg's segments or all gyroscopes negated break several joints at once: the joints are not judged then
    return found + (joint_findings(imu, segments, source) if joints_judged and not legs else []) + legs


def _gravity_findings(imu: np.ndarray, segments: tuple[str, ...], angles: dict[str, float], source: str) -> list[str]:
    off = {}
    for i, s in enumerate(segments):
        mx, my = imu[:, i, 0].mean(), imu[:, i, 1].mean()
        measured = float(np.degrees(np.arctan2(mx, my)))
        stated = float(np.degrees(angles.get(s, 0.0)))
        off[s] = (measured, stated, abs(_wrap_deg(measured - stated)), float(np.hypot(mx, my)))
    if len(off) > 1 and all(d > GRAVITY_ANGLE_ERROR_DEG for _, _, d, _ in off.values()):
        worst = ", ".join(f"{s} {m:+.0f}°" for s, (m, _, _, _) in off.items())
        raise ImpossibleSignalError(
            f"{source}: on every sensor the mean specific force points away from the segment's upward axis "
            f"(atan2(acc_x, acc_y): {worst}; upright ≈ the placement angle): the accelerometers are negated "
            "(acceleration instead of specific force, or an axis convention with y down): negate acc_x and acc_y")
    return [f"{source}: sensor {s}: the mean specific force (gravity) points {measured:+.0f}° from the sensor's y axis "
            f"(atan2(mean acc_x, mean acc_y), |mean| {norm:.1f} m/s²) but the placement angle says {stated:+.0f}°: "
            f"{d:.0f}° apart (> {GRAVITY_ANGLE_WARN_DEG:.0f}°): an accelerometer axis negated or acc_x/acc_y swapped, "
            "or the placement angle wrong (in rad, not degrees)"
            for s, (measured, stated, d, norm) in off.items() if d > GRAVITY_ANGLE_WARN_DEG]


def _autocorr(x: np.ndarray) -> np.ndarray:
    """Normalised (biased) autocorrelation of ``x`` minus its mean."""
    x = x - x.mean()
    f = np.fft.rfft(x, 2 * len(x))
    r = np.fft.irfft(f * np.conj(f))[: len(x)]
    return r / r[0] if r[0] > 0 else np.zeros(len(x))


def _unbiased_at(r: np.ndarray, lag: int) -> float:
    """The biased autocorrelation ``r`` at ``lag`` corrected for the overlap (n / (n − lag))."""
    return float(r[lag] * len(r) / (len(r) - lag)) if 0 < lag < len(r) else 0.0


def gait_rhythm(imu: np.ndarray, segments: tuple[str, ...], rate_hz: float = RATE_HZ) -> GaitRhythm | None:
    """The stride period of the leg sensors (the lag of the strongest autocorrelation peak of the
    summed autocorrelations of the leg rates, between 0.05 s and half the recording), or None for
    a recording shorter than :data:`MIN_GAIT_S` or without gait (the strongest leg rate below
    :data:`MIN_GAIT_GYRO_RMS`, or the mean periodicity below :data:`MIN_GAIT_PERIODICITY`)."""
    n = imu.shape[0]
    legs = [i for i, s in enumerate(segments) if s != "pelvis"]
    if n < MIN_GAIT_S * rate_hz or not legs or max(float(np.std(imu[:, i, 2])) for i in legs) < MIN_GAIT_GYRO_RMS:
        return None
    r = {segments[i]: _autocorr(imu[:, i, 2]) for i in legs}
    mean = np.mean(list(r.values()), axis=0)
    lo, hi = max(2, int(0.05 * rate_hz)), n // 2
    peaks = [k for k in range(lo, hi) if mean[k] > mean[k - 1] and mean[k] >= mean[k + 1] and mean[k] > 0]
    if not peaks:
        return None
    lag = max(peaks, key=lambda k: mean[k])
    # a stride's multiples are nearly as strong; the shortest lag within 10 % of the best is the stride
    lag = min(k for k in peaks if mean[k] >= 0.9 * mean[lag])
    by_segment = {s: _unbiased_at(v, lag) for s, v in r.items()}
    periodicity = float(np.mean(list(by_segment.values())))
    if periodicity < MIN_GAIT_PERIODICITY:
        return None
    for i, s in enumerate(segments):
        if s not in by_segment:  # the trunk repeats with every step
            r_s = _autocorr(imu[:, i, 2])
            by_segment[s] = max(_unbiased_at(r_s, lag), _unbiased_at(r_s, int(round(lag / 2))))
    return GaitRhythm(lag / rate_hz, periodicity, by_segment)


def _cadence_findings(rhythm: GaitRhythm, source: str) -> list[str]:
    steps = 2.0 / rhythm.period_s
    lo, hi = CADENCE_STEPS_HZ
    if lo <= steps <= hi:
        return []
    rate = RATE_HZ * 1.8 / steps  # the rate at which the cadence would be 1.8 steps/s (walking)
    if not lo / 10 <= steps <= hi * 10:
        raise ImpossibleSignalError(
            f"{source}: the legs repeat every {rhythm.period_s:.3g} s at the stated {RATE_HZ:g} Hz: {steps:.3g} steps/s, "
            f"more than ten times outside {lo:g}–{hi:g} steps/s of human gait: the sample rate is wrong (recorded at "
            f"≈ {rate:.3g} Hz?): resample to 100 Hz with the true rate")
    return [f"{source}: the legs repeat every {rhythm.period_s:.3g} s at the stated {RATE_HZ:g} Hz: {steps:.3g} steps/s, outside "
            f"{lo:g}–{hi:g} steps/s of human gait: the sample rate is likely wrong (recorded at ≈ {rate:.3g} Hz?): "
            "resample to 100 Hz with the true rate"]


def _periodicity_findings(imu: np.ndarray, segments: tuple[str, ...], rhythm: GaitRhythm, source: str) -> list[str]:
    found = []
    for i, s in enumerate(segments):
        p = rhythm.by_segment[s]
        smooth = _unbiased_at(_autocorr(imu[:, i, 2]), 1)
        if smooth >= MIN_SMOOTHNESS and (p >= MIN_PERIODICITY or s == "pelvis"):
            continue
        rms = float(np.std(imu[:, i, 2]))
        acc_rms = float(np.std(np.hypot(imu[:, i, 0], imu[:, i, 1])))
        if rms < STILL_GYRO_RMS_RAD_S:
            found.append(f"{source}: sensor {s} is not on a moving body: gyr_z RMS {rms:.3g} rad/s and |acc| RMS {acc_rms:.3g} m/s² "
                         f"while the legs walk with a {rhythm.period_s:.2f} s stride: a sensor lying still (on a table?)")
        else:
            why = (f"sample-to-sample correlation {smooth:.2f} < {MIN_SMOOTHNESS:g}: a flat rate spectrum, noise"
                   if smooth < MIN_SMOOTHNESS else f"autocorrelation {p:.2f} at that lag, < {MIN_PERIODICITY:g}")
            found.append(f"{source}: sensor {s}: gyr_z does not move with the {rhythm.period_s:.2f} s stride of the legs "
                         f"({why}; RMS {rms:.3g} rad/s): a dead but noisy gyroscope, or a sensor not on the body")
    return found


def scale_and_bias_findings(imu: np.ndarray, segments: tuple[str, ...], source: str) -> list[str]:
    """While the legs walk or run (the caller found a gait rhythm): the pelvis accelerometer's
    scale, the median over 1 s windows of its in-plane mean specific force (≈ g: gravity dominates
    a second's mean of a sensor that turns little), outside :data:`ACC_SCALE_RANGE`; and a
    gyroscope bias, the mean gyr_z over the recording (a segment's angle repeats with the stride,
    so its mean rate is ≈ 0), above :data:`GYRO_BIAS_ALL_RAD_S` on every sensor (median) or
    :data:`GYRO_BIAS_ONE_RAD_S` on one. The legs' sensors are not judged for scale: their rotation
    adds a centripetal mean (measured: thighs 1.55 g, shanks 1.6 g, feet 3 g on the semi-real
    running; shanks 1.13 g, feet 1.2 g on the predicted 1.3 m/s walk)."""
    found = []
    n = imu.shape[0] // int(RATE_HZ)
    if "pelvis" in segments and n >= 2:
        i = segments.index("pelvis")
        second = imu[: n * int(RATE_HZ), i, :2].reshape(n, int(RATE_HZ), 2).mean(axis=1)
        scale = float(np.median(np.hypot(second[:, 0], second[:, 1]))) / GRAVITY
        lo, hi = ACC_SCALE_RANGE
        if not lo <= scale <= hi:
            found.append(f"{source}: sensor pelvis: its accelerometer reads gravity as {scale:.2f} g (median 1 s mean specific "
                         f"force; untouched recordings {lo:g}–{hi:g} g): the accelerometer looks scaled by {scale:.2f} (a unit "
                         "or range setting? the other sensors likely too)")
    bias = imu[:, :, 2].mean(axis=0)
    typical = float(np.median(np.abs(bias)))
    if typical > GYRO_BIAS_ALL_RAD_S:
        found.append(f"{source}: the gyroscopes' gyr_z average {typical:.2f} rad/s in magnitude (median over the sensors; a "
                     f"walking segment's angle repeats, so its mean rate is ≈ 0; untouched recordings ≤ {GYRO_BIAS_ALL_RAD_S:g}): "
                     "every gyroscope looks biased; remove the bias (a still period's mean) first")
    else:
        found += [f"{source}: sensor {s}: gyr_z averages {b:+.2f} rad/s (a walking segment's mean rate is ≈ 0; untouched "
                  f"recordings ≤ {GYRO_BIAS_ONE_RAD_S:g} in magnitude): a gyroscope bias; remove it first"
                  for s, b in zip(segments, bias) if abs(b) > GYRO_BIAS_ONE_RAD_S]
    return found


def cross_leg_findings(imu: np.ndarray, segments: tuple[str, ...], rhythm: GaitRhythm, source: str) -> list[str]:
    """The two legs swing half a stride apart: the same segments' gyr_z of the right and left leg
    are ≈ 180° apart at the stride frequency. When at least two of the pairs (thighs, shanks,
    feet) are within 90° of in phase, one leg's sensors are turned 180° about their long axis
    (gyr_z and acc_x negated) or that leg's gyroscopes negated."""
    n = imu.shape[0]
    window = min(max(4 * rhythm.period_s, 2.0), n / RATE_HZ)
    close = []
    for kind in _KINDS:
        a, b = f"{kind}_r", f"{kind}_l"
        if a not in segments or b not in segments:
            continue
        sab, saa, sbb = cross_spectrum(imu[:, segments.index(a), 2][:, None], imu[:, segments.index(b), 2], RATE_HZ,
                                       1 / rhythm.period_s, [(0, n)], window)
        if saa[0] * sbb == 0 or abs(sab[0]) / np.sqrt(saa[0] * sbb) < MIN_COHERENCE:
            continue
        phase = float(np.degrees(np.angle(sab[0])))
        if abs(_wrap_deg(phase)) < 90.0:
            close.append(f"{a}/{b} {phase:+.0f}°")
    if len(close) < 2:
        return []
    return [f"{source}: the right and left legs swing in phase ({', '.join(close)} at the stride frequency; walking and "
            f"running: ≈ ±180°, untouched recordings beyond ±{CROSS_LEG_MIN_DEG:g}°): one leg's sensors look turned 180° about "
            "their long axis (gyr_z and acc_x negated), or that leg's gyroscopes negated"]


def _knee_skew_findings(imu: np.ndarray, segments: tuple[str, ...], source: str) -> list[str]:
    sos = butter(2, 0.3, btype="high", fs=RATE_HZ, output="sos")
    skews = {}
    for side in ("r", "l"):
        if f"femur_{side}" in segments and f"tibia_{side}" in segments:
            i, j = segments.index(f"femur_{side}"), segments.index(f"tibia_{side}")
            knee = sosfiltfilt(sos, np.cumsum(imu[:, j, 2] - imu[:, i, 2]) / RATE_HZ)
            skews[side] = float(skew(knee))
    if skews and all(v > KNEE_SKEW_WARN for v in skews.values()):
        values = ", ".join(f"{'right' if k == 'r' else 'left'} {v:+.2f}" for k, v in skews.items())
        return [f"{source}: sensors femur/tibia: the knee angle from gyr_z (shank minus thigh, integrated) is skewed towards "
                f"extension (skewness {values}; gait: below {KNEE_SKEW_WARN:+g}, knee flexion negative): the gyroscopes look "
                "negated (gyr_z must be positive counter-clockwise seen from the right)"]
    return []


def _wrap_deg(angle: float) -> float:
    """An angle in deg wrapped into [−180, 180)."""
    return (angle + 180.0) % 360.0 - 180.0


def cross_spectrum(a: np.ndarray, b: np.ndarray, rate_hz: float, freq_hz: float, runs: list[tuple[int, int]],
                   window_s: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(Σ A·conj(B), Σ|A|², Σ|B|²) at ``freq_hz`` of ``a`` (n, k) against ``b`` (n,), summed over Hann
    windows of ``window_s`` (half overlap) inside the walking ``runs`` (each window's mean removed)."""
    n = int(window_s * rate_hz)
    kernel = np.hanning(n) * np.exp(-2j * np.pi * freq_hz * np.arange(n) / rate_hz)
    sab, saa, sbb = np.zeros(a.shape[1], complex), np.zeros(a.shape[1]), 0.0
    for start, stop in runs:
        for k in range(start, stop - n + 1, max(1, n // 2)):
            x, y = a[k:k + n], b[k:k + n]
            A, B = (x - x.mean(axis=0)).T @ kernel, np.dot(y - y.mean(), kernel)
            sab += A * np.conj(B)
            saa += np.abs(A) ** 2
            sbb += abs(B) ** 2
    return sab, saa, sbb


def leg_phase_findings(rates: dict[str, np.ndarray], rate_hz: float, stride_hz: float, runs: list[tuple[int, int]],
                       window_s: float) -> dict[str, list[tuple[str, str, float, float]]]:
    """Per side ("right"/"left"), the pairs of that side's leg segments whose sagittal rates
    (``rates``: segment → (n,) rad/s) have a stride-frequency phase more than 90° from
    :data:`LEG_PHASE_DEG`: (segment a, segment b, phase of a over b, expected), deg; pairs with a
    coherence below :data:`MIN_COHERENCE` are not judged."""
    out = {}
    for side, name in (("r", "right"), ("l", "left")):
        bad = []
        for a, b in combinations([k for k in _KINDS if f"{k}_{side}" in rates], 2):
            sa, sb = f"{a}_{side}", f"{b}_{side}"
            sab, saa, sbb = cross_spectrum(rates[sa][:, None], rates[sb], rate_hz, stride_hz, runs, window_s)
            if saa[0] * sbb == 0 or abs(sab[0]) / np.sqrt(saa[0] * sbb) < MIN_COHERENCE:
                continue
            phase, expected = float(np.degrees(np.angle(sab[0]))), LEG_PHASE_DEG[(a, b)]
            if abs(_wrap_deg(phase - expected)) > 90.0:
                bad.append((sa, sb, phase, expected))
        if bad:
            out[name] = bad
    return out


# ------------------------------------------------------------------------------------ labels
def mean_vertical_force_findings(what: str, mean_n: float, mass: float, strict: bool = False) -> list[str]:
    """The one check of a mean summed vertical force (``mean_n``, N, both feet, over a recording
    or a GRF file; ``what`` names it) against the body weight of ``mass`` kg: outside
    :data:`LABEL_MEAN_BW_RANGE` a warning (a wrong mass, a missing plate, time off the treadmill;
    periodic gait averages 1). ``strict`` (a GRF file on import): negative (the vertical axis
    points down) or outside :data:`MEAN_VERTICAL_BW_PLAUSIBLE` (another unit, named when one
    fits) raises :class:`ImpossibleSignalError`."""
    weight = mass * GRAVITY
    ratio = mean_n / weight
    text = f"{what} average {mean_n:.4g} N, {ratio:.3g} × the body weight ({weight:.0f} N for {mass:g} kg)"
    low, high = MEAN_VERTICAL_BW_PLAUSIBLE
    ok = LABEL_MEAN_BW_RANGE
    if strict and ratio < 0:
        hint = ("the vertical axis points down: negate the vertical columns (y up is assumed)" if low <= -ratio <= high
                else "negative and not near body weight: check the columns, their sign and unit")
        raise ImpossibleSignalError(f"{text}: {hint}")
    if strict and not low <= ratio <= high:
        guesses = {**{unit: mean_n * factor / weight for unit, factor in _FORCE_UNITS.items()},
                   "body weights": mean_n, "N/kg": mean_n * mass / weight}
        unit = next((u for u, r in guesses.items() if ok[0] <= r <= ok[1]), None)
        hint = f"it looks like {unit}: give newtons" if unit else "not newtons under both feet: check the unit, the columns and the mass"
        raise ImpossibleSignalError(f"{text}, outside {low:g}–{high:g} (newtons, both feet): {hint}")
    if not ok[0] <= ratio <= ok[1]:
        return [f"{text}, outside {ok[0]:g}–{ok[1]:g} (periodic gait averages 1): a wrong mass or unit, a missing plate, "
                "or time off the treadmill"]
    return []


def speed_label_findings(rec: Recording, source: str) -> list[str]:
    """A warning when the mean ``speed`` label, with the IMU's stride period, gives a stride
    length whose ratio to Alexander's is outside :data:`SPEED_LABEL_STRIDE_RANGE` (a speed label
    off by more than about × 2 to 3.6 or ÷ 1.7 to 2.4: stride ∝ v against Alexander's v^0.6; a
    unit, a digit, another trial)."""
    labels = rec.labels
    if labels is None or labels.speed is None or not np.isfinite(labels.speed).all():
        return []
    rhythm = gait_rhythm(rec.imu, tuple(rec.segments))
    v = float(abs(np.mean(labels.speed)))
    if rhythm is None or v <= 0.3:
        return []
    stride, expected = v * rhythm.period_s, alexander_stride(v, rec.height)
    lo, hi = SPEED_LABEL_STRIDE_RANGE
    if lo <= stride / expected <= hi:
        return []
    likely = (expected / rhythm.period_s) ** 2.5 / v**1.5  # the speed at which stride = Alexander's: v^0.4 ∝ stride/period
    return [f"{source}: label speed averages {v:.3g} m/s; with the IMU's {rhythm.period_s:.2f} s stride that is a stride of "
            f"{stride:.2f} m, but a {rec.height:g} m person at that speed strides ≈ {expected:.2f} m (Alexander 1984; "
            f"accepted ratio {lo:g}–{hi:g}): the speed label looks wrong (≈ {likely:.2g} m/s fits the cadence)"]


def label_findings(rec: Recording, source: str, mean_check: bool = True) -> list[str]:
    """Warnings about the GRF labels of ``rec`` against its body weight and its IMU (module
    docstring; without the mean force where the caller judged it, as ``sspinn import`` does on the
    GRF file with :func:`mean_vertical_force_findings`); none without GRF labels."""
    labels = rec.labels
    if labels is None or rec.imu.shape[0] < 10:
        return []
    found = speed_label_findings(rec, source)
    if labels.grf is None:
        return found
    weight = rec.mass * GRAVITY
    grf = np.asarray(labels.grf, dtype=float)
    vertical = {side: grf[:, k] for side, k in (("r", 1), ("l", 3)) if np.isfinite(grf[:, k]).all()}
    for side, v in vertical.items():
        low = float(v.min()) / weight
        if low < -NEGATIVE_GRF_TOLERANCE_BW:
            found.append(f"{source}: label grf_y_{side} reaches {low:.2f} body weights ({v.min():.4g} N); the ground only pushes "
                         f"(noise down to −{NEGATIVE_GRF_TOLERANCE_BW:g}): a negated or offset force channel")
    if len(vertical) == 2 and mean_check:
        found += mean_vertical_force_findings(f"{source}: labels grf_y_r + grf_y_l", float(np.mean(vertical["r"] + vertical["l"])),
                                              rec.mass)
    imu, segments = rec.imu, tuple(rec.segments)
    rhythm = gait_rhythm(imu, segments)
    if rhythm is None or not vertical:
        return found
    side, v = next(iter(vertical.items()))
    r = _autocorr(v)
    lag = int(round(rhythm.period_s * RATE_HZ))
    lags = np.arange(max(2, int(0.5 * lag)), min(len(r) - 1, int(2.2 * lag)))
    if len(lags) > 2:
        best = int(lags[np.argmax(r[lags])])
        if abs(best - lag) > PERIOD_MISMATCH * lag and r[best] > r[lag] + 0.2:
            found.append(f"{source}: label grf_y_{side} repeats every {best / RATE_HZ:.3g} s but the IMU's stride is "
                         f"{rhythm.period_s:.3g} s: the labels' time base or rate differs from the IMU's")
    feet = [s for s in ("foot_r", "foot_l") if s in segments]
    if len(vertical) == 2 and len(feet) == 2:
        still = {s[-1]: -np.abs(imu[:, segments.index(s), 2]) for s in feet}
        corr = float(np.corrcoef(vertical["r"] - vertical["l"], still["r"] - still["l"])[0, 1])
        if corr < -0.2:
            found.append(f"{source}: labels grf_y_r/grf_y_l: the right label is loaded while the left foot sensor is still "
                         f"(correlation of the right-minus-left force with the right-minus-left stillness {corr:+.2f}, "
                         "gait: > 0): the GRF labels' sides look swapped")
    return found


# ------------------------------------------------------------------------------------ estimates
def alexander_stride(speed: float, height: float) -> float:
    """The stride length (m) of a ``height`` m person at ``speed`` m/s by Alexander's relation
    λ/h = 2.3 (v²/(g h))^0.3, h = :data:`LEG_PER_HEIGHT` × height (module docstring)."""
    leg = LEG_PER_HEIGHT * height
    return 2.3 * (speed**2 / (GRAVITY * leg)) ** 0.3 * leg if speed > 0 else 0.0


def estimate_findings(name: str, vertical_grf: np.ndarray, speed: np.ndarray, imu: np.ndarray, segments: Sequence[str],
                      height: float, mass: float) -> list[str]:
    """Warnings about an estimate of the recording ``name``: the summed vertical GRF (T,) N and
    forward speed (T,) m/s against the body weight (``mass`` kg) and the IMU's stride (module
    docstring); none for a recording without gait (:func:`gait_rhythm`)."""
    rhythm = gait_rhythm(imu, tuple(segments))
    if rhythm is None:
        return []
    n = int(round(rhythm.period_s * RATE_HZ))
    whole = (len(vertical_grf) // n) * n
    found = []
    mean = float(np.mean(vertical_grf[:whole])) / (mass * GRAVITY)
    if mean < MIN_MEAN_VERTICAL_BW:
        found.append(f"{name}: the estimated vertical GRF averages {mean:.2f} body weights over {whole // n} whole strides, "
                     f"below {MIN_MEAN_VERTICAL_BW:g} (the feet carry the body: ≈ 1 over a stride): the estimate is not "
                     "trustworthy; check the input signals' signs and axes")
    v = float(abs(np.mean(speed[:whole])))
    stride, expected = v * rhythm.period_s, alexander_stride(v, height)
    if v > 0.3 and not expected / STRIDE_LENGTH_FACTOR <= stride <= expected * STRIDE_LENGTH_FACTOR:
        found.append(f"{name}: the estimated speed {v:.2f} m/s with the IMU's {rhythm.period_s:.2f} s stride gives a stride of "
                     f"{stride:.2f} m, but a {height:g} m person at that speed strides ≈ {expected:.2f} m (Alexander 1984; "
                     f"accepted ×/÷ {STRIDE_LENGTH_FACTOR:g}): the speed estimate is implausible")
    return found


# ------------------------------------------------------------------------------------ joint constraints
@dataclass(frozen=True)
class JointFit:
    """The 2D joint constraint of two sensors on neighbouring segments fitted over windows:
    ``residual`` (sum of squared residuals, (m/s²)² · samples), ``samples``, and the median fitted
    distances of each sensor from the joint (``reach_a``, ``reach_b``, m)."""

    residual: float
    samples: int
    reach_a: float
    reach_b: float


def joint_fit(x: np.ndarray, i: int, j: int, dt: float = 1.0 / RATE_HZ, gyro_scale: tuple[float, float] = (1.0, 1.0),
              mirror: tuple[bool, bool] = (False, False), window_s: float = JOINT_WINDOW_S) -> JointFit:
    """Fit the joint shared by the sensors ``i`` and ``j`` of ``x`` ((T, n, 3) acc_x, acc_y, gyr_z,
    low-passed by :func:`_joint_signals`) in windows of ``window_s``: one point of both segments
    (the joint) has the same specific force seen from either sensor, so in complex sagittal
    coordinates ``f_i + K_i r_i = u e^{iφ(t)} (f_j + K_j r_j)`` with ``K = iα − ω²`` (tangential and
    centripetal terms), ``φ = ∫(ω_j − ω_i) dt`` (the joint angle from the gyroscopes), ``r`` the
    sensors' constant positions relative to the joint and ``u`` the constant rotation between the
    frames: linear in (r_i, u, u r_j), solved by least squares per window (Seel, Raisch and Schauer 2014, "IMU-based
    joint angle measurement for gait analysis", Sensors 14(4):6891–6909, the same constraint in 3D).
    ``dt`` is the sample interval assumed (s), ``gyro_scale`` and ``mirror`` (acc_x negated) the
    hypotheses tried on each sensor."""
    fi = (-1.0 if mirror[0] else 1.0) * x[:, i, 0] + 1j * x[:, i, 1]
    fj = (-1.0 if mirror[1] else 1.0) * x[:, j, 0] + 1j * x[:, j, 1]
    wi, wj = gyro_scale[0] * x[:, i, 2], gyro_scale[1] * x[:, j, 2]
    ki = 1j * np.gradient(wi) / dt - wi**2
    kj = 1j * np.gradient(wj) / dt - wj**2
    n = int(window_s * RATE_HZ)
    total, count, reach = 0.0, 0, []
    for s in range(0, len(fi) - n + 1, n):
        w = slice(s, s + n)
        turn = np.exp(1j * np.cumsum(wj[w] - wi[w]) * dt)
        design = np.column_stack([-ki[w], turn * fj[w], turn * kj[w]])
        sol, *_ = np.linalg.lstsq(design, fi[w], rcond=None)
        total += float(np.sum(np.abs(fi[w] - design @ sol) ** 2))
        count += n
        reach.append((abs(sol[0]), abs(sol[2] / sol[1]) if sol[1] != 0 else np.inf))
    a, b = np.median(reach, axis=0) if reach else (np.nan, np.nan)
    return JointFit(total, count, float(a), float(b))


def hip_residual_rms(imu: np.ndarray, segments: Sequence[str]) -> float | None:
    """The RMS residual (m/s²) of the hip constraints of :func:`joint_fit` between the ``pelvis``
    sensor of ``imu`` ((T, n, 3) sagittal signals in the order of ``segments``) and the thigh
    sensors, both hips pooled; None without a pelvis and a thigh or with less than one window."""
    pairs = [(a, b) for a, b in joints(segments) if a == "pelvis"]
    x = _joint_signals(imu)
    fits = [joint_fit(x, list(segments).index(a), list(segments).index(b)) for a, b in pairs]
    samples = sum(f.samples for f in fits)
    return float(np.sqrt(sum(f.residual for f in fits) / samples)) if samples else None


def _joint_signals(imu: np.ndarray) -> np.ndarray:
    """The IMU array low-passed at :data:`JOINT_LOWPASS_HZ` (the constraint holds for the rigid
    body motion; vibration and soft tissue above it only add noise), at most
    :data:`JOINT_MAX_S` of it."""
    n = min(imu.shape[0], int(JOINT_MAX_S * RATE_HZ))
    sos = butter(2, JOINT_LOWPASS_HZ, fs=RATE_HZ, output="sos")
    return sosfiltfilt(sos, imu[:n], axis=0)


def joints(segments: Sequence[str]) -> list[tuple[str, str]]:
    """The neighbouring segments of ``segments`` that share a joint (hips, knees, ankles)."""
    chain = [("pelvis", "femur_{}"), ("femur_{}", "tibia_{}"), ("tibia_{}", "foot_{}")]
    return [(a.format(side), b.format(side)) for side in ("r", "l") for a, b in chain
            if a.format(side) in segments and b.format(side) in segments]


def _residual(x: np.ndarray, segments: tuple[str, ...], pairs: list[tuple[str, str]], dt: float = 1.0 / RATE_HZ,
              scale: dict[str, float] | None = None, mirrored: str | None = None) -> float:
    scale = scale or {}
    total = 0.0
    for a, b in pairs:
        fit = joint_fit(x, segments.index(a), segments.index(b), dt, (scale.get(a, 1.0), scale.get(b, 1.0)),
                        (a == mirrored, b == mirrored))
        total += fit.residual
    return total


def _best_factor(cost, lo: float, hi: float) -> tuple[float, float]:
    """(argmin, min) of ``cost`` over factors in [lo, hi] (a log grid refined by a bounded search)."""
    from scipy.optimize import minimize_scalar

    grid = np.exp(np.linspace(np.log(lo), np.log(hi), 17))
    values = [cost(g) for g in grid]
    k = int(np.argmin(values))
    a, b = np.log(grid[max(k - 1, 0)]), np.log(grid[min(k + 1, len(grid) - 1)])
    res = minimize_scalar(lambda z: cost(float(np.exp(z))), bounds=(a, b), method="bounded", options={"xatol": 0.005})
    if res.fun < values[k]:
        return float(np.exp(res.x)), float(res.fun)
    return float(grid[k]), float(values[k])


@dataclass(frozen=True)
class JointStats:
    """What the joint constraints say about a recording (:func:`joint_stats`): ``factor`` — the
    speed-up of the motion that fits the joints best (1: the stated rate is right), ``factor_gain``
    — how much smaller the residual is at that factor than at 1; per sensor ``mirror`` — how much
    smaller its joints' residual is with its acc_x negated, ``negated`` — with its gyr_z negated,
    ``scale`` — the factor on its gyr_z that fits best and the gain (None for the pelvis); ``rms``
    the residual specific force at the stated rate, m/s² RMS; ``excluded`` the suspected sensors
    whose joints the factor was not fitted on."""

    factor: float
    factor_gain: float
    mirror: dict[str, float]
    negated: dict[str, float]
    scale: dict[str, tuple[float, float] | None]
    rms: float
    excluded: tuple[str, ...]


def joint_stats(imu: np.ndarray, segments: tuple[str, ...], per_sensor: bool = True) -> JointStats | None:
    """The :class:`JointStats` of ``imu`` (T, n, 3), or None without two neighbouring segments.
    The sensors are judged at the stated rate first; the time-base factor is then fitted on the
    joints of the sensors not suspected (:func:`_suspects`), so that one wrong sensor does not
    pass for a wrong rate (``per_sensor=False``: the factor alone, on every joint)."""
    pairs = joints(segments)
    if not pairs:
        return None
    x = _joint_signals(imu)
    base = _residual(x, segments, pairs)
    if base <= 0:
        return None
    legs = {f"{k}_{side}" for k in _KINDS for side in ("r", "l")}
    mirror, negated, scale = {}, {}, {}
    for s in segments if per_sensor else ():
        own = [p for p in pairs if s in p]
        if not own:
            continue
        mine = _residual(x, segments, own)
        mirror[s] = mine / max(_residual(x, segments, own, mirrored=s), 1e-12)
        if s not in legs:  # the pelvis turns too little to weigh its gyroscope's sign or scale
            scale[s] = None
            continue
        negated[s] = mine / max(_residual(x, segments, own, scale={s: -1.0}), 1e-12)
        g, best_s = _best_factor(lambda v, own=own, s=s: _residual(x, segments, own, scale={s: v}), *JOINT_SCALE_RANGE)
        scale[s] = (g, mine / max(best_s, 1e-12))
    stats = JointStats(1.0, 1.0, mirror, negated, scale, float(np.sqrt(base / (len(pairs) * x.shape[0]))), ())
    excluded = tuple(s for _, s, _ in _suspects(stats))
    kept = [p for p in pairs if not set(p) & set(excluded)] or pairs
    at_one = _residual(x, segments, kept)
    factor, best = _best_factor(lambda f: _residual(x, segments, kept, dt=f / RATE_HZ), *JOINT_FACTOR_RANGE)
    return replace(stats, factor=factor, factor_gain=at_one / max(best, 1e-12), excluded=excluded)


def _suspects(stats: JointStats) -> list[tuple[float, str, str]]:
    """(gain, sensor, what) for every sensor whose joints fit clearly better with one mistake undone."""
    found = []
    for s in stats.mirror:
        if stats.mirror[s] > JOINT_MIRROR_WARN:
            found.append((stats.mirror[s], s, f"its joints fit {stats.mirror[s]:.1f} times better with acc_x negated "
                          f"(untouched recordings: below {JOINT_MIRROR_WARN:g}): acc_x points backwards (on a 3D sensor: a "
                          "negated gyroscope or two swapped accelerometer axes, which the calibration turns into a "
                          "mirrored acc_x)"))
        elif stats.negated.get(s, 0.0) > JOINT_MIRROR_WARN:
            found.append((stats.negated[s], s, f"its joints fit {stats.negated[s]:.1f} times better with gyr_z negated "
                          f"(untouched recordings: below {JOINT_MIRROR_WARN:g}): the gyroscope is negated"))
        elif stats.scale.get(s) is not None:
            scale, gain = stats.scale[s]
            lo, hi = JOINT_SCALE_OK[s.split("_")[0]]
            if not lo <= scale <= hi:
                found.append((gain, s, f"its joints fit best with gyr_z × {scale:.2f} (residual {gain:.2f} times smaller; "
                              f"untouched recordings: {lo:g}–{hi:g}): the gyroscope reads × {1 / scale:.2f} of the true "
                              "rate (a unit or range setting?)"))
    return found


def joint_findings(imu: np.ndarray, segments: tuple[str, ...], source: str) -> list[str]:
    """The joint-constraint checks of the module docstring on a recording with gait: the time base
    (the factor that makes the joints fit best, with joints of two kinds or more; then nothing is
    said of single sensors), else per
    sensor a mirrored acc_x, a negated or a mis-scaled gyroscope; empty without two neighbouring
    segments. Not called where the leg pairing or the knee-angle skew found sensors on another
    leg's segments or all gyroscopes negated (several joints broken at once)."""
    stats = joint_stats(imu, segments)
    if stats is None:
        return []
    lo, hi = JOINT_RATE_OK
    # one kind of joint alone (only knees: thigh and shank sensors) fits a range of rates almost
    # equally well (untouched synthetic walkers: factor 0.82–0.84 at 1.01–1.02 times smaller
    # residuals), so the time base is judged on two or more kinds
    kinds = {distal.split("_")[0] for _, distal in joints(segments)}
    if len(kinds) >= 2 and not lo <= stats.factor <= hi:
        return [f"{source}: the sensors' joints (hips, knees, ankles) fit best if the motion ran {stats.factor:.2f} times as "
                f"fast as stamped (residual {stats.factor_gain:.2f} times smaller than at the stated rate; untouched "
                f"recordings: {lo:g}–{hi:g}): the sample rate is likely wrong (recorded at ≈ {RATE_HZ / stats.factor:.3g} Hz?): "
                "resample to 100 Hz with the true rate"]
    # a wrong sensor spoils its neighbours' joints too: name the clearest one of each neighbourhood
    pairs, named, found = joints(segments), set(), []
    for _, s, text in sorted(_suspects(stats), reverse=True):
        if any(n in named for p in pairs if s in p for n in p):
            continue
        named.add(s)
        found.append(f"{source}: sensor {s}: {text}")
    return found
