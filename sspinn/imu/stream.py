"""Raw 3D multi-sensor IMU streams as vendor files give them, before calibration onto the
sagittal plane (:mod:`sspinn.imu.calibration`).

* :class:`SensorSignals` — one sensor: time stamps (s, the vendor's clock), specific force
  ``acc`` (n, 3) in m/s² **including gravity** and angular rate ``gyr`` (n, 3) in rad/s, both in
  the sensor's own 3D frame; optionally the vendor's fused orientation (unit quaternions
  w, x, y, z) and the packet counter.
* :class:`IMUStream` — the sensors of one recording (synchronised with each other: one clock).
* :func:`check_sensor` — units and liveness: a gyroscope in deg/s, an accelerometer in g (or
  without gravity), a constant axis, non-finite values; one-line errors naming file and sensor.
* :func:`standing_statistics` — a still sensor's |specific force| (≈ g) and gyroscope bias.
* :func:`find_gaps` — dropped samples from the packet counter (wraps at 65536) or time stamps.
* :func:`resample` — every sensor on one 100 Hz grid over the span all sensors cover: gaps up to
  ``max_gap_s`` are interpolated and reported, longer ones are an error naming file, sensor, time
  and length; rates above 100 Hz are low-pass filtered (zero-phase, 4th-order Butterworth at
  40 Hz) before cubic-spline interpolation.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Final

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import butter, sosfiltfilt

from sspinn.data.gait_events import true_runs
from sspinn.errors import DataFormatError
from sspinn.model.conventions import GRAVITY
from sspinn.resource_limits import MAX_ROWS

#: The project's sample rate, Hz.
RATE_HZ: Final = 100.0
#: Largest angular-rate norm (rad/s) a body segment reaches (a foot in sprinting ≈ 30); above
#: it, and plausible once divided by 180/π, the gyroscope is in deg/s.
MAX_GYRO_NORM_RAD_S: Final = 50.0
#: Accepted median |specific force| in m/s²: about 1 g of gravity plus movement. Below 0.3 g the
#: unit is g (median ≈ 1) or gravity was removed (free acceleration); above 5 g, cm/s² or mm/s².
MEDIAN_ACC_RANGE_M_S2: Final = (0.3 * GRAVITY, 5.0 * GRAVITY)
#: Gaps up to this long are interpolated (and reported) by :func:`resample`, s.
DEFAULT_MAX_GAP_S: Final = 0.05
#: Cut-off of the anti-alias filter applied before down-sampling to 100 Hz, Hz.
ANTI_ALIAS_HZ: Final = 40.0


class IMUImportError(DataFormatError):
    """Vendor IMU files that cannot be imported as they are; the one-line message names the file
    and the sensor, what is wrong and what to do."""


@dataclass(frozen=True)
class Gap:
    """Samples missing from one sensor's stream.

    Attributes:
        sensor: sensor name; source: the file.
        start_s: time stamp of the last sample before the gap, s (the vendor's clock).
        duration_s: time between the samples around the gap, s.
        missing: number of samples missing.
        detected_by: ``"packet counter"``, ``"time stamps"`` or ``"non-finite values"``.
    """

    sensor: str
    source: str
    start_s: float
    duration_s: float
    missing: int
    detected_by: str

    def describe(self) -> str:
        return (f"{self.source}, sensor {self.sensor!r}: {self.missing} sample(s) missing after t = {self.start_s:.3f} s "
                f"({self.duration_s:.3f} s between samples; found from the {self.detected_by})")


@dataclass
class SensorSignals:
    """One sensor's raw 3D signals (see the module docstring for frames and units).

    Attributes:
        name: the sensor's name in the files (e.g. ``femur_r_imu_offset_imu`` or an Xsens device ID).
        source: the file(s) it was read from, for messages.
        time: (n,) time stamps, s, increasing.
        acc: (n, 3) specific force (gravity included), m/s², sensor frame.
        gyr: (n, 3) angular rate, rad/s, sensor frame.
        orientation: (n, 4) the vendor's orientation estimate (unit quaternion w, x, y, z of the
            sensor in the vendor's global frame), or None. Informational: calibration does not use it.
        counter: (n,) packet counter (unwrapped), or None.
        gaps: gaps found so far (:func:`find_gaps`, :func:`resample`).
    """

    name: str
    source: str
    time: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray
    orientation: np.ndarray | None = None
    counter: np.ndarray | None = None
    gaps: list[Gap] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.time = np.asarray(self.time, dtype=np.float64).reshape(-1)
        self.acc = np.asarray(self.acc, dtype=np.float64)
        self.gyr = np.asarray(self.gyr, dtype=np.float64)
        n = len(self.time)
        for name, arr, width in (("acc", self.acc, 3), ("gyr", self.gyr, 3), ("orientation", self.orientation, 4)):
            if arr is not None and np.shape(arr) != (n, width):
                raise IMUImportError(f"{self.source}, sensor {self.name!r}: {name} has shape {np.shape(arr)}, expected ({n}, {width})")
        if n < 2:
            raise IMUImportError(f"{self.source}, sensor {self.name!r}: needs at least 2 samples, found {n}")

    @property
    def sample_rate_hz(self) -> float:
        """Sample rate of the time stamps, Hz: the mean step between samples, gaps (steps over
        1.5 medians) left out (a mean, as quantised time stamps alternate between two steps)."""
        dt = np.diff(self.time)
        return float(1.0 / np.mean(dt[dt < 1.5 * np.median(dt)]))


@dataclass
class IMUStream:
    """The sensors of one recording, synchronised with each other (one clock).

    Attributes:
        sensors: name → :class:`SensorSignals`, in file order.
        source: the files, for messages.
        notes: what the readers and :func:`resample` report (gaps filled, files found).
        warnings: what the readers found suspicious but readable (e.g. two files with the same
            values), one line each naming the files.
    """

    sensors: dict[str, SensorSignals]
    source: str
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def names(self) -> list[str]:
        return list(self.sensors)

    @property
    def gaps(self) -> list[Gap]:
        return [g for s in self.sensors.values() for g in s.gaps]

    def sensor(self, name: str) -> SensorSignals:
        if name not in self.sensors:
            raise IMUImportError(f"{self.source}: no sensor {name!r}; the files have {self.names}")
        return self.sensors[name]

    def crop(self, start_s: float | None = None, end_s: float | None = None) -> IMUStream:
        """The samples with ``start_s <= time - t0 < end_s``, where t0 is the earliest time stamp
        of the stream (so times count from the start of the files)."""
        t0 = min(float(s.time[0]) for s in self.sensors.values())
        lo = -np.inf if start_s is None else t0 + start_s - 1e-9
        hi = np.inf if end_s is None else t0 + end_s - 1e-9
        out = {}
        for name, s in self.sensors.items():
            keep = (s.time >= lo) & (s.time < hi)
            if keep.sum() < 2:
                raise IMUImportError(f"{s.source}, sensor {name!r}: no samples between {start_s} s and {end_s} s "
                                     f"(the stream spans {s.time[0] - t0:.2f}–{s.time[-1] - t0:.2f} s)")
            out[name] = replace(
                s, time=s.time[keep], acc=s.acc[keep], gyr=s.gyr[keep],
                orientation=None if s.orientation is None else s.orientation[keep],
                counter=None if s.counter is None else s.counter[keep],
                gaps=[g for g in s.gaps if lo <= g.start_s < hi],
            )
        return IMUStream(out, self.source, list(self.notes), list(self.warnings))


# ---------------------------------------------------------------------------------- checks
def check_sensor(s: SensorSignals) -> None:
    """Raise :class:`IMUImportError` naming file and sensor if the signals are not specific force
    in m/s² and angular rate in rad/s from a working 3-axis sensor (non-finite rows are gaps and
    are skipped here)."""
    ok = np.isfinite(s.acc).all(axis=1) & np.isfinite(s.gyr).all(axis=1)
    if ok.sum() < 2:
        raise IMUImportError(f"{s.source}, sensor {s.name!r}: no complete sample (every row has a missing or non-finite value)")
    acc, gyr = s.acc[ok], s.gyr[ok]
    for label, arr, unit in (("acc", acc, "m/s²"), ("gyr", gyr, "rad/s")):
        for j, axis in enumerate("XYZ"):
            if np.ptp(arr[:, j]) == 0.0:
                raise IMUImportError(
                    f"{s.source}, sensor {s.name!r}: {label} axis {axis} is constant ({arr[0, j]:.6g} {unit}) over all "
                    f"{len(arr)} samples: a dead axis or a 2D export padded to 3D; every axis of a 3D sensor must move"
                )
    gyr_norm = np.linalg.norm(gyr, axis=1)
    peak = float(gyr_norm.max())
    if peak > MAX_GYRO_NORM_RAD_S:
        hint = ("it looks like deg/s: convert to rad/s (× π/180)" if peak * np.pi / 180 <= MAX_GYRO_NORM_RAD_S
                else "far beyond what a body segment does: check the unit and the sensor")
        raise IMUImportError(f"{s.source}, sensor {s.name!r}: gyroscope reaches {peak:.4g} (norm), but body segments turn at most "
                             f"~{MAX_GYRO_NORM_RAD_S:g} rad/s; {hint}")
    median = float(np.median(np.linalg.norm(acc, axis=1)))
    low, high = MEDIAN_ACC_RANGE_M_S2
    if median < low:
        kind = "units of g (multiply by 9.81)" if 0.5 < median < 2.0 else "acceleration without gravity (free acceleration)"
        raise IMUImportError(f"{s.source}, sensor {s.name!r}: median |acc| is {median:.3g}, far below g = {GRAVITY} m/s²: "
                             f"it looks like {kind}; export the specific force in m/s² (Xsens: Acc_X/Y/Z, not FreeAcc)")
    if median > high:
        raise IMUImportError(f"{s.source}, sensor {s.name!r}: median |acc| is {median:.4g}, {median / GRAVITY:.3g} g: "
                             "a wrong unit (cm/s²: divide by 100, mm/s²: by 1000)")


@dataclass(frozen=True)
class StandingStatistics:
    """One sensor's signals over a span in which it is assumed still (a static trial, quiet standing).

    Attributes:
        sensor: its name; source: the file.
        seconds: the span, s; samples: complete samples in it.
        acc_norm_m_s2: mean |specific force|, m/s² (g = 9.81 for a working accelerometer in m/s²).
        acc_norm_sd_m_s2: its standard deviation, m/s².
        gyro_bias_rad_s: (3,) mean angular rate per sensor axis, rad/s (the gyroscope bias when still).
        gyro_sd_rad_s: (3,) standard deviation of the angular rate per axis, rad/s (noise and sway).
    """

    sensor: str
    source: str
    seconds: float
    samples: int
    acc_norm_m_s2: float
    acc_norm_sd_m_s2: float
    gyro_bias_rad_s: np.ndarray
    gyro_sd_rad_s: np.ndarray

    def describe(self) -> str:
        bias = ", ".join(f"{v:+.4f}" for v in self.gyro_bias_rad_s)
        sd = ", ".join(f"{v:.4f}" for v in self.gyro_sd_rad_s)
        return (f"{self.sensor}: {self.samples} samples over {self.seconds:.2f} s; |acc| {self.acc_norm_m_s2:.3f} ± "
                f"{self.acc_norm_sd_m_s2:.3f} m/s² ({self.acc_norm_m_s2 / GRAVITY - 1:+.1%} from g); gyro bias ({bias}) rad/s "
                f"(|bias| {np.linalg.norm(self.gyro_bias_rad_s):.4f}), sd ({sd}) rad/s")


def standing_statistics(s: SensorSignals, start_s: float | None = None, end_s: float | None = None) -> StandingStatistics:
    """Statistics of ``s`` between ``start_s`` and ``end_s`` (s from its first sample; default:
    all of it), assuming the sensor is still there; rows with a missing value are left out."""
    t = s.time - s.time[0]
    keep = (t >= (start_s or 0.0) - 1e-9) & (t < (np.inf if end_s is None else end_s) - 1e-9)
    keep &= np.isfinite(s.acc).all(axis=1) & np.isfinite(s.gyr).all(axis=1)
    if keep.sum() < 2:
        raise IMUImportError(f"{s.source}, sensor {s.name!r}: fewer than 2 complete samples between {start_s} s and {end_s} s")
    norm = np.linalg.norm(s.acc[keep], axis=1)
    span = float(t[keep][-1] - t[keep][0])
    return StandingStatistics(s.name, s.source, span, int(keep.sum()), float(norm.mean()), float(norm.std()),
                              s.gyr[keep].mean(axis=0), s.gyr[keep].std(axis=0))


def find_gaps(s: SensorSignals) -> list[Gap]:
    """Dropped samples of one sensor: packet-counter jumps (counter unwrapped already) when there
    is a counter, else time steps longer than 1.5 median steps, and runs of non-finite rows."""
    gaps: list[Gap] = []
    dt = np.diff(s.time)
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0])
        raise IMUImportError(f"{s.source}, sensor {s.name!r}: time stamps do not increase at sample {k + 1} "
                             f"({s.time[k]:.6g} s then {s.time[k + 1]:.6g} s): a reset clock or concatenated files")
    step = float(np.median(dt))
    if s.counter is not None:
        jumps = np.diff(s.counter)
        for k in np.flatnonzero(jumps != 1):
            if jumps[k] < 1:
                raise IMUImportError(f"{s.source}, sensor {s.name!r}: packet counter goes from {s.counter[k]} to {s.counter[k + 1]} "
                                     f"at sample {k + 1}: duplicated or reordered packets")
            gaps.append(Gap(s.name, s.source, float(s.time[k]), float(dt[k]), int(jumps[k] - 1), "packet counter"))
    else:
        for k in np.flatnonzero(dt > 1.5 * step):
            gaps.append(Gap(s.name, s.source, float(s.time[k]), float(dt[k]), int(round(dt[k] / step)) - 1, "time stamps"))
    bad = ~(np.isfinite(s.acc).all(axis=1) & np.isfinite(s.gyr).all(axis=1))
    if bad.any():
        for a, b in true_runs(bad):
            before, after = max(a - 1, 0), min(b, len(s.time) - 1)
            gaps.append(Gap(s.name, s.source, float(s.time[before]), float(s.time[after] - s.time[before]), int(b - a),
                            "non-finite values"))
    return sorted(gaps, key=lambda g: g.start_s)


def resample(stream: IMUStream, max_gap_s: float = DEFAULT_MAX_GAP_S, rate_hz: float = RATE_HZ,
             grid: np.ndarray | None = None) -> tuple[np.ndarray, IMUStream]:
    """Every sensor on one grid at ``rate_hz`` over the span all sensors cover (or on ``grid``, s,
    which every sensor must cover: the grid of another resampled stream).

    Returns (time grid (m,) on the stream's clock, the resampled stream). Each sensor is first
    checked (:func:`check_sensor`) and its gaps found (:func:`find_gaps`); gaps up to
    ``max_gap_s`` are bridged by the spline and listed in ``notes``; a longer gap raises
    :class:`IMUImportError` naming file, sensor, time and length (import a part without it:
    ``start_s``/``end_s``). Sensors at a higher rate are low-pass filtered at
    :data:`ANTI_ALIAS_HZ` first. The orientation is not resampled (dropped).
    """
    for s in stream.sensors.values():
        check_sensor(s)
        s.gaps = find_gaps(s)
    too_long = [g for s in stream.sensors.values() for g in s.gaps if g.duration_s > max_gap_s + 1e-9]
    if too_long:
        g = too_long[0]
        shared = sum(h.sensor != g.sensor and abs(h.start_s - g.start_s) < 1e-6 for h in too_long)
        raise IMUImportError(
            f"{g.describe()}{f' (the same gap in {shared} other sensor(s))' if shared else ''}: a gap longer than {max_gap_s:g} s "
            "cannot be bridged; import the part before or after it (start/end times) or allow longer gaps (max_gap_s)"
        )
    notes = list(stream.notes) + [f"gap interpolated: {g.describe()}" for s in stream.sensors.values() for g in s.gaps]
    t0 = max(float(s.time[0]) for s in stream.sensors.values())
    t1 = min(float(s.time[-1]) for s in stream.sensors.values())
    if t1 - t0 < 2.0 / rate_hz:
        spans = ", ".join(f"{n}: {s.time[0]:.3f}–{s.time[-1]:.3f} s" for n, s in stream.sensors.items())
        raise IMUImportError(f"{stream.source}: the sensors' time spans do not overlap ({spans}); they must share one clock")
    if grid is None:
        n_grid = int(np.floor((t1 - t0) * rate_hz + 1e-9)) + 1
        if n_grid > MAX_ROWS:
            raise IMUImportError(f"{stream.source}: the sensors span {t1 - t0:.6g} s, {n_grid} samples at {rate_hz:g} Hz, "
                                 f"more than the {MAX_ROWS} a recording may have here: is the time column in seconds "
                                 "(not ms)? Import a part (start/end times)")
        grid = t0 + np.arange(n_grid) / rate_hz
    elif grid[0] < t0 - 1e-9 or grid[-1] > t1 + 1e-9:
        raise IMUImportError(f"{stream.source}: the sensors cover {t0:.3f}–{t1:.3f} s, not the grid's {grid[0]:.3f}–{grid[-1]:.3f} s")
    out: dict[str, SensorSignals] = {}
    for name, s in stream.sensors.items():
        ok = np.isfinite(s.acc).all(axis=1) & np.isfinite(s.gyr).all(axis=1)
        t, acc, gyr = s.time[ok], s.acc[ok], s.gyr[ok]
        rate = s.sample_rate_hz
        if rate > rate_hz * 1.01:
            sos = butter(4, ANTI_ALIAS_HZ, fs=rate, output="sos")
            acc, gyr = sosfiltfilt(sos, acc, axis=0), sosfiltfilt(sos, gyr, axis=0)
            notes.append(f"{s.source}, sensor {name!r}: {rate:.4g} Hz low-pass filtered at {ANTI_ALIAS_HZ:g} Hz and resampled to {rate_hz:g} Hz")
        elif abs(rate - rate_hz) > 0.01 * rate_hz:
            notes.append(f"{s.source}, sensor {name!r}: {rate:.4g} Hz resampled to {rate_hz:g} Hz (cubic spline)")
        out[name] = SensorSignals(name, s.source, grid, CubicSpline(t, acc)(grid), CubicSpline(t, gyr)(grid), gaps=list(s.gaps))
    return grid, IMUStream(out, stream.source, notes, list(stream.warnings))
