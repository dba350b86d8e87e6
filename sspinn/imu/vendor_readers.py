"""Readers of vendor IMU and force files into :class:`sspinn.imu.stream.IMUStream` (raw 3D, per
sensor) and plain arrays; every file may be plain text or gzip-compressed (``.gz``).

* **OpenSim / OpenSense** (:func:`read_opensense`): ``<stem>_Accel.trc`` and ``<stem>_Gyro.trc``
  (one file per quantity, all sensors side by side: a TRC header of 5 lines, a blank line, then
  ``Frame#, Time`` and X/Y/Z per sensor; specific force in m/s² including gravity and angular
  rate in rad/s, each in the sensor's own frame — the TRC ``Units`` field, "m", is meaningless
  here and ignored), plus ``<stem>_Orientations.sto`` where present (one quaternion
  ``w,x,y,z`` per sensor and row; kept as information, calibration does not use it).
* **Xsens MT Manager text export** (:func:`read_xsens_txt`, one file per sensor): header lines
  starting with ``//`` (``// Update Rate: 100.0Hz`` is used if present), then a table separated
  by tabs, commas or semicolons whose header names ``PacketCounter``, ``SampleTimeFine``,
  ``Acc_X/Y/Z`` (m/s², gravity included), ``Gyr_X/Y/Z`` (rad/s), optionally ``Mag_*`` and
  ``Quat_q0…q3``. Assumptions: ``SampleTimeFine`` counts 1e-4 s ticks on the clock all sensors of
  one recording share (a 32-bit counter, unwrapped here); ``PacketCounter`` is a 16-bit counter
  (unwrapped), its jumps are dropped samples; without ``SampleTimeFine`` the time is
  ``PacketCounter / update rate``; an empty field is a missing value (a gap). The sensor's name is
  the device ID when the file name is MT Manager's ``MT_<...>_<DEVICEID>.txt``, else the file
  stem. ``FreeAcc_*`` (gravity removed) or ``VelInc``/``OriInc`` (strap-down integrals) alone are
  rejected with a message.
* **OpenSim motion/storage tables** (:func:`read_mot`, e.g. treadmill GRF ``.mot``): header lines
  up to ``endheader``, then a column-name line and numbers; :func:`read_treadmill_grf` picks the
  per-side forces.

Errors are :class:`sspinn.imu.stream.IMUImportError`, one line naming the file (and sensor).
"""

from __future__ import annotations

import gzip
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Final

import numpy as np

from sspinn.data.opensim_files import OpenSimFormatError, read_opensim_table
from sspinn.imu.stream import IMUImportError, IMUStream, SensorSignals

#: File-name suffixes of the OpenSense export (before an optional ``.gz``).
OPENSENSE_SUFFIXES: Final = {"accel": "_Accel.trc", "gyro": "_Gyro.trc", "orientations": "_Orientations.sto"}
#: Tick length of Xsens ``SampleTimeFine``, s.
XSENS_TICK_S: Final = 1e-4
_XSENS_DEVICE_ID = re.compile(r"^MT_.*_([0-9A-Fa-f]{8})$")


def read_text(path: Path) -> str:
    """The text of a plain or gzip-compressed file (UTF-8, a byte-order mark ignored)."""
    path = Path(path)
    if not path.exists():
        raise IMUImportError(f"{path}: file not found")
    raw = path.read_bytes()
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError) as exc:
            raise IMUImportError(f"{path}: a damaged gzip file ({exc})") from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise IMUImportError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def _float(path: Path, row: int, text: str) -> float:
    text = text.strip()
    if text == "":
        return np.nan
    try:
        return float(text)
    except ValueError:
        raise IMUImportError(f"{path}: line {row}: {text!r} is not a number") from None


def _stem(path: Path) -> str:
    name = Path(path).name
    return name[:-3] if name.endswith(".gz") else name


# ---------------------------------------------------------------------------------- OpenSense
def read_trc_vectors(path: str | Path) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
    """(time (n,) s, name → (n, 3) X/Y/Z values, DataRate Hz) of a TRC file with one 3-vector
    per name (as OpenSense writes accelerations and angular rates). Blank values are NaN."""
    path = Path(path)
    lines = read_text(path).splitlines()
    if len(lines) < 7 or not lines[0].startswith("PathFileType"):
        raise IMUImportError(f"{path}: not a TRC file (expected 'PathFileType' on line 1 and a 5-line header)")
    keys, values = lines[1].split("\t"), lines[2].split("\t")
    header = {k.strip(): v.strip() for k, v in zip(keys, values)}
    try:
        rate = float(header["DataRate"])
    except (KeyError, ValueError):
        raise IMUImportError(f"{path}: line 3 must give DataRate (Hz), got {lines[2]!r}") from None
    names_line = [x.strip() for x in lines[3].split("\t")]
    if len(names_line) < 3 or names_line[0] != "Frame#" or names_line[1] != "Time":
        raise IMUImportError(f"{path}: line 4 must start with 'Frame#' and 'Time', got {lines[3][:60]!r}")
    names = [n for n in names_line[2:] if n]
    if len(set(names)) != len(names):
        raise IMUImportError(f"{path}: duplicate sensor name(s) {sorted({n for n in names if names.count(n) > 1})} on line 4")
    width = 2 + 3 * len(names)
    rows: list[list[float]] = []
    for row, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        fields = line.rstrip("\r\n").split("\t")
        while len(fields) > width and not fields[-1].strip():
            fields.pop()
        if len(fields) > width:
            raise IMUImportError(f"{path}: line {row} has {len(fields)} values but {len(names)} sensors need {width}")
        fields += [""] * (width - len(fields))
        rows.append([_float(path, row, f) for f in fields])
    if len(rows) < 2:
        raise IMUImportError(f"{path}: fewer than 2 data rows")
    data = np.array(rows)
    if not np.isfinite(data[:, 1]).all():
        raise IMUImportError(f"{path}: the Time column has blank or non-numeric values")
    return data[:, 1], {n: data[:, 2 + 3 * i: 5 + 3 * i] for i, n in enumerate(names)}, rate


def read_sto_quaternions(path: str | Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(time (n,), name → (n, 4) unit quaternions w, x, y, z) of an OpenSense ``_Orientations.sto``."""
    path = Path(path)
    lines = read_text(path).splitlines()
    try:
        end = next(i for i, line in enumerate(lines) if line.strip().lower() == "endheader")
    except StopIteration:
        raise IMUImportError(f"{path}: no 'endheader' line (not an OpenSim .sto file)") from None
    names = [x.strip() for x in lines[end + 1].split("\t")]
    if not names or names[0].lower() != "time":
        raise IMUImportError(f"{path}: the column line after 'endheader' must start with 'time'")
    times, quats = [], []
    for row, line in enumerate(lines[end + 2:], start=end + 3):
        if not line.strip():
            continue
        fields = line.split("\t")
        if len(fields) != len(names):
            raise IMUImportError(f"{path}: line {row} has {len(fields)} fields, the header {len(names)}")
        times.append(_float(path, row, fields[0]))
        q = []
        for f in fields[1:]:
            parts = f.split(",")
            if len(parts) != 4:
                raise IMUImportError(f"{path}: line {row}: {f!r} is not a quaternion 'w,x,y,z'")
            q.append([_float(path, row, p) for p in parts])
        quats.append(q)
    arr = np.array(quats)
    return np.array(times), {n: arr[:, i] for i, n in enumerate(names[1:])}


def opensense_files(path: str | Path) -> dict[str, Path]:
    """The files of one OpenSense export given any of them (``<stem>_Accel.trc[.gz]``, ``_Gyro``
    or ``_Orientations.sto``): ``{"accel", "gyro"[, "orientations"]}``; accel and gyro must exist."""
    path = Path(path)
    name = _stem(path)
    suffix = next((s for s in OPENSENSE_SUFFIXES.values() if name.endswith(s)), None)
    if suffix is None:
        raise IMUImportError(f"{path}: not an OpenSense file name (<stem>{'/'.join(OPENSENSE_SUFFIXES.values())}[.gz])")
    stem = name[: -len(suffix)]
    found: dict[str, Path] = {}
    for key, suf in OPENSENSE_SUFFIXES.items():
        for candidate in (path.parent / f"{stem}{suf}", path.parent / f"{stem}{suf}.gz"):
            if candidate.exists():
                found[key] = candidate
                break
    for key in ("accel", "gyro"):
        if key not in found:
            raise IMUImportError(f"{path}: the OpenSense export lacks {stem}{OPENSENSE_SUFFIXES[key]}[.gz] beside it "
                                 "(accelerations and angular rates are both needed)")
    return found


def read_opensense(path: str | Path) -> IMUStream:
    """An OpenSense export (see the module docstring) given any of its files → raw stream."""
    files = opensense_files(path)
    t_acc, acc, rate_acc = read_trc_vectors(files["accel"])
    t_gyr, gyr, rate_gyr = read_trc_vectors(files["gyro"])
    source = f"{files['accel']} + {files['gyro'].name}"
    if list(acc) != list(gyr):
        raise IMUImportError(f"{source}: the two files name different sensors ({list(acc)} vs {list(gyr)})")
    if len(t_acc) != len(t_gyr) or not np.allclose(t_acc, t_gyr, atol=1e-6):
        raise IMUImportError(f"{source}: the two files have different time columns ({len(t_acc)} vs {len(t_gyr)} rows)")
    notes = [f"OpenSense export: {len(acc)} sensors, {len(t_acc)} rows at {rate_acc:g} Hz (files {', '.join(str(p) for p in files.values())})"]
    if abs(rate_acc - rate_gyr) > 1e-6:
        raise IMUImportError(f"{source}: DataRate differs ({rate_acc} vs {rate_gyr} Hz)")
    quats: dict[str, np.ndarray] = {}
    if "orientations" in files:
        t_q, quats = read_sto_quaternions(files["orientations"])
        if len(t_q) != len(t_acc) or not np.allclose(t_q, t_acc, atol=1e-6):
            notes.append(f"{files['orientations']}: time column differs from the accelerations; orientations not used")
            quats = {}
    sensors = {n: SensorSignals(n, source, t_acc, acc[n], gyr[n], orientation=quats.get(n)) for n in acc}
    return IMUStream(sensors, source, notes)


# ---------------------------------------------------------------------------------- Xsens
def _unwrap(counter: np.ndarray, modulus: float) -> np.ndarray:
    """Undo the wrap-around of an unsigned counter (a drop by more than half the modulus)."""
    steps = np.diff(counter)
    wraps = np.concatenate([[0.0], np.cumsum(np.where(steps < -modulus / 2, modulus, 0.0))])
    return counter + wraps


def xsens_sensor_name(path: str | Path) -> str:
    """The device ID of MT Manager's ``MT_<...>_<DEVICEID>.txt`` file names, else the file stem."""
    stem = Path(_stem(Path(path))).stem
    match = _XSENS_DEVICE_ID.match(stem)
    return match.group(1) if match else stem


def read_xsens_txt(path: str | Path) -> SensorSignals:
    """One sensor's MT Manager text export (see the module docstring for the assumptions)."""
    path = Path(path)
    name = xsens_sensor_name(path)
    lines = read_text(path).splitlines()
    body = next((i for i, line in enumerate(lines) if not line.startswith("//")), len(lines))
    rates = [re.search(r"update\s*rate\s*:\s*([0-9.]+)", line, re.IGNORECASE) for line in lines[:body]]
    rate = next((float(m.group(1)) for m in rates if m), None)
    lines = [line for line in lines[body:] if line.strip()]
    if not lines:
        raise IMUImportError(f"{path}, sensor {name!r}: no column header after the '//' lines")
    header = lines[0]
    sep = "\t" if "\t" in header else ";" if ";" in header else "," if "," in header else None
    columns = [c.strip() for c in (header.split(sep) if sep else header.split())]
    col = {c: i for i, c in enumerate(columns)}
    need = [f"{q}_{a}" for q in ("Acc", "Gyr") for a in "XYZ"]
    missing = [c for c in need if c not in col]
    if missing:
        other = [c for c in columns if c.startswith(("FreeAcc", "VelInc", "OriInc", "RateOfTurn"))]
        hint = (f"; found {other}: export 'Acceleration' (Acc_*, with gravity) and 'Rate of Turn' (Gyr_*) in m/s² and rad/s"
                if other else "")
        raise IMUImportError(f"{path}, sensor {name!r}: missing column(s) {missing} in the header {columns[:12]}{hint}")
    if "SampleTimeFine" not in col and ("PacketCounter" not in col or rate is None):
        raise IMUImportError(f"{path}, sensor {name!r}: no SampleTimeFine column, and no PacketCounter with an "
                             "'// Update Rate: …Hz' header line: cannot time the samples")
    rows = []
    for row, line in enumerate(lines[1:], start=body + 2):
        fields = line.split(sep) if sep else line.split()
        fields += [""] * (len(columns) - len(fields))
        if len(fields) > len(columns) and any(f.strip() for f in fields[len(columns):]):
            raise IMUImportError(f"{path}, sensor {name!r}: line {row} has {len(fields)} fields, the header {len(columns)}")
        rows.append(fields[: len(columns)])
    if len(rows) < 2:
        raise IMUImportError(f"{path}, sensor {name!r}: fewer than 2 data rows")

    def column(c: str) -> np.ndarray:
        return np.array([_float(path, k + body + 2, r[col[c]]) for k, r in enumerate(rows)])

    counter = _unwrap(column("PacketCounter"), 65536.0) if "PacketCounter" in col else None
    if "SampleTimeFine" in col:
        ticks = column("SampleTimeFine")
        if not np.isfinite(ticks).all():
            raise IMUImportError(f"{path}, sensor {name!r}: SampleTimeFine has blank or non-numeric values")
        time = _unwrap(ticks, 2.0**32) * XSENS_TICK_S
    else:
        if counter is None or not np.isfinite(counter).all():
            raise IMUImportError(f"{path}, sensor {name!r}: PacketCounter has blank values")
        time = counter / rate
    if counter is not None and not np.isfinite(counter).all():
        counter = None
    acc = np.stack([column(f"Acc_{a}") for a in "XYZ"], axis=1)
    gyr = np.stack([column(f"Gyr_{a}") for a in "XYZ"], axis=1)
    quat = None
    if all(f"Quat_q{i}" in col for i in range(4)):
        quat = np.stack([column(f"Quat_q{i}") for i in range(4)], axis=1)
    return SensorSignals(name, str(path), time, acc, gyr, orientation=quat, counter=counter)


def read_xsens_files(paths: Sequence[str | Path]) -> IMUStream:
    """Several MT Manager exports (one per sensor, one shared clock) → one raw stream."""
    sensors: dict[str, SensorSignals] = {}
    for p in paths:
        s = read_xsens_txt(p)
        if s.name in sensors:
            raise IMUImportError(f"{p}: sensor {s.name!r} is also in {sensors[s.name].source}: one file per sensor")
        sensors[s.name] = s
    source = ", ".join(str(p) for p in paths)
    return IMUStream(sensors, source, [f"Xsens MT Manager export: {len(sensors)} sensor file(s)"])


def read_imu_files(paths: Sequence[str | Path]) -> IMUStream:
    """Dispatch on the file names: one OpenSense file (its siblings are found) or Xsens ``.txt``/``.csv`` files."""
    paths = [Path(p) for p in paths]
    if not paths:
        raise IMUImportError("no IMU files given")
    names = [_stem(p) for p in paths]
    if any(n.endswith(tuple(OPENSENSE_SUFFIXES.values())) for n in names):
        stems = {opensense_files(p)["accel"] for p in paths}
        if len(stems) > 1:
            raise IMUImportError(f"{paths[0]}: files of {len(stems)} different OpenSense exports given; import one trial at a time")
        return read_opensense(paths[0])
    if all(n.lower().endswith((".txt", ".csv")) for n in names):
        return read_xsens_files(paths)
    raise IMUImportError(f"{paths[0]}: unknown IMU file type (OpenSense <stem>_Accel.trc/_Gyro.trc[.gz] or Xsens MT Manager .txt)")


# ---------------------------------------------------------------------------------- motion tables
def read_mot(path: str | Path) -> tuple[list[str], np.ndarray]:
    """(column names, (rows, columns) values) of an OpenSim ``.mot``/``.sto`` table, plain or
    gzip (:func:`sspinn.data.opensim_files.read_opensim_table`), all values finite."""
    path = Path(path)
    if not path.exists():
        raise IMUImportError(f"{path}: file not found")
    try:
        names, table = read_opensim_table(path)
    except OpenSimFormatError as exc:
        raise IMUImportError(str(exc)) from None
    if not np.isfinite(table).all():
        r, c = np.argwhere(~np.isfinite(table))[0]
        raise IMUImportError(f"{path}: column {names[c]!r} has a non-finite value at data row {r + 1}")
    return names, table


#: Column names of the per-side treadmill forces in OpenSim GRF files, tried in order:
#: (horizontal x, vertical y) per side.
GRF_COLUMN_PATTERNS: Final = (("{s}Fx", "{s}Fy"), ("ground_force_{s}_vx", "ground_force_{s}_vy"), ("{s}_ground_force_vx", "{s}_ground_force_vy"))


def read_treadmill_grf(path: str | Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(time (n,) s, {"r": (n, 2), "l": (n, 2)}) horizontal (lab x) and vertical (lab y, up)
    forces per side, N, from an OpenSim GRF ``.mot`` (columns ``rFx, rFy, lFx, lFy`` or
    ``ground_force_r_vx/vy``…). The lab x direction is not assumed forward (see
    :func:`sspinn.imu.time_alignment.walking_direction_sign`)."""
    path = Path(path)
    names, table = read_mot(path)
    col = {n: i for i, n in enumerate(names)}
    if "time" not in col:
        raise IMUImportError(f"{path}: no 'time' column (has {names[:8]}…)")
    forces = {}
    for side in ("r", "l"):
        pair = next(((x.format(s=side), y.format(s=side)) for x, y in GRF_COLUMN_PATTERNS
                     if x.format(s=side) in col and y.format(s=side) in col), None)
        if pair is None:
            raise IMUImportError(f"{path}: no force columns for side {side!r} (expected {side}Fx/{side}Fy or "
                                 f"ground_force_{side}_vx/vy; has {names})")
        forces[side] = table[:, [col[pair[0]], col[pair[1]]]]
    time = table[:, col["time"]]
    if np.any(np.diff(time) <= 0):
        raise IMUImportError(f"{path}: the time column does not increase")
    return time, forces
