"""Synthetic 3D sensors with known mountings, to test the sagittal sensor calibration
(:mod:`sspinn.imu.calibration`; the tests, and ``benchmarks/accuracy/validate_sensor_calibration.py``).

Recipe (:func:`mounting_trials`):

1. A walking gait of the sagittal model — q, u, q̈ of one periodic stride on the 100 Hz grid
   (``tests/fixtures/predicted_walk_1.3.csv``, with its GRF: :func:`predictive.solve_predictive` at
   1.3 m/s for the 1.75 m, 70 kg Winter body, written by ``benchmarks/accuracy/validate_sensor_calibration.py``) — repeated
   for ``strides`` strides, after ``standing_s`` of quiet standing in the zero pose (or none);
   the 2D virtual IMUs (:func:`sspinn.model.kinematics.virtual_imu`, default placement, angle 0) give
   each segment's ``acc_x, acc_y, gyr_z``.
2. Each sensor gets a uniformly random 3D mounting ``M`` (sensor-from-segment rotation) and
   out-of-plane motion (:func:`embed_in_3d`): the segment rolls and twists by small band-limited
   angles α (about its x axis) and β (about its y axis), RMS :attr:`OutOfPlane.angle_rms_deg`,
   0.3–3 Hz, which tilt gravity and the sagittal rate out of the plane and add (α̇, β̇) to the
   rate; plus band-limited out-of-plane acceleration (``acc_rms``, 0.5–10 Hz, along z), a
   constant gyroscope bias and white noise.
3. The calibration recovers the segment axes in the sensor frame; :func:`calibration_errors`
   gives the axis error (angle between the recovered and the true medio-lateral axis, 180° for
   a wrong sign) and the in-plane angle error (signed angle of the recovered y axis from the true
   one about the true z axis).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from sspinn.data.dataset import read_csv_table
from sspinn.data.sensor_noise import band_limited_process
from sspinn.imu.calibration import Calibration, calibrate
from sspinn.imu.sensor_map import SensorAssignment
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.conventions import COORDINATES, GRF, SEGMENTS
from sspinn.model.kinematics import virtual_imu

RATE_HZ = 100.0
GAIT_COLUMNS = ("time", *COORDINATES, *(f"d_{c}" for c in COORDINATES), *(f"dd_{c}" for c in COORDINATES), *GRF)


@dataclass(frozen=True)
class OutOfPlane:
    """Out-of-plane motion and sensor noise of the synthetic sensors."""

    angle_rms_deg: float = 2.0
    """RMS of the out-of-plane roll and twist of each sensor, degrees."""
    acc_rms: float = 0.5
    """RMS of the band-limited out-of-plane acceleration (0.5–10 Hz, along the sensor z), m/s²."""
    gyro_bias_rad_s: float = 0.02
    """Standard deviation of the constant gyroscope bias drawn per axis, rad/s."""
    acc_noise: float = 0.05
    """White accelerometer noise, m/s² RMS."""
    gyro_noise: float = 0.01
    """White gyroscope noise, rad/s RMS."""


class Gait(NamedTuple):
    """One stride at 100 Hz: q, u, q̈ (n, 9) and the GRF (n, 4) N (:data:`sspinn.model.conventions.GRF` order)."""

    q: np.ndarray
    u: np.ndarray
    qdd: np.ndarray
    grf: np.ndarray


def write_gait_csv(path: str | Path, gait: Gait) -> Path:
    """One stride as CSV (columns :data:`GAIT_COLUMNS`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    t = np.arange(len(gait.q)) / RATE_HZ
    np.savetxt(path, np.column_stack([t, gait.q, gait.u, gait.qdd, gait.grf]), delimiter=",", header=",".join(GAIT_COLUMNS),
               comments="", fmt="%.9g")
    return path


def read_gait_csv(path: str | Path) -> Gait:
    """The stride written by :func:`write_gait_csv`."""
    names, table = read_csv_table(Path(path))
    col = {n: i for i, n in enumerate(names)}
    q, u, qdd = (table[:, [col[f"{p}{c}"] for c in COORDINATES]] for p in ("", "d_", "dd_"))
    return Gait(q, u, qdd, table[:, [col[g] for g in GRF]])


def synthetic_walk(q: np.ndarray, u: np.ndarray, qdd: np.ndarray, strides: int = 12, standing_s: float = 2.0,
                   body: BodyParameters | None = None) -> np.ndarray:
    """(n, 7, 3) 2D virtual IMU signals: ``standing_s`` of standing in the zero pose, then the
    stride repeated ``strides`` times (periodic, so the joins are smooth)."""
    body = body or BodyParameters.from_anthropometry(1.75, 70.0)
    placement = IMUPlacement.default(body.height)
    walk = virtual_imu(q, u, qdd, placement, body.vector())
    parts = [np.tile(walk, (strides, 1, 1))]
    n_stand = int(round(standing_s * RATE_HZ))
    if n_stand:
        q0 = np.zeros((n_stand, len(COORDINATES)))
        q0[:, 1] = body.standing_hip_height
        zero = np.zeros_like(q0)
        parts.insert(0, virtual_imu(q0, zero, zero, placement, body.vector()))
    return np.concatenate(parts, axis=0)


def random_mounting(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation (3, 3): sensor-from-segment (v_sensor = M · v_segment)."""
    return Rotation.random(random_state=rng).as_matrix()


def embed_in_3d(signals: np.ndarray, mounting: np.ndarray, rng: np.random.Generator, oop: OutOfPlane = OutOfPlane(),
                still: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(acc (n, 3) m/s², gyr (n, 3) rad/s) of a 3D sensor on a segment whose sagittal signals are
    ``signals`` (n, 3) [acc_x, acc_y, gyr_z], mounted with ``mounting`` (module docstring, step 2).
    The out-of-plane motion is off during the first ``still`` samples (quiet standing) and fades
    in over 0.5 s."""
    n = len(signals)
    envelope = np.clip((np.arange(n) - still) / (0.5 * RATE_HZ), 0.0, 1.0)
    envelope = 0.5 - 0.5 * np.cos(np.pi * envelope)
    d_envelope = np.gradient(envelope) * RATE_HZ
    angles, rates, _ = band_limited_process(rng, n, (2,), np.radians(oop.angle_rms_deg), 0.3, 3.0, RATE_HZ)
    angles, rates = angles * envelope[:, None], rates * envelope[:, None] + angles * d_envelope[:, None]
    acc_z = band_limited_process(rng, n, (), oop.acc_rms, 0.5, 10.0, RATE_HZ)[0] * envelope
    tilt = Rotation.from_euler("xy", angles).as_matrix()  # segment-from-sagittal frame, transposed below
    f_sag = np.column_stack([signals[:, 0], signals[:, 1], np.zeros(n)])
    w_sag = np.column_stack([np.zeros(n), np.zeros(n), signals[:, 2]])
    f_seg = np.einsum("nji,nj->ni", tilt, f_sag) + np.column_stack([np.zeros(n), np.zeros(n), acc_z])
    w_seg = np.einsum("nji,nj->ni", tilt, w_sag) + np.column_stack([rates, np.zeros(n)])
    bias = rng.normal(scale=oop.gyro_bias_rad_s, size=3)
    acc = f_seg @ mounting.T + rng.normal(scale=oop.acc_noise, size=(n, 3))
    gyr = w_seg @ mounting.T + bias + rng.normal(scale=oop.gyro_noise, size=(n, 3))
    return acc, gyr


def calibration_errors(rotation: np.ndarray, mounting: np.ndarray) -> tuple[float, float]:
    """(axis error, in-plane angle error), degrees, of a calibration ``rotation`` (rows: segment
    x, y, z in the sensor frame) against the true ``mounting`` (columns: the same)."""
    z_true, y_true = mounting[:, 2], mounting[:, 1]
    z, y = rotation[2], rotation[1]
    axis_error = float(np.degrees(np.arccos(np.clip(z @ z_true, -1.0, 1.0))))
    y_plane = y - (y @ z_true) * z_true
    angle_error = float(np.degrees(np.arctan2(np.cross(y_true, y_plane) @ z_true, y_true @ y_plane)))
    return axis_error, angle_error


def turned_in_plane(rotation: np.ndarray, angle: float) -> np.ndarray:
    """A calibration ``rotation`` (rows: segment x, y, z in the sensor frame) whose in-plane axes
    are turned by ``angle`` (rad) about z: the projected signals turn by R(angle)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.array(rotation, dtype=float)
    out[:2] = np.array([[c, -s], [s, c]]) @ out[:2]
    return out


def mounting_trials(q: np.ndarray, u: np.ndarray, qdd: np.ndarray, trials: int = 50, seed: int = 0,
                    standing_s: float = 2.0, strides: int = 12, oop: OutOfPlane = OutOfPlane(),
                    walking_angles: str = "joints",
                    refine: Callable[[np.ndarray], dict[str, float]] | None = None) -> dict[str, np.ndarray]:
    """Calibrate ``trials`` random mountings of all seven sensors (``walking_angles``: the
    in-plane method without standing, see :func:`~sspinn.imu.calibration.calibrate`); returns per
    segment kind and overall arrays ``axis`` and ``angle`` (deg; one entry per trial and sensor)
    and ``sign_ok``. ``refine`` takes the calibrated (n, 7, 3) sagittal signals (``SEGMENTS``
    order) and returns in-plane corrections (rad) per segment name, applied with
    :func:`turned_in_plane` before the errors are measured."""
    rng = np.random.default_rng(seed)
    imu2d = synthetic_walk(q, u, qdd, strides, standing_s)
    assignments = {s: SensorAssignment(f"sensor_{s}", s) for s in SEGMENTS}
    axis, angle, segs = [], [], []
    for _ in range(trials):
        mountings = {s: random_mounting(rng) for s in SEGMENTS}
        still = int(round(standing_s * RATE_HZ))
        signals = {s: embed_in_3d(imu2d[:, i], mountings[s], rng, oop, still) for i, s in enumerate(SEGMENTS)}
        cal: Calibration = calibrate(signals, assignments, RATE_HZ, standing="auto" if standing_s else None,
                                     walking_angles=walking_angles)
        corrections = {}
        if refine is not None:
            corrections = refine(np.stack([cal.sensors[s].project(*signals[s]) for s in SEGMENTS], axis=1))
        for s in SEGMENTS:
            a, b = calibration_errors(turned_in_plane(cal.sensors[s].rotation, corrections.get(s, 0.0)), mountings[s])
            axis.append(a)
            angle.append(b)
            segs.append(s)
    axis_arr, angle_arr, seg_arr = np.array(axis), np.array(angle), np.array(segs)
    out = {"axis": axis_arr, "angle": angle_arr, "segment": seg_arr, "sign_ok": axis_arr < 90.0}
    return out


def summary(result: dict[str, np.ndarray]) -> list[tuple[str, float, float, float, float, int]]:
    """Rows (group, median |axis error|, max, median |angle error|, max, wrong signs), degrees."""
    rows = []
    groups = [("all", np.ones(len(result["axis"]), dtype=bool))]
    groups += [(s, result["segment"] == s) for s in SEGMENTS]
    for name, m in groups:
        ax, an = result["axis"][m], np.abs(result["angle"][m])
        rows.append((name, float(np.median(ax)), float(ax.max()), float(np.median(an)), float(an.max()), int((ax >= 90).sum())))
    return rows

