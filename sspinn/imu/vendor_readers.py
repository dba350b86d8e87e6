"""Readers of vendor IMU and force files into :class:`sspinn.imu.stream.IMUStream` (raw 3D, per
sensor) and plain arrays; every file may be plain text or gzip-compressed (``.gz``).

* **OpenSim / OpenSense** (:func:`read_opensense`): ``<stem>_Accel.trc`` and ``<stem>_Gyro.trc``
  (one file per quantity, all sensors side by side: a TRC header of 5 lines, a blank line, then
  ``Frame#, Time`` and X/Y/Z per sensor; specific force in m/s² including gravity and angular
  rate in rad/s, each in the sensor's own frame — the TRC ``Units`` field, "m", is meaningless
  here and ignored), plus ``<stem>_Orientations.sto`` where present (one quaternion
  ``w,x,y,z`` per sensor and row; kept as information, calibration does not use it).
* **OpenSim ``.sto`` tables of 3-vectors** (:func:`read_sto_vectors`; what OpenSim's Xsens and
  APDM readers write): ``<stem>_linear_accelerations.sto`` and ``<stem>_angular_velocity.sto``
  (header up to ``endheader``, then ``time`` and one ``x,y,z`` cell per sensor, tab-separated),
  ``<stem>_orientations.sto`` (``w,x,y,z``) where present; same units and frames as the ``.trc``
  export, the rate from the time column. File-name suffixes of both layouts are matched
  case-insensitively.
* **Xsens MT Manager text export** (:func:`read_xsens_files`, one file per sensor): optional
  header lines starting with ``//`` (``// Update Rate: 100.0Hz`` gives the rate), then a table
  whose separator is read from its column line (tab, semicolon, comma, else whitespace; with a
  separator other than the comma a decimal comma is read as a point) and whose header names
  ``Acc_X/Y/Z`` (m/s², gravity included), ``Gyr_X/Y/Z`` (rad/s), ``PacketCounter`` and/or
  ``SampleTimeFine``, optionally ``Mag_*`` and ``Quat_q0…q3`` (names case-insensitive).
  Assumptions, each named in the one-line error of a file that does not fit:

  - time: ``SampleTimeFine`` when every row has one — integers stepping like 1e-4 s ticks of
    :data:`XSENS_RATE_RANGE_HZ` rates (a 32-bit counter, unwrapped) or values stepping like
    seconds (the two ranges do not overlap); when it is absent or blank (``""`` or ``NaN``) in
    some row, ``PacketCounter / update rate`` — a 16-bit counter (65,535 is followed by 0,
    unwrapped; a jump is a dropped packet, a gap). The rate is a given ``rate_hz`` (a header
    that disagrees is an error), else the file's header, else the header of the other files of
    the recording when they agree;
  - a row with no accelerometer, gyroscope and time value is a missing packet (left out); any
    other blank field is a missing value (a gap);
  - the sensor's name is the file stem when the sensor map names it, else the file name's last
    run of exactly 8 hexadecimal characters (the device ID, e.g. ``00B40B91`` in
    ``S01-Trial-Static-1-000_00B40B91.txt`` or ``MT_01200627_000-000_00B40B91.txt``), else the
    file stem;
  - all files of one recording share one clock; two files with identical values are warned
    about (a copied file).

  ``FreeAcc_*`` (gravity removed) or ``VelInc``/``OriInc`` (strap-down integrals) alone are
  rejected with a message.
* **OpenSim motion/storage tables** (:func:`read_mot`, e.g. treadmill GRF ``.mot``): header lines
  up to ``endheader``, then a column-name line and numbers; :func:`read_treadmill_grf` picks the
  per-side forces.

Errors are :class:`sspinn.imu.stream.IMUImportError`, one line naming the file (and sensor).
"""

from __future__ import annotations

import dataclasses
import gzip
import io
import re
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Final

import numpy as np

from sspinn.data.opensim_files import OpenSimFormatError, read_opensim_table
from sspinn.imu.stream import IMUImportError, IMUStream, SensorSignals
from sspinn.resource_limits import MAX_INPUT_BYTES, ResourceLimitError, input_file

#: File-name suffixes of the OpenSense export (before an optional ``.gz``).
OPENSENSE_SUFFIXES: Final = {"accel": "_Accel.trc", "gyro": "_Gyro.trc", "orientations": "_Orientations.sto"}
#: The two layouts read: the ``.trc`` export and OpenSim's ``.sto`` tables of 3-vectors (its
#: Xsens / APDM readers' output); suffixes are matched case-insensitively.
OPENSENSE_LAYOUTS: Final = (OPENSENSE_SUFFIXES, {"accel": "_linear_accelerations.sto", "gyro": "_angular_velocity.sto",
                                                 "orientations": "_orientations.sto"})
#: Tick length of Xsens ``SampleTimeFine``, s, and its wrap-around (a 32-bit counter).
XSENS_TICK_S: Final = 1e-4
XSENS_TICK_MODULUS: Final = 2.0**32
#: Wrap-around of Xsens ``PacketCounter`` (16 bit: 65,535 is followed by 0).
XSENS_COUNTER_MODULUS: Final = 65536.0
#: Update rates an Xsens ``SampleTimeFine`` may imply, Hz: what tells ticks from seconds.
XSENS_RATE_RANGE_HZ: Final = (1.0, 2000.0)
_XSENS_DEVICE_ID = re.compile(r"(?<![0-9A-Fa-f])[0-9A-Fa-f]{8}(?![0-9A-Fa-f])")
_XSENS_RATE = re.compile(r"(?:update|sample|sampling|output)\s*rate\s*[:=]\s*([0-9]+(?:\.[0-9]+)?)", re.IGNORECASE)
_SEP_NAMES: Final = {"\t": "tab", ";": "semicolon", ",": "comma", " ": "whitespace"}


def read_text(path: Path) -> str:
    """The text of a plain or gzip-compressed file (UTF-8, a byte-order mark ignored)."""
    path = Path(path)
    if not path.exists():
        raise IMUImportError(f"{path}: file not found")
    try:
        input_file(path, MAX_INPUT_BYTES, "IMU or force file")  # no FIFO, device or huge file
    except ResourceLimitError as exc:
        raise IMUImportError(str(exc)) from None
    raw = path.read_bytes()
    if raw[:2] == b"\x1f\x8b":
        try:
            with gzip.GzipFile(fileobj=io.BytesIO(raw)) as fh:
                raw = fh.read(MAX_INPUT_BYTES + 1)  # never more than the limit, however well it compresses
        except (OSError, EOFError) as exc:
            raise IMUImportError(f"{path}: a damaged gzip file ({exc})") from None
        if len(raw) > MAX_INPUT_BYTES:
            raise IMUImportError(f"{path}: decompresses to more than the {MAX_INPUT_BYTES >> 20} MiB a file may have here")
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
#: Sample rates an IMU or force file may have, Hz: outside, the time column is in other units.
FILE_RATE_RANGE_HZ: Final = (1.0, 20_000.0)


def _rate_from_time(path: Path, time: np.ndarray, stated: float | None = None) -> float:
    """The sample rate (Hz) of a time column in seconds; an error naming the file for a column
    that does not increase, implies a rate outside :data:`FILE_RATE_RANGE_HZ`, or disagrees by
    more than 1 % with the ``stated`` rate of the header (a time column in ms, say)."""
    steps = np.diff(time)
    if not (steps > 0).any():
        raise IMUImportError(f"{path}: the time column does not increase: no sample rate")
    rate = float(1.0 / np.median(steps[steps > 0]))
    low, high = FILE_RATE_RANGE_HZ
    if stated is not None and abs(rate - stated) > 0.01 * stated:
        hint = " (the time column in ms?)" if abs(rate * 1000 / stated - 1) < 0.01 else ""
        raise IMUImportError(f"{path}: the time column steps by {1 / rate:.6g} (a rate of {rate:.6g} Hz if in seconds) but "
                             f"the header's DataRate is {stated:g} Hz{hint}: give the time in seconds")
    if not low <= rate <= high:
        raise IMUImportError(f"{path}: the time column steps by {1 / rate:.6g}, a rate of {rate:.6g} Hz if in seconds, "
                             f"outside {low:g}–{high:g} Hz: is it in ms or samples? Give the time in seconds")
    return rate


def read_trc_vectors(path: str | Path) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
    """(time (n,) s, name → (n, 3) X/Y/Z values, DataRate Hz) of a TRC file with one 3-vector
    per name (as OpenSense writes accelerations and angular rates). Blank values are NaN; the
    rate is the header's ``DataRate``, or from the Time column when the header lacks it."""
    path = Path(path)
    lines = read_text(path).splitlines()
    if len(lines) < 7 or not lines[0].startswith("PathFileType"):
        raise IMUImportError(f"{path}: not a TRC file (expected 'PathFileType' on line 1 and a 5-line header)")
    keys, values = lines[1].split("\t"), lines[2].split("\t")
    header = {k.strip(): v.strip() for k, v in zip(keys, values)}
    try:
        rate: float | None = float(header["DataRate"])
    except (KeyError, ValueError):
        rate = None
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
    rate = _rate_from_time(path, data[:, 1], rate)
    return data[:, 1], {n: data[:, 2 + 3 * i: 5 + 3 * i] for i, n in enumerate(names)}, rate


def read_sto_vectors(path: str | Path, width: int) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
    """(time (n,), name → (n, ``width``) values, rate Hz from the time column) of an OpenSim
    storage file whose cells are comma-separated vectors (``x,y,z`` as OpenSim writes
    ``_linear_accelerations.sto`` and ``_angular_velocity.sto``; quaternions ``w,x,y,z`` in
    ``_orientations.sto``): header lines up to ``endheader``, then tab-separated ``time`` and one
    vector per sensor."""
    path = Path(path)
    lines = read_text(path).splitlines()
    try:
        end = next(i for i, line in enumerate(lines) if line.strip().lower() == "endheader")
    except StopIteration:
        raise IMUImportError(f"{path}: no 'endheader' line (not an OpenSim .sto file)") from None
    if end + 1 >= len(lines):
        raise IMUImportError(f"{path}: no column line after 'endheader'")
    names = [x.strip() for x in lines[end + 1].split("\t")]
    if not names or names[0].lower() != "time":
        raise IMUImportError(f"{path}: the column line after 'endheader' must start with 'time'")
    times, vectors = [], []
    for row, line in enumerate(lines[end + 2:], start=end + 3):
        if not line.strip():
            continue
        fields = line.rstrip("\r\n").split("\t")
        if len(fields) != len(names):
            raise IMUImportError(f"{path}: line {row} has {len(fields)} fields, the header {len(names)}")
        times.append(_float(path, row, fields[0]))
        q = []
        for name, f in zip(names[1:], fields[1:]):
            parts = f.split(",")
            if len(parts) != width:
                raise IMUImportError(f"{path}: line {row}, column {name}: {f!r} is not a {width}-vector 'a,b,c{',d' if width == 4 else ''}'")
            q.append([_float(path, row, p) for p in parts])
        vectors.append(q)
    if len(times) < 2:
        raise IMUImportError(f"{path}: fewer than 2 data rows")
    time, arr = np.array(times), np.array(vectors)
    if not np.isfinite(time).all():
        raise IMUImportError(f"{path}: the time column has blank or non-numeric values")
    return time, {n: arr[:, i] for i, n in enumerate(names[1:])}, _rate_from_time(path, time)


def read_sto_quaternions(path: str | Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(time (n,), name → (n, 4) unit quaternions w, x, y, z) of an OpenSense ``_Orientations.sto``."""
    time, quats, _ = read_sto_vectors(path, 4)
    return time, quats


def _opensense_suffix(name: str) -> str | None:
    """The OpenSense suffix (:data:`OPENSENSE_LAYOUTS`) a file name ends with, case aside."""
    lower = name.lower()
    return next((s for layout in OPENSENSE_LAYOUTS for s in layout.values() if lower.endswith(s.lower())), None)


def opensense_files(path: str | Path) -> dict[str, Path]:
    """The files of one OpenSense export given any of them (``<stem>_Accel.trc[.gz]``, ``_Gyro``
    or ``_Orientations.sto``, or OpenSim's ``<stem>_linear_accelerations.sto``,
    ``_angular_velocity.sto``, ``_orientations.sto``; suffixes matched case-insensitively):
    ``{"accel", "gyro"[, "orientations"]}``; accel and gyro must exist."""
    path = Path(path)
    name = _stem(path)
    suffix = _opensense_suffix(name)
    if suffix is None:
        raise IMUImportError(f"{path}: not an OpenSense file name (<stem>{'/'.join(OPENSENSE_SUFFIXES.values())}[.gz] or "
                             f"<stem>{'/'.join(OPENSENSE_LAYOUTS[1].values())}[.gz])")
    stem = name[: -len(suffix)]
    beside = {p.name.lower(): p for p in path.parent.iterdir()} if path.parent.is_dir() else {}
    layouts = sorted(OPENSENSE_LAYOUTS, key=lambda layout: suffix.lower() not in {s.lower() for s in layout.values()})
    for layout in layouts:  # the layout of the given file first
        found: dict[str, Path] = {}
        for key, suf in layout.items():
            for candidate in (f"{stem}{suf}".lower(), f"{stem}{suf}.gz".lower()):
                if candidate in beside:
                    found[key] = beside[candidate]
                    break
        if "accel" in found and "gyro" in found:
            return found
    layout = layouts[0]
    lacking = [layout[k] for k in ("accel", "gyro") if not any(f"{stem}{layout[k]}".lower() + gz in beside for gz in ("", ".gz"))]
    raise IMUImportError(f"{path}: the OpenSense export lacks {stem}{lacking[0]}[.gz] beside it "
                         "(accelerations and angular rates are both needed)")


def _read_vectors(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
    return read_trc_vectors(path) if _stem(path).lower().endswith(".trc") else read_sto_vectors(path, 3)[:3]


def read_opensense(path: str | Path) -> IMUStream:
    """An OpenSense export (see the module docstring) given any of its files → raw stream."""
    files = opensense_files(path)
    t_acc, acc, rate_acc = _read_vectors(files["accel"])
    t_gyr, gyr, rate_gyr = _read_vectors(files["gyro"])
    source = f"{files['accel']} + {files['gyro'].name}"
    if list(acc) != list(gyr):
        raise IMUImportError(f"{source}: the two files name different sensors ({list(acc)} vs {list(gyr)})")
    if len(t_acc) != len(t_gyr) or not np.allclose(t_acc, t_gyr, atol=1e-6):
        raise IMUImportError(f"{source}: the two files have different time columns ({len(t_acc)} vs {len(t_gyr)} rows)")
    notes = [f"OpenSense export: {len(acc)} sensors, {len(t_acc)} rows at {rate_acc:g} Hz (files {', '.join(str(p) for p in files.values())})"]
    if abs(rate_acc - rate_gyr) > 1e-6 * rate_acc:
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


def xsens_device_id(path: str | Path) -> str | None:
    """The Xsens device ID in a file name: its last run of exactly 8 hexadecimal characters
    (``S01-Trial-Static-1-000_00B40B91.txt``, ``MT_01200627_000-000_00B41234.txt`` → ``00B4…``),
    upper-case; None without one."""
    found = _XSENS_DEVICE_ID.findall(Path(_stem(Path(path))).stem)
    return found[-1].upper() if found else None


def xsens_sensor_name(path: str | Path, known: Collection[str] = ()) -> str:
    """The sensor name of one MT Manager file: the file stem if ``known`` (the sensor map's
    names) has it, else the device ID of the file name (:func:`xsens_device_id`; as ``known``
    spells it, case aside), else the file stem."""
    stem = Path(_stem(Path(path))).stem
    if stem in known:
        return stem
    device = xsens_device_id(path)
    if device is None:
        return stem
    return next((k for k in known if k.upper() == device), device)


@dataclass
class _XsensTable:
    """One MT Manager file split into fields: the header's rate (Hz, or None), the column names,
    the data rows (text fields, one list per row) with their line numbers, and the separator."""

    path: Path
    name: str
    header_rate: float | None
    columns: list[str]
    rows: list[list[str]]
    line_numbers: list[int]
    separator: str

    def index(self, column: str) -> int | None:
        """The position of ``column`` (case-insensitive), or None."""
        lower = [c.lower() for c in self.columns]
        return lower.index(column.lower()) if column.lower() in lower else None

    def where(self, column: str) -> str:
        return f"{self.path}, sensor {self.name!r}, column {column}"

    def values(self, column: str) -> np.ndarray:
        """The column as floats (blank and ``NaN`` → NaN); a decimal comma is read as a point
        unless the separator is a comma."""
        k = self.index(column)
        assert k is not None
        out = np.empty(len(self.rows))
        for i, (row, line) in enumerate(zip(self.rows, self.line_numbers)):
            text = row[k].strip().strip('"')
            if self.separator != ",":
                text = text.replace(",", ".")
            try:
                out[i] = float(text) if text else np.nan
            except ValueError:
                raise IMUImportError(f"{self.where(column)}: line {line}: {row[k].strip()!r} is not a number") from None
        return out


def _separator(header: str) -> str:
    """The separator of an MT Manager table, from its header line: tab, semicolon, comma, else
    whitespace (``" "``)."""
    return next((sep for sep in ("\t", ";", ",") if sep in header), " ")


def _split(line: str, sep: str) -> list[str]:
    return line.split() if sep == " " else line.rstrip("\r\n").split(sep)


def _parse_xsens(path: Path, known: Collection[str]) -> _XsensTable:
    """Header lines (``//``), the column line and the rows of one MT Manager text export."""
    name = xsens_sensor_name(path, known)
    lines = read_text(path).splitlines()
    body = next((i for i, line in enumerate(lines) if line.strip() and not line.lstrip().startswith("//")), len(lines))
    rates = [_XSENS_RATE.search(line) for line in lines[:body]]
    header_rate = next((float(m.group(1)) for m in rates if m), None)
    if body == len(lines):
        raise IMUImportError(f"{path}, sensor {name!r}: no column header after the '//' lines (an empty export?)")
    sep = _separator(lines[body])
    columns = [c.strip().strip('"') for c in _split(lines[body], sep)]
    while columns and not columns[-1]:  # a trailing separator
        columns.pop()
    rows, numbers = [], []
    for number, line in enumerate(lines[body + 1:], start=body + 2):
        if not line.strip() or line.lstrip().startswith("//"):
            continue
        fields = _split(line, sep)
        if len(fields) > len(columns) and any(f.strip() for f in fields[len(columns):]):
            raise IMUImportError(f"{path}, sensor {name!r}: line {number} has {len(fields)} fields, the header "
                                 f"{len(columns)} ({_SEP_NAMES[sep]}-separated)")
        if len(fields) < len(columns):
            if sep == " ":
                raise IMUImportError(
                    f"{path}, sensor {name!r}: line {number} has {len(fields)} values, the header {len(columns)} columns: "
                    "in a whitespace-separated table a blank value cannot be told from a missing one; export with "
                    "tabs, commas or semicolons")
            fields += [""] * (len(columns) - len(fields))
        rows.append(fields[: len(columns)])
        numbers.append(number)
    if len(rows) < 2:
        raise IMUImportError(f"{path}, sensor {name!r}: fewer than 2 data rows")
    return _XsensTable(path, name, header_rate, columns, rows, numbers, sep)


def _xsens_time(table: _XsensTable, rate: float | None, rate_origin: str) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    """(time stamps s, unwrapped packet counter or None, notes) of one table whose empty rows
    are already dropped; the assumptions are those of the module docstring."""
    counter = None
    if table.index("PacketCounter") is not None:
        raw = table.values("PacketCounter")
        if np.isfinite(raw).all():
            counter = _unwrap(raw, XSENS_COUNTER_MODULUS)
        elif np.isfinite(raw).any():
            line = table.line_numbers[int(np.flatnonzero(~np.isfinite(raw))[0])]
            raise IMUImportError(f"{table.where('PacketCounter')}: blank at line {line} while other rows have a value: "
                                 "the reader assumes a 16-bit packet counter in every row (or none)")
    notes: list[str] = []
    fine = table.values("SampleTimeFine") if table.index("SampleTimeFine") is not None else None
    if fine is not None and np.isfinite(fine).all():
        steps = np.diff(fine)
        step = float(np.median(steps[steps > 0])) if (steps > 0).any() else 0.0
        integral = bool(np.all(fine == np.round(fine)))
        low, high = XSENS_RATE_RANGE_HZ
        as_ticks = step > 0 and integral and low <= 1.0 / (step * XSENS_TICK_S) <= high
        as_seconds = 0 < step and low <= 1.0 / step <= high
        if as_ticks == as_seconds:
            raise IMUImportError(
                f"{table.where('SampleTimeFine')}: median step {step:g} fits neither assumption: 1e-4 s ticks (integers, "
                f"{1e4 / high:g}–{1e4 / low:g} per sample for {low:g}–{high:g} Hz) nor seconds ({1 / high:g}–{1 / low:g} s per sample)")
        if as_ticks:
            time, unit = _unwrap(fine, XSENS_TICK_MODULUS) * XSENS_TICK_S, "1e-4 s ticks"
        else:
            time, unit = fine.copy(), "seconds"
        found = 1.0 / (step * (XSENS_TICK_S if as_ticks else 1.0))
        if rate is not None and abs(found / rate - 1) > 0.05:
            raise IMUImportError(
                f"{table.where('SampleTimeFine')}: read as {unit} it steps at {found:.4g} Hz, but {rate_origin} says "
                f"{rate:g} Hz: one of the two is not what the reader assumes (ticks of 1e-4 s or seconds; the update rate)")
        notes.append(f"{table.path}, sensor {table.name!r}: time from SampleTimeFine read as {unit} ({found:.4g} Hz)")
        return time, counter, notes
    why = ("no SampleTimeFine column" if fine is None else "SampleTimeFine blank in every row" if not np.isfinite(fine).any()
           else f"SampleTimeFine blank in {int((~np.isfinite(fine)).sum())} of {len(fine)} rows")
    if counter is None:
        raise IMUImportError(f"{table.where('PacketCounter')}: {why} and no PacketCounter values: cannot time the samples "
                             "(the reader assumes SampleTimeFine in 1e-4 s ticks or seconds, else PacketCounter / update rate)")
    if rate is None:
        raise IMUImportError(
            f"{table.where('PacketCounter')}: {why}, so time = PacketCounter / update rate, but no rate is known: no "
            "'// Update Rate: …Hz' header line in this file or in another file of the recording; give the rate (--imu-rate)")
    notes.append(f"{table.path}, sensor {table.name!r}: {why}: time = PacketCounter (16-bit, unwrapped) / {rate:g} Hz ({rate_origin})")
    return counter / rate, counter, notes


def _xsens_signals(table: _XsensTable, rate: float | None, rate_origin: str) -> tuple[SensorSignals, list[str]]:
    """One parsed table → (signals, notes)."""
    need = [f"{q}_{a}" for q in ("Acc", "Gyr") for a in "XYZ"]
    missing = [c for c in need if table.index(c) is None]
    if missing:
        other = [c for c in table.columns if c.startswith(("FreeAcc", "VelInc", "OriInc", "RateOfTurn"))]
        hint = (f"; found {other}: export 'Acceleration' (Acc_*, with gravity) and 'Rate of Turn' (Gyr_*) in m/s² and rad/s"
                if other else "")
        raise IMUImportError(f"{table.path}, sensor {table.name!r}: missing column(s) {missing} in the header "
                             f"{table.columns[:12]} ({_SEP_NAMES[table.separator]}-separated){hint}")
    acc = np.stack([table.values(f"Acc_{a}") for a in "XYZ"], axis=1)
    gyr = np.stack([table.values(f"Gyr_{a}") for a in "XYZ"], axis=1)
    notes = []
    empty = ~np.isfinite(acc).any(axis=1) & ~np.isfinite(gyr).any(axis=1)
    if table.index("SampleTimeFine") is not None:
        empty &= ~np.isfinite(table.values("SampleTimeFine"))
    if empty.any():  # rows written for missing packets: left out, the counter or the time stamps show the gap
        notes.append(f"{table.path}, sensor {table.name!r}: {int(empty.sum())} row(s) without data left out (missing packets)")
        table = dataclasses.replace(table, rows=[r for r, e in zip(table.rows, empty) if not e],
                                    line_numbers=[n for n, e in zip(table.line_numbers, empty) if not e])
        acc, gyr = acc[~empty], gyr[~empty]
        if len(table.rows) < 2:
            raise IMUImportError(f"{table.path}, sensor {table.name!r}: fewer than 2 rows with data")
    time, counter, time_notes = _xsens_time(table, rate, rate_origin)
    quat = None
    if all(table.index(f"Quat_q{i}") is not None for i in range(4)):
        quat = np.stack([table.values(f"Quat_q{i}") for i in range(4)], axis=1)
        quat = quat if np.isfinite(quat).any() else None
    return SensorSignals(table.name, str(table.path), time, acc, gyr, orientation=quat, counter=counter), notes + time_notes


def read_xsens_txt(path: str | Path, rate_hz: float | None = None, known: Collection[str] = ()) -> SensorSignals:
    """One sensor's MT Manager text export (module docstring). ``rate_hz``: the update rate when
    the file's header lacks one; ``known``: the sensor map's names (:func:`xsens_sensor_name`)."""
    return read_xsens_files([path], rate_hz, known).sensors[xsens_sensor_name(path, known)]


def read_xsens_files(paths: Sequence[str | Path], rate_hz: float | None = None, known: Collection[str] = ()) -> IMUStream:
    """Several MT Manager exports (one per sensor, one shared clock) → one raw stream.

    The update rate of each file is its ``// Update Rate`` header line; ``rate_hz`` (given)
    overrides it (a header that disagrees by more than 1 % is an error naming the file); a file
    without either takes the rate of the other files when their headers agree. It only matters
    where the time comes from ``PacketCounter``."""
    tables = [_parse_xsens(Path(p), known) for p in paths]
    seen: dict[str, Path] = {}
    for t in tables:
        if t.name in seen:
            raise IMUImportError(f"{t.path}: sensor {t.name!r} is also in {seen[t.name]}: one file per sensor "
                                 "(the name is the device ID of the file name, or the file stem the sensor map names)")
        seen[t.name] = t.path
    if rate_hz is not None:
        for t in tables:
            if t.header_rate is not None and abs(t.header_rate / rate_hz - 1) > 0.01:
                raise IMUImportError(f"{t.path}, sensor {t.name!r}: its header says {t.header_rate:g} Hz, the given rate is {rate_hz:g} Hz")
    header_rates = sorted({t.header_rate for t in tables if t.header_rate is not None})
    if len(header_rates) > 1 and rate_hz is None:
        rates = ", ".join(f"{t.path.name} ({t.name}): {t.header_rate:g} Hz" for t in tables if t.header_rate is not None)
        raise IMUImportError(f"the Xsens files' headers give different update rates ({rates}); the sensors of one "
                             "recording share one rate: export them again at one rate")
    shared = header_rates[0] if len(header_rates) == 1 else None
    sensors: dict[str, SensorSignals] = {}
    notes = [f"Xsens MT Manager export: {len(tables)} sensor file(s)"]
    for t in tables:
        if rate_hz is not None:
            rate, origin = rate_hz, "the given rate"
        elif t.header_rate is not None:
            rate, origin = t.header_rate, "the file's header"
        else:
            rate, origin = shared, "the other files' header"
        s, file_notes = _xsens_signals(t, rate, origin)
        sensors[s.name] = s
        device = xsens_device_id(t.path)
        how = ("the file stem (named in the sensor map)" if s.name == Path(_stem(t.path)).stem and s.name in known
               else "the device ID in the file name" if device is not None and s.name.upper() == device else "the file stem")
        notes.append(f"{t.path}: sensor {s.name!r} ({how}), {_SEP_NAMES[t.separator]}-separated, {len(s.time)} rows")
        notes += file_notes
    source = ", ".join(str(p) for p in paths)
    return IMUStream(sensors, source, notes, _identical_sensors(sensors))


def _identical_sensors(sensors: dict[str, SensorSignals]) -> list[str]:
    """A warning per pair of sensors whose accelerometer and gyroscope values are identical (a
    file copied under another sensor's name: two sensors never read the same noise)."""
    out = []
    names = list(sensors)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            sa, sb = sensors[a], sensors[b]
            n = min(len(sa.time), len(sb.time))
            if n >= 2 and np.array_equal(sa.acc[:n], sb.acc[:n], equal_nan=True) and np.array_equal(sa.gyr[:n], sb.gyr[:n], equal_nan=True):
                out.append(f"{sa.source} and {sb.source}: sensors {a!r} and {b!r} hold identical accelerometer and gyroscope "
                           f"values ({n} rows): one file is probably a copy of the other")
    return out


def read_imu_files(paths: Sequence[str | Path], rate_hz: float | None = None, known: Collection[str] = ()) -> IMUStream:
    """Dispatch on the file names: one OpenSense file (its siblings are found) or Xsens
    ``.txt``/``.csv`` files (``rate_hz`` and ``known`` as in :func:`read_xsens_files`)."""
    paths = [Path(p) for p in paths]
    if not paths:
        raise IMUImportError("no IMU files given")
    names = [_stem(p) for p in paths]
    if any(_opensense_suffix(n) is not None for n in names):
        stems = {opensense_files(p)["accel"] for p in paths}
        if len(stems) > 1:
            raise IMUImportError(f"{paths[0]}: files of {len(stems)} different OpenSense exports given; import one trial at a time")
        if rate_hz is not None:
            raise IMUImportError(f"{paths[0]}: the update rate (--imu-rate {rate_hz:g}) applies to Xsens files only; an "
                                 "OpenSense export's rate is its DataRate header and time column: leave it out")
        return read_opensense(paths[0])
    if all(n.lower().endswith((".txt", ".csv")) for n in names):
        return read_xsens_files(paths, rate_hz, known)
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
    time, forces, _ = read_treadmill_grf_columns(path)
    return time, forces


def read_treadmill_grf_columns(path: str | Path) -> tuple[np.ndarray, dict[str, np.ndarray], dict[str, tuple[str, str]]]:
    """:func:`read_treadmill_grf` and, per side, the names of the (horizontal, vertical) columns read."""
    path = Path(path)
    names, table = read_mot(path)
    col = {n: i for i, n in enumerate(names)}
    if "time" not in col:
        raise IMUImportError(f"{path}: no 'time' column (has {names[:8]}…)")
    forces, columns = {}, {}
    for side in ("r", "l"):
        pair = next(((x.format(s=side), y.format(s=side)) for x, y in GRF_COLUMN_PATTERNS
                     if x.format(s=side) in col and y.format(s=side) in col), None)
        if pair is None:
            raise IMUImportError(f"{path}: no force columns for side {side!r} (expected {side}Fx/{side}Fy or "
                                 f"ground_force_{side}_vx/vy; has {names})")
        forces[side] = table[:, [col[pair[0]], col[pair[1]]]]
        columns[side] = pair
    time = table[:, col["time"]]
    if np.any(np.diff(time) <= 0):
        raise IMUImportError(f"{path}: the time column does not increase")
    return time, forces, columns
