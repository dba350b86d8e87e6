"""Readers that turn other recording formats into :class:`sspinn.data.dataset.Recording` (100 Hz).

* :func:`read_averaged_stride` — a folder with ``signals.csv`` + ``meta.json`` holding one
  ensemble-averaged stride (as in ``$SSPINN_SHARED_DATA/dorschky_P03_walking``), resampled to 100 Hz
  with the stride duration and, for SSPINNpose's "averaged" protocol, repeated periodically.
* :func:`read_csv_recording` — a plain CSV of IMU signals with a column map, any sample rate.

Resampling uses SciPy's cubic splines (periodic for averaged strides).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from sspinn.data.dataset import SAMPLE_RATE_HZ, DataFormatError, Labels, Recording, read_csv_table, read_json_data
from sspinn.data.signal_checks import check_recording
from sspinn.model.body import IMUPlacement
from sspinn.model.conventions import GRAVITY, GRF, IMU_CHANNELS, JOINTS, SEGMENTS
from sspinn.resource_limits import MAX_CONFIG_BYTES

#: OpenSim coordinate names of our joints (as used in $SSPINN_SHARED_DATA): hip_r → hip_flexion_r.
OPENSIM_NAMES = {j: j.replace("hip", "hip_flexion").replace("knee", "knee_angle").replace("ankle", "ankle_angle") for j in JOINTS}
#: Column names of the averaged-stride label files → sspinn label columns.
_AVERAGED_LABELS = {
    **{f"{OPENSIM_NAMES[j]}_angle": j for j in JOINTS},
    **{f"{OPENSIM_NAMES[j]}_moment": f"tau_{j}" for j in JOINTS},
}


@contextlib.contextmanager
def _named(path: Path, name: str) -> Iterator[None]:
    """Re-raise a validation error of the recording ``name`` made from ``path`` naming the file
    (sample numbers are those of the recording resampled to 100 Hz)."""
    try:
        yield
    except DataFormatError as exc:
        raise DataFormatError(f"{path} (as 100 Hz samples): {str(exc).removeprefix(name + ': ')}") from None


def _read_table(path: Path) -> tuple[list[str], np.ndarray]:
    """:func:`sspinn.data.dataset.read_csv_table`, plus existence and finiteness checks."""
    if not path.exists():
        raise DataFormatError(f"{path}: file not found")
    names, data = read_csv_table(path)
    bad = ~np.isfinite(data)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise DataFormatError(f"{path}: column {names[c]!r} has a non-finite value at row {r + 2}")
    return names, data


def read_averaged_stride(
    folder: str | Path,
    height: float = 1.75,
    mass: float = 70.0,
    periods: int = 1,
    placement: IMUPlacement | None = None,
) -> Recording:
    """One averaged stride (``signals.csv`` + ``meta.json``) as a 100 Hz recording.

    The N samples of the file span one stride of ``stride_duration_s`` (sample N+1 would be the
    next right heel strike); they are interpolated with a periodic cubic spline and sampled at
    100 Hz over ``periods`` strides (circular padding for the averaged protocol). IMU positions in
    ``meta.json`` become the nominal placement (scaled otherwise from ``height``). Labels: the
    joint angles and moments present (N·m) and the GRFs (converted from BW to N with ``mass``),
    and the mean speed. Height and mass are not recorded in these files: pass what you assume.
    """
    folder = Path(folder)
    meta_path = folder / "meta.json"
    if not meta_path.exists():
        raise DataFormatError(f"{meta_path}: file not found")
    meta: dict[str, Any] = read_json_data(meta_path, MAX_CONFIG_BYTES)
    if not isinstance(meta, dict):
        raise DataFormatError(f"{meta_path}: expected a JSON object, got a {type(meta).__name__}")
    for key in ("units", "speed_mps", "participant"):
        if not isinstance(meta.get(key, {}), dict):
            raise DataFormatError(f"{meta_path}: {key} must be a JSON object, got {meta[key]!r}")
    try:
        duration = float(meta["stride_duration_s"]["mean"])
        n_file = int(meta["samples_per_stride"])
    except (KeyError, TypeError, ValueError):
        raise DataFormatError(f"{meta_path}: needs stride_duration_s.mean and samples_per_stride") from None
    if not 0.2 < duration < 3.0:
        raise DataFormatError(f"{meta_path}: stride duration {duration} s is implausible (expected 0.2–3 s)")
    names, data = _read_table(folder / "signals.csv")
    if data.shape[0] != n_file:
        raise DataFormatError(f"{folder / 'signals.csv'}: {data.shape[0]} rows but meta.json says {n_file} samples per stride")
    col = {n: i for i, n in enumerate(names)}
    segments = tuple(s for s in SEGMENTS if all(f"{s}_{c}" in col for c in IMU_CHANNELS))
    if not segments:
        raise DataFormatError(f"{folder / 'signals.csv'}: no complete IMU (columns <segment>_acc_x, _acc_y, _gyr_z)")
    t_file = np.arange(n_file + 1) * duration / n_file
    n_out = int(round(periods * duration * SAMPLE_RATE_HZ))
    t_out = np.arange(n_out) / SAMPLE_RATE_HZ

    def resample(column: np.ndarray) -> np.ndarray:
        spline = CubicSpline(t_file, np.append(column, column[0]), bc_type="periodic")
        return spline(np.mod(t_out, duration))

    imu = np.stack([[resample(data[:, col[f"{s}_{c}"]]) for c in IMU_CHANNELS] for s in segments]).transpose(2, 0, 1)
    labels: dict[str, np.ndarray] = {}
    for src, dst in _AVERAGED_LABELS.items():
        if src in col:
            labels[dst] = resample(data[:, col[src]])
    weight = mass * GRAVITY
    for g in GRF:
        if g in col:
            if meta.get("units", {}).get(g, "BW") != "BW":
                raise DataFormatError(f"{meta_path}: expected {g} in BW, got {meta['units'][g]!r}")
            labels[g] = resample(data[:, col[g]]) * weight
    speed = meta.get("speed_mps", {}).get("mean")
    if speed is not None:
        if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not np.isfinite(speed):
            raise DataFormatError(f"{meta_path}: speed_mps.mean must be a finite number (m/s), got {speed!r}")
        labels["speed"] = np.full(n_out, float(speed))
    positions = meta.get("imu_position_in_segment_frame_m") or {}
    if placement is None:
        placement = IMUPlacement.default(height)
        if positions:
            try:
                placement = IMUPlacement(positions={
                    s: (float(positions.get(s, placement.positions[s])[0]), float(positions.get(s, placement.positions[s])[1]))
                    for s in SEGMENTS})
            except (TypeError, ValueError, IndexError, KeyError, AttributeError) as exc:
                raise DataFormatError(f"{meta_path}: imu_position_in_segment_frame_m must map segments to [x, y, ...] "
                                      f"in metres ({type(exc).__name__}: {exc})") from None
    with _named(folder / "signals.csv", folder.name):
        rec = Recording(
            name=folder.name,
            imu=imu,
            segments=segments,
            height=height,
            mass=mass,
            subject=str(meta.get("participant", {}).get("participantName", folder.name)),
            placement=placement,
            labels=Labels.from_columns(labels, n_out) if labels else None,
            provenance={"source": str(folder), "kind": "averaged stride", "periods": periods, "stride_duration_s": duration,
                        "assumed_height_m": height, "assumed_mass_kg": mass, "original": meta.get("source", "")},
        )
    check_recording(rec, f"{folder / 'signals.csv'} (as 100 Hz samples)")
    return rec


def read_csv_recording(
    path: str | Path,
    column_map: dict[str, str],
    sample_rate_hz: float,
    height: float,
    mass: float,
    gyro_unit: str = "rad/s",
    acc_unit: str = "m/s^2",
    subject: str = "unknown",
    placement: IMUPlacement | None = None,
) -> Recording:
    """A plain CSV of IMU signals → 100 Hz recording.

    ``column_map`` maps sspinn channel names (``<segment>_acc_x``, ``_acc_y``, ``_gyr_z``) to the
    file's column names; every IMU must be complete. Units are converted from ``gyro_unit``
    ("rad/s" or "deg/s") and ``acc_unit`` ("m/s^2" or "g"); the signals are resampled with a cubic
    spline from ``sample_rate_hz`` to 100 Hz.
    """
    path = Path(path)
    if sample_rate_hz <= 0:
        raise DataFormatError(f"{path}: sample rate must be > 0 Hz, got {sample_rate_hz}")
    gyro_scale = {"rad/s": 1.0, "deg/s": np.pi / 180}.get(gyro_unit)
    acc_scale = {"m/s^2": 1.0, "g": GRAVITY}.get(acc_unit)
    if gyro_scale is None or acc_scale is None:
        raise DataFormatError(f"{path}: gyro_unit must be 'rad/s' or 'deg/s' and acc_unit 'm/s^2' or 'g'")
    names, data = _read_table(path)
    col = {n: i for i, n in enumerate(names)}
    unknown = [k for k in column_map if not any(k == f"{s}_{c}" for s in SEGMENTS for c in IMU_CHANNELS)]
    if unknown:
        raise DataFormatError(f"{path}: unknown sspinn channel(s) {unknown} in the column map")
    absent = [v for v in column_map.values() if v not in col]
    if absent:
        raise DataFormatError(f"{path}: column(s) {absent} of the column map are not in the file (has: {names})")
    segments = tuple(s for s in SEGMENTS if any(k.startswith(f"{s}_") for k in column_map))
    for s in segments:
        lack = [f"{s}_{c}" for c in IMU_CHANNELS if f"{s}_{c}" not in column_map]
        if lack:
            raise DataFormatError(f"{path}: IMU {s} is incomplete, missing {lack} in the column map")
    n = data.shape[0]
    t_in = np.arange(n) / sample_rate_hz
    t_out = np.arange(int(np.floor(t_in[-1] * SAMPLE_RATE_HZ)) + 1) / SAMPLE_RATE_HZ
    imu = np.empty((len(t_out), len(segments), 3))
    for i, s in enumerate(segments):
        for j, c in enumerate(IMU_CHANNELS):
            x = data[:, col[column_map[f"{s}_{c}"]]] * (gyro_scale if c == "gyr_z" else acc_scale)
            imu[:, i, j] = CubicSpline(t_in, x)(t_out) if sample_rate_hz != SAMPLE_RATE_HZ else x
    with _named(path, path.stem):
        rec = Recording(
            name=path.stem, imu=imu, segments=segments, height=height, mass=mass, subject=subject,
            placement=placement or IMUPlacement.default(height),
            provenance={"source": str(path), "sample_rate_hz_original": sample_rate_hz, "column_map": column_map},
        )
    check_recording(rec, f"{path} (as 100 Hz samples)")
    return rec
