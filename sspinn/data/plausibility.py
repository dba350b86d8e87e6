"""Physical plausibility of IMU recordings: is this human movement, in SI units, from working
sensors placed on the segment they are said to be on?

One threshold per quantity cannot tell a pelvis gyroscope in deg/s (walking peaks ≈ 35 "rad/s")
from a foot gyroscope in rad/s; so each check is driven by what the body can do, per segment:

* **angular rate** (gyr_z, rad/s): at most :data:`MAX_GYRO_RAD_S` of the segment — sprinting
  reaches ≈ 6 (pelvis), 15 (thigh), 20 (shank) and 30 rad/s (foot); the limits are above that.
  A larger value is deg/s (or a broken sensor).
* **specific force** (acc_x/y, m/s²): every sample within :data:`MAX_ACC_M_S2` (50 g; tibial
  impacts in running reach 10–20 g); and **gravity is visible**: the median magnitude lies within
  :data:`GRAVITY_MAGNITUDE_RANGE` × g (units of g give ≈ 0.1 g, cm/s² ≈ 100 g, linear
  acceleration without gravity ≈ 0.1–0.3 g), and so does the magnitude of the low-frequency
  specific force (the mean over each :data:`LOW_PASS_WINDOW_S` window: linear accelerations
  average out, gravity does not) in the median window. In the frame of a swinging segment the
  centripetal acceleration does not average out either: virtual foot IMUs on human running
  kinematics at 4 m/s (``benchmarks.accuracy.semi_real_running``) give 1 s means of 2.9–3.1 g
  (shank 1.6 g), hence the upper bound of :data:`LOW_PASS_RANGE` equals that of the raw median.
* **dead sensors**: a channel that never changes over the recording.
* **saturated sensors**: a channel that sits at its extreme value (max or min) for at least
  :data:`SATURATION_MIN_RUN` consecutive samples in at least :data:`SATURATION_MIN_EPISODES`
  separate episodes (a clipped signal; a real peak is not flat at float precision).
* **placement**: each IMU position (m, segment frame) within its segment's size
  (:data:`PLACEMENT_SLACK` × the Winter segment length for the subject's height, plus 5 cm); a
  position in cm is hundreds of segment lengths away.

:func:`check_imu_plausibility` raises :class:`ImplausibleRecordingError` (a
:class:`sspinn.errors.DataFormatError`) naming the source, the column, the value seen and the
likely cause.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from sspinn.errors import DataFormatError
from sspinn.model.body import WINTER, IMUPlacement
from sspinn.model.conventions import GRAVITY, SEGMENTS

#: Largest sagittal angular rate per segment kind, rad/s (above sprinting values).
MAX_GYRO_RAD_S: Final[dict[str, float]] = {"pelvis": 12.0, "femur": 25.0, "tibia": 35.0, "foot": 45.0}
#: Largest specific-force component, m/s² (50 g).
MAX_ACC_M_S2: Final = 50 * GRAVITY
#: Accepted median |specific force| and low-frequency |specific force|, in units of g.
GRAVITY_MAGNITUDE_RANGE: Final = (0.3, 5.0)
LOW_PASS_RANGE: Final = (0.3, 5.0)
#: Window of the low-frequency specific force, s; checked only for recordings at least this long.
LOW_PASS_WINDOW_S: Final = 1.0
#: Saturation: runs of at least this many samples at the extreme, in at least this many episodes.
SATURATION_MIN_RUN: Final = 3
SATURATION_MIN_EPISODES: Final = 3
#: Placement bound: this many segment lengths plus 5 cm from the segment's origin.
PLACEMENT_SLACK: Final = 1.2

_DEG = 180.0 / np.pi


class ImplausibleRecordingError(DataFormatError):
    """IMU signals or placement that no working sensor on a moving human gives, in SI units."""


def segment_kind(segment: str) -> str:
    """"pelvis", "femur", "tibia" or "foot" for a segment name such as ``femur_r``."""
    return segment.split("_")[0]


def check_imu_plausibility(
    source: str, imu: np.ndarray, segments: tuple[str, ...], sample_rate_hz: float, height: float,
    placement: IMUPlacement | None = None,
) -> None:
    """Raise :class:`ImplausibleRecordingError` unless ``imu`` (T, n_imu, 3) [acc_x, acc_y,
    gyr_z] (m/s², rad/s; finite) looks like human movement measured by working sensors, and the
    ``placement`` (if given) fits segments of a ``height`` (m) subject."""
    n = imu.shape[0]
    for i, s in enumerate(segments):
        acc, gyr = imu[:, i, :2], imu[:, i, 2]
        _check_gyro(source, s, gyr)
        _check_acc_range(source, s, acc)
        if n >= 10:
            for j, channel in enumerate(("acc_x", "acc_y", "gyr_z")):
                _check_alive(source, f"{s}_{channel}", imu[:, i, j])
            _check_gravity(source, s, acc, sample_rate_hz)
    if placement is not None:
        check_placement(source, placement, height)


def _check_gyro(source: str, segment: str, gyr: np.ndarray) -> None:
    limit = MAX_GYRO_RAD_S[segment_kind(segment)]
    k = int(np.argmax(np.abs(gyr)))
    peak = float(abs(gyr[k]))
    if peak > limit:
        as_deg = peak / _DEG
        hint = (f"it looks like deg/s ({peak:.4g} deg/s = {as_deg:.3g} rad/s): convert to rad/s"
                if as_deg <= limit else "far beyond human movement: check the units and the sensor")
        raise ImplausibleRecordingError(
            f"{source}: column '{segment}_gyr_z' reaches {gyr[k]:.4g} at sample {k}, but a {segment_kind(segment)} "
            f"turns at most ~{limit:g} rad/s in human movement; {hint}"
        )


def _check_acc_range(source: str, segment: str, acc: np.ndarray) -> None:
    flat = np.abs(acc)
    k, j = np.unravel_index(int(np.argmax(flat)), flat.shape)
    if flat[k, j] > MAX_ACC_M_S2:
        raise ImplausibleRecordingError(
            f"{source}: column '{segment}_acc_{'xy'[j]}' reaches {acc[k, j]:.4g} at sample {k}, beyond "
            f"{MAX_ACC_M_S2:.0f} m/s² (50 g) that human movement gives: wrong units (cm/s² or mm/s²?) or a corrupt value"
        )


def _check_alive(source: str, column: str, values: np.ndarray) -> None:
    if np.ptp(values) == 0.0:
        raise ImplausibleRecordingError(
            f"{source}: column '{column}' is constant ({values[0]:.6g}) over all {len(values)} samples: "
            "a dead, disconnected or zero-filled sensor; remove this IMU or fix the export"
        )
    for extreme in (values.max(), values.min()):
        at = np.concatenate([[False], values == extreme, [False]])
        starts = np.flatnonzero(np.diff(at.astype(np.int8)) == 1)
        ends = np.flatnonzero(np.diff(at.astype(np.int8)) == -1)
        episodes = int(np.sum(ends - starts >= SATURATION_MIN_RUN))
        if episodes >= SATURATION_MIN_EPISODES:
            raise ImplausibleRecordingError(
                f"{source}: column '{column}' is clipped at {extreme:.6g} ({episodes} flat episodes of "
                f"≥ {SATURATION_MIN_RUN} samples at that value): the sensor saturated; use a larger measurement range"
            )


def _check_gravity(source: str, segment: str, acc: np.ndarray, sample_rate_hz: float) -> None:
    columns = f"{segment}_acc_x/y"
    median = float(np.median(np.hypot(acc[:, 0], acc[:, 1]))) / GRAVITY
    low, high = GRAVITY_MAGNITUDE_RANGE
    if median < low:
        raise ImplausibleRecordingError(
            f"{source}: {columns} median magnitude {median * GRAVITY:.3g} m/s² is far below g = {GRAVITY} m/s²: "
            "accelerometers look like units of g (multiply by 9.81) or lack gravity (need specific force)"
        )
    if median > high:
        raise ImplausibleRecordingError(
            f"{source}: {columns} median magnitude {median * GRAVITY:.4g} m/s² is {median:.3g} g, far above the ≈ 1 g "
            "of gait: wrong units or scale (cm/s²: divide by 100, mm/s²: by 1000)"
        )
    window = int(round(LOW_PASS_WINDOW_S * sample_rate_hz))
    if acc.shape[0] < window or window < 2:
        return
    kernel = np.ones(window) / window
    mean = np.stack([np.convolve(acc[:, j], kernel, mode="valid") for j in range(2)], axis=1)
    low_freq = float(np.median(np.hypot(mean[:, 0], mean[:, 1]))) / GRAVITY
    low, high = LOW_PASS_RANGE
    if not low <= low_freq <= high:
        raise ImplausibleRecordingError(
            f"{source}: the low-frequency specific force of {columns} ({LOW_PASS_WINDOW_S:g} s means) has median "
            f"magnitude {low_freq:.2f} g, outside {low:g}–{high:g} g (gravity, plus the centripetal acceleration of a "
            "swinging segment): the signals lack gravity or are scaled wrongly"
        )


def check_placement(source: str, placement: IMUPlacement, height: float) -> None:
    """Raise :class:`ImplausibleRecordingError` if an IMU position (m) lies outside its segment."""
    for s in SEGMENTS:
        x, y = placement.positions[s]
        bound = PLACEMENT_SLACK * WINTER[segment_kind(s)][1] * height + 0.05
        distance = float(np.hypot(x, y))
        if distance > bound:
            raise ImplausibleRecordingError(
                f"{source}: IMU placement of {s} ({x:.4g}, {y:.4g}) is {distance:.3g} m from the segment's origin, "
                f"beyond the {bound:.2f} m a {segment_kind(s)} of a {height:g} m subject spans: positions must be in "
                "metres (cm divided by 100)"
            )
