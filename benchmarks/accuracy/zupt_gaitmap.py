"""The ZUPT filter (:mod:`sspinn.estimator.zupt`) on gaitmap's data: 3D foot IMUs → sagittal signals, and
the validation against motion capture on gaitmap's example recording.

* :func:`sagittal_from_gaitmap_frame` projects a 3D foot IMU given in gaitmap's sensor frame onto
  the foot's sagittal plane in sspinn's conventions (gravity and heading alignment, as gaitmap's
  preprocessing), ready for :class:`~sspinn.estimator.zupt.SagittalZuptKalman`.
* :func:`load_gaitmap_example` reads gaitmap's example walking recording
  (``$SSPINN_SHARED_DATA/gaitmap_foot_imu``: two foot IMUs at 204.8 Hz, foot markers at 100 Hz,
  57 strides from mid-stance to mid-stance), and :func:`gaitmap_stride_speeds` compares the
  per-stride forward speed of the 2D filter with the motion-capture markers
  (:class:`StrideSpeeds`). ``benchmarks/accuracy/validate_zupt.py`` prints and plots the comparison;
  ``tests/test_zupt.py`` checks it with thresholds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sspinn.estimator.zupt import SagittalZuptKalman, stance_phases


# --------------------------------------------------------------------------------------------
# 3D foot IMUs in gaitmap's sensor frame → sagittal signals
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SagittalSignals:
    """Sagittal-plane signals of a 3D foot IMU (see :func:`sagittal_from_gaitmap_frame`)."""

    acc_xy: np.ndarray
    """(T, 2) specific force (anterior, up), m/s²."""
    gyr_z: np.ndarray
    """(T,) sagittal angular rate, rad/s, counter-clockwise seen from the right (toe up +)."""
    rotation: np.ndarray
    """(3, 3) rotation applied to the gaitmap-frame vectors (aligned = rotation @ raw)."""
    tilt_deg: float
    """Angle between the sensor z axis and the vertical at rest, °, removed by the alignment."""
    heading_deg: float
    """Rotation about the vertical that made the principal gyro axis the medio-lateral y axis, °."""


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation matrix taking unit vector a onto unit vector b (Rodrigues)."""
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    s2 = float(np.dot(v, v))
    if s2 < 1e-24:
        if c > 0:
            return np.eye(3)
        raise ValueError("the gravity direction at rest is opposite to +z: is the sensor upside down?")
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + vx + vx @ vx * ((1.0 - c) / s2)


def sagittal_from_gaitmap_frame(
    acc_xyz: np.ndarray,
    gyr_xyz_dps: np.ndarray,
    sample_rate_hz: float,
    align: bool = True,
    rest_gyro_threshold_dps: float = 34.0,
    rest_window_s: float = 0.05,
) -> SagittalSignals:
    """Sagittal signals of a foot IMU given in gaitmap's sensor frame.

    gaitmap's foot sensor frame (both feet alike, right-handed): x forward (towards the toe),
    y to the left, z up when the foot is flat; acc in m/s², gyro in **deg/s**. Sagittal signals in
    sspinn's convention: acc_x = acc_x, acc_y = acc_z, and gyr_z = −gyr_y in rad/s (a rotation
    about gaitmap's +y, pointing left, lowers the toe; sspinn's positive angles raise it). For the
    example recording this mapping is checked from the data in ``benchmarks/accuracy/validate_zupt.py``
    (gravity on +z at rest, gyr_y > 0 at push-off, acc_x > 0 after toe-off, positive forward speed).

    With ``align`` (default) the sensor is first aligned to the foot as gaitmap's preprocessing
    does (``align_dataset_to_gravity`` and ``PcaAlignment``): (1) rotate so that the mean specific
    force at rest points along +z (rest = runs of at least ``rest_window_s`` s with the 3D gyro
    norm below ``rest_gyro_threshold_dps``); (2) rotate about z so that the principal axis of the
    horizontal gyro components outside rest (the axis the foot mostly rotates about, medio-lateral)
    becomes the y axis, by the smallest such rotation (|heading| ≤ 90°, so x stays forward). Without
    it a mounting tilt or yaw mixes out-of-plane rotations into gyr_y and shortens forward
    distances (on the example recording: tilt 14–16°, yaw 16–20°; turns then corrupt the pitch
    integral by tens of degrees).
    """
    acc = np.asarray(acc_xyz, dtype=float)
    gyr = np.asarray(gyr_xyz_dps, dtype=float)
    if acc.ndim != 2 or acc.shape[1] != 3 or gyr.shape != acc.shape:
        raise ValueError(f"acc_xyz and gyr_xyz_dps must both have shape (T, 3), got {acc.shape} and {gyr.shape}")
    if not (np.isfinite(acc).all() and np.isfinite(gyr).all()):
        raise ValueError("acc_xyz / gyr_xyz_dps contain NaN or inf")
    if not np.isfinite(sample_rate_hz) or sample_rate_hz <= 0:
        raise ValueError(f"sample_rate_hz must be a positive number (Hz), got {sample_rate_hz!r}")
    rotation = np.eye(3)
    tilt = heading = 0.0
    if align:
        quiet = np.linalg.norm(gyr, axis=1) < rest_gyro_threshold_dps
        min_len = max(1, int(round(rest_window_s * sample_rate_hz)))
        rest = np.zeros(len(acc), dtype=bool)
        for s, e in stance_phases(quiet):
            if e - s >= min_len:
                rest[s:e] = True
        if not rest.any():
            raise ValueError("no rest period found for the gravity alignment (3D gyro norm never quiet)")
        g_dir = acc[rest].mean(axis=0)
        g_dir /= np.linalg.norm(g_dir)
        r_tilt = _rotation_between(g_dir, np.array([0.0, 0.0, 1.0]))
        tilt = math.degrees(math.acos(np.clip(g_dir[2], -1.0, 1.0)))
        w_xy = (gyr[~rest] @ r_tilt.T)[:, :2]
        eigval, eigvec = np.linalg.eigh(w_xy.T @ w_xy)
        ml = eigvec[:, int(np.argmax(eigval))]
        psi = math.atan(ml[0] / ml[1]) if ml[1] != 0 else math.pi / 2
        c, s = math.cos(psi), math.sin(psi)
        r_heading = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        rotation = r_heading @ r_tilt
        heading = math.degrees(psi)
        acc = acc @ rotation.T
        gyr = gyr @ rotation.T
    return SagittalSignals(
        acc_xy=np.column_stack((acc[:, 0], acc[:, 2])),
        gyr_z=-np.deg2rad(gyr[:, 1]),
        rotation=rotation,
        tilt_deg=tilt,
        heading_deg=heading,
    )


# --------------------------------------------------------------------------------------------
# Validation on gaitmap's example recording ($SSPINN_SHARED_DATA/gaitmap_foot_imu)
# --------------------------------------------------------------------------------------------
FEET: tuple[str, ...] = ("left", "right")
_IMU_AXES = ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")
_FOOT_MARKERS = ("TOE", "FCC", "FM5")  # toe, heel (calcaneus), fifth metatarsal head


@dataclass(frozen=True)
class GaitmapExample:
    """gaitmap's example walking recording: two foot IMUs, foot markers and stride events."""

    imu: dict[str, np.ndarray]
    """foot → (T, 6) acc_x, acc_y, acc_z (m/s²), gyr_x, gyr_y, gyr_z (deg/s), gaitmap sensor frame."""
    imu_rate_hz: float
    markers: dict[str, np.ndarray]
    """marker name (e.g. ``L_TOE``) → (N, 3) position in m, lab frame with z up (x, y horizontal)."""
    mocap_rate_hz: float
    strides: list[dict[str, int | str]]
    """rows of ``stride_events_sample.csv``: s_id, foot, start, end, ic, tc, min_vel, pre_ic (IMU samples)."""


def _read_two_row_header(path: Path) -> tuple[list[str], list[str], np.ndarray]:
    with path.open() as fh:
        first = fh.readline().rstrip("\n").split(",")
        second = fh.readline().rstrip("\n").split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=2, ndmin=2)
    return first[1:], second[1:], data[:, 1:]


def load_gaitmap_example(path: Path, imu_rate_hz: float = 204.8, mocap_rate_hz: float = 100.0) -> GaitmapExample:
    """Read ``imu_sample.csv``, ``mocap_sample.csv`` and ``stride_events_sample.csv`` from ``path``.

    Both recordings start at the same instant (checked in ``benchmarks/accuracy/validate_zupt.py``: equal
    durations, 38.71 s, and the best lag between the two speed signals is below one mocap sample).
    """
    path = Path(path)
    sensors, axes, data = _read_two_row_header(path / "imu_sample.csv")
    imu = {}
    for foot in FEET:
        cols = []
        for axis in _IMU_AXES:
            matches = [i for i, (s, a) in enumerate(zip(sensors, axes)) if s == f"{foot}_sensor" and a == axis]
            if len(matches) != 1:
                raise ValueError(f"{path / 'imu_sample.csv'}: no unique column {foot}_sensor/{axis}")
            cols.append(matches[0])
        imu[foot] = data[:, cols]
    names, coords, mdata = _read_two_row_header(path / "mocap_sample.csv")
    markers = {}
    for name in dict.fromkeys(names):
        cols = [next(i for i, (n, c) in enumerate(zip(names, coords)) if n == name and c == ax) for ax in "xyz"]
        markers[name] = mdata[:, cols] / 1000.0
    strides: list[dict[str, int | str]] = []
    with (path / "stride_events_sample.csv").open() as fh:
        header = fh.readline().strip().split(",")
        for line in fh:
            values = line.strip().split(",")
            if len(values) != len(header):
                continue
            row: dict[str, int | str] = {}
            for key, value in zip(header, values):
                row[key] = value if key == "foot" else int(round(float(value)))
            strides.append(row)
    return GaitmapExample(imu, imu_rate_hz, markers, mocap_rate_hz, strides)


def foot_marker(example: GaitmapExample, foot: str, marker: str = "FCC") -> np.ndarray:
    """(N, 3) trajectory (m) of one foot marker (``TOE``, ``FCC`` = heel, ``FM5``) or their ``centroid``."""
    side = foot[0].upper()
    if marker == "centroid":
        return np.mean([example.markers[f"{side}_{m}"] for m in _FOOT_MARKERS], axis=0)
    if marker not in _FOOT_MARKERS:
        raise ValueError(f"marker must be one of {', '.join(_FOOT_MARKERS)} or 'centroid', got {marker!r}")
    return example.markers[f"{side}_{marker}"]


@dataclass(frozen=True)
class StrideSpeeds:
    """Per-stride mean forward speed from the ZUPT filter and from motion capture (m/s)."""

    s_id: np.ndarray
    foot: np.ndarray
    duration_s: np.ndarray
    zupt: np.ndarray
    """Stride length along the foot's sagittal (forward) axis of the 2D filter / duration."""
    mocap: np.ndarray
    """Horizontal displacement magnitude of the mocap marker / duration."""
    turn_deg: np.ndarray
    """Change of the foot's horizontal heading (heel → toe markers) over the stride, °."""
    signal_rmse: np.ndarray
    """RMS difference within the stride between the ZUPT speed |v_x| and the marker's horizontal
    speed (central differences at 100 Hz), m/s; the sensor and the marker are different points."""

    @property
    def error(self) -> np.ndarray:
        """ZUPT − mocap, m/s."""
        return self.zupt - self.mocap

    def summary(self, mask: np.ndarray | None = None) -> dict[str, float]:
        """n, mean, SD, RMSE and max |·| of the per-stride speed error (m/s) over ``mask``."""
        err = self.error if mask is None else self.error[mask]
        return {
            "n": float(len(err)),
            "mean": float(err.mean()),
            "sd": float(err.std(ddof=1)) if len(err) > 1 else 0.0,
            "rmse": float(np.sqrt(np.mean(err**2))),
            "max": float(np.abs(err).max()),
        }


def gaitmap_stride_speeds(
    example: GaitmapExample,
    estimator: SagittalZuptKalman | None = None,
    align: bool = True,
    marker: str = "FCC",
) -> tuple[StrideSpeeds, dict[str, SagittalZuptKalman]]:
    """Per-stride speeds of the example recording: ZUPT (2D, per foot) vs motion capture.

    Strides run from one mid-stance (``start`` = ``min_vel``) to the next (``end``), both inside
    stance. ZUPT: forward displacement ``position_[end, 0] − position_[start, 0]`` over the
    duration; the 2D filter has no heading, so this is the distance along the foot's path in its
    sagittal plane. Mocap: the horizontal (x, y) displacement magnitude of ``marker`` (default the
    heel marker FCC, whose per-stride trajectory is gaitmap's own reference ``position_sample.csv``;
    the IMU is mounted laterally at the heel) between the same instants (IMU sample × 100/204.8,
    rounded; gaitmap derived the events the other way round), not a fixed lab axis, since the
    subject walks there and back with a turn. Returns the table and the fitted estimator per foot.
    """
    template = SagittalZuptKalman() if estimator is None else estimator
    fits: dict[str, SagittalZuptKalman] = {}
    rows = []
    ratio = example.mocap_rate_hz / example.imu_rate_hz
    for foot in FEET:
        raw = example.imu[foot]
        sig = sagittal_from_gaitmap_frame(raw[:, :3], raw[:, 3:], example.imu_rate_hz, align=align)
        est = template.clone().estimate(sig.acc_xy, sig.gyr_z, example.imu_rate_hz)
        fits[foot] = est
        point = foot_marker(example, foot, marker)
        point_speed = np.linalg.norm(np.gradient(point[:, :2], axis=0), axis=1) * example.mocap_rate_hz
        zupt_speed = np.abs(est.velocity_[:, 0])
        t_imu = np.arange(len(zupt_speed)) / example.imu_rate_hz
        axis = foot_marker(example, foot, "TOE") - foot_marker(example, foot, "FCC")
        heading = np.arctan2(axis[:, 1], axis[:, 0])
        for stride in example.strides:
            if stride["foot"] != foot:
                continue
            s, e = int(stride["start"]), int(stride["end"])
            duration = (e - s) / example.imu_rate_hz
            ms, me = int(round(s * ratio)), int(round(e * ratio))
            turn = math.degrees(math.remainder(heading[me] - heading[ms], 2 * math.pi))
            idx = np.arange(ms, me + 1)
            diff = np.interp(idx / example.mocap_rate_hz, t_imu, zupt_speed) - point_speed[idx]
            rows.append(
                (
                    int(stride["s_id"]),
                    foot,
                    duration,
                    (est.position_[e, 0] - est.position_[s, 0]) / duration,
                    float(np.linalg.norm(point[me, :2] - point[ms, :2])) / duration,
                    turn,
                    float(np.sqrt(np.mean(diff**2))),
                )
            )
    cols = list(zip(*rows))
    table = StrideSpeeds(
        s_id=np.array(cols[0], dtype=int),
        foot=np.array(cols[1]),
        duration_s=np.array(cols[2]),
        zupt=np.array(cols[3]),
        mocap=np.array(cols[4]),
        turn_deg=np.array(cols[5]),
        signal_rmse=np.array(cols[6]),
    )
    return table, fits
