"""The sspinn recording and dataset format (version 1).

A **recording** is one continuous trial: sagittal IMU signals at 100 Hz, the subject's height and
mass, the nominal IMU placement the estimator is told, optional ground-truth labels, units and
provenance. On disk it is two files side by side:

* ``<name>.csv`` — one row per sample, a ``time`` column (s, step 0.01) and the columns
  ``<segment>_acc_x, <segment>_acc_y, <segment>_gyr_z`` (m/s², rad/s; see
  :mod:`sspinn.model.conventions`) for each IMU present, then optional label columns: the coordinates
  ``pelvis_tx … ankle_l`` (m, rad), their rates ``d_<coordinate>`` and accelerations
  ``dd_<coordinate>``, torques ``tau_<joint>`` (N·m), ground reaction forces ``grf_x_r, grf_y_r,
  grf_x_l, grf_y_l`` (N, global frame), contact fractions ``w_r, w_l`` and ``speed`` (m/s,
  horizontal speed of the pelvis averaged over a stride);
* ``<name>.json`` — the sidecar: ``{"format": "sspinn-recording", "version": 1,
  "sample_rate_hz": 100, "subject": {"id", "height_m", "mass_kg"}, "imu": {"segments",
  "placement"}, "units": {...}, "provenance": {...}}``.

Why CSV + JSON: readable and diff-able, opened by pandas, numpy, spreadsheets and every other
language without extra dependencies, and small (a 20 s recording is ~2,000 rows); HDF5 or
Parquet would add a binary dependency for no gain at this size.

A **dataset** is a folder of recordings plus ``dataset.json`` listing the recordings of each
split (``train``, ``val``, ``test``; split by subject) and how the data were made.

Loading validates everything and fails with a message naming the file, the column, the row or
the value: missing IMU columns, NaN/inf, a wrong sample rate, gyroscopes in deg/s,
accelerometers in g, GRFs in body weights, angles in degrees, shape mismatches.
"""

from __future__ import annotations

import contextlib
import fcntl
import io
import json
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np

from sspinn.data.plausibility import check_imu_plausibility
from sspinn.data.signal_checks import check_recording
from sspinn.errors import DataFormatError
from sspinn.model.body import IMUPlacement, ParameterError
from sspinn.model.conventions import GRAVITY, IMU_CHANNELS, SEGMENTS
from sspinn.model.trajectory import COLUMNS, Trajectory
from sspinn.resource_limits import MAX_CONFIG_BYTES, MAX_INPUT_BYTES, MAX_ROWS, ResourceLimitError, read_input_text
from sspinn.run_folder import atomic_path, atomic_write_text

FORMAT: Final = "sspinn-recording"
VERSION: Final = 1
SAMPLE_RATE_HZ: Final = 100.0

#: Label groups: name → column names (in order): the trajectory's (:data:`sspinn.model.trajectory.COLUMNS`) and the speed.
LABEL_COLUMNS: Final[dict[str, tuple[str, ...]]] = {**COLUMNS, "speed": ("speed",)}
UNITS: Final[dict[str, str]] = {
    "time": "s",
    "acc": "m/s^2 (specific force, sensor frame)",
    "gyr": "rad/s",
    "q": "m (pelvis_tx, pelvis_ty), rad (angles)",
    "u": "m/s, rad/s",
    "qdd": "m/s^2, rad/s^2",
    "tau": "N*m",
    "grf": "N (global frame)",
    "w": "1 (0 toe ... 1 heel)",
    "speed": "m/s",
}


@dataclass
class Labels:
    """Ground-truth labels; each field (T, n) — or (T,) for ``speed`` — or None when absent
    (columns in LABEL_COLUMNS). Partially known groups (e.g. only the right leg's angles) hold
    NaN in the unknown columns, which are listed in ``missing``; every other value is finite."""

    q: np.ndarray | None = None
    u: np.ndarray | None = None
    qdd: np.ndarray | None = None
    tau: np.ndarray | None = None
    grf: np.ndarray | None = None
    w: np.ndarray | None = None
    speed: np.ndarray | None = None
    missing: frozenset[str] = frozenset()

    @classmethod
    def from_columns(cls, columns: dict[str, np.ndarray], n_samples: int) -> Labels:
        """Build from named columns (LABEL_COLUMNS names); absent columns of a used group → NaN."""
        unknown = [c for c in columns if not any(c in cols for cols in LABEL_COLUMNS.values())]
        if unknown:
            raise DataFormatError(f"unknown label column(s) {unknown}")
        groups: dict[str, np.ndarray] = {}
        missing: set[str] = set()
        for group, cols in LABEL_COLUMNS.items():
            if not any(c in columns for c in cols):
                continue
            arr = np.full((n_samples, len(cols)), np.nan)
            for i, c in enumerate(cols):
                if c in columns:
                    arr[:, i] = np.asarray(columns[c], dtype=np.float64).reshape(-1)
                else:
                    missing.add(c)
            groups[group] = arr if group != "speed" else arr[:, 0]
        return cls(**groups, missing=frozenset(missing))

    def available(self) -> list[str]:
        """Groups with at least one known column."""
        return [g for g in LABEL_COLUMNS if getattr(self, g) is not None]

    def columns(self) -> list[str]:
        """All known label columns."""
        return [c for g in self.available() for c in LABEL_COLUMNS[g] if c not in self.missing]

    def column(self, name: str) -> np.ndarray:
        for g, cols in LABEL_COLUMNS.items():
            if name in cols and getattr(self, g) is not None and name not in self.missing:
                arr = getattr(self, g)
                return arr if arr.ndim == 1 else arr[:, cols.index(name)]
        raise KeyError(f"label column {name!r} is not available; available: {self.columns()}")

    def slice(self, sl: slice) -> Labels:
        return Labels(
            **{n: (None if getattr(self, n) is None else getattr(self, n)[sl]) for n in LABEL_COLUMNS},
            missing=self.missing,
        )

    @classmethod
    def from_trajectory(cls, trajectory: Trajectory, speed: np.ndarray | None = None) -> Labels:
        """Complete labels from a trajectory (copies of q, u, q̈, τ, GRF, w) and optionally the
        per-sample ``speed`` (m/s)."""
        groups = {g: np.array(getattr(trajectory, g), dtype=np.float64) for g in COLUMNS}
        if speed is not None:
            groups["speed"] = np.array(speed, dtype=np.float64).reshape(-1)
        return cls(**groups)

    def trajectory(self, time: np.ndarray | None = None) -> Trajectory:
        """The labels as a :class:`~sspinn.model.trajectory.Trajectory` at ``time`` (s; default
        k / SAMPLE_RATE_HZ). Needs every group of it (q, u, q̈, τ, GRF, w) with no column
        missing, else :class:`DataFormatError` naming what is absent."""
        absent = [g for g in COLUMNS if getattr(self, g) is None]
        partial = sorted(c for g in COLUMNS for c in COLUMNS[g] if c in self.missing and g not in absent)
        if absent or partial:
            what = ", ".join([f"no {g} labels" for g in absent] + ([f"no column(s) {partial}"] if partial else []))
            raise DataFormatError(f"a trajectory needs the labels q, u, qdd, tau, grf and w complete: {what}")
        n = len(self.q)
        return Trajectory(time=np.arange(n) / SAMPLE_RATE_HZ if time is None else time, **{g: getattr(self, g) for g in COLUMNS})


@dataclass
class Recording:
    """One continuous trial at 100 Hz (see the module docstring for units and conventions).

    Attributes:
        name: unique name (also the file stem).
        imu: (T, n_imu, 3) [acc_x, acc_y, gyr_z] per IMU in ``segments`` order.
        segments: the segments carrying an IMU (subset of conventions.SEGMENTS, in that order).
        height, mass: subject height (m) and mass (kg) — what the estimator is told.
        subject: subject identifier (splits are by subject).
        placement: nominal IMU placement the estimator is told (not necessarily the truth).
        labels: ground truth, or None.
        provenance: free-form description of where the data came from.
    """

    name: str
    imu: np.ndarray
    segments: tuple[str, ...]
    height: float
    mass: float
    subject: str = "unknown"
    placement: IMUPlacement = field(default_factory=IMUPlacement)
    labels: Labels | None = None
    provenance: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.imu = np.asarray(self.imu, dtype=np.float64)
        self.segments = tuple(self.segments)
        validate_recording(self, source=self.name)

    @property
    def n_samples(self) -> int:
        return self.imu.shape[0]

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.n_samples) / SAMPLE_RATE_HZ

    @property
    def duration(self) -> float:
        return self.n_samples / SAMPLE_RATE_HZ

    def provenance_spans(self, key: str) -> list[tuple[float, float, tuple[Any, ...]]]:
        """The spans that ``provenance[key]`` lists — each [start, stop, ...] in s of the source
        files, whose time of the recording's first sample is the provenance's
        ``start_s_in_files`` (``sspinn import`` writes both: ``turning_s``, ``grf_misaligned_s``)
        — as (start, stop) in s of this recording, clipped to it, and the entries after them;
        none when the key is absent."""
        prov = self.provenance if isinstance(self.provenance, dict) else {}
        t0 = float(prov.get("start_s_in_files", 0.0))
        spans = []
        for span in prov.get(key) or []:
            a, b = max(0.0, float(span[0]) - t0), min(self.duration, float(span[1]) - t0)
            if b > a:
                spans.append((a, b, tuple(span[2:])))
        return spans

    def provenance_mask(self, key: str) -> np.ndarray:
        """(T,) bool: the samples inside :meth:`provenance_spans` of ``key``."""
        mask = np.zeros(self.n_samples, dtype=bool)
        for a, b, _ in self.provenance_spans(key):
            mask[int(round(a * SAMPLE_RATE_HZ)):int(round(b * SAMPLE_RATE_HZ))] = True
        return mask

    def imu_columns(self) -> list[str]:
        return [f"{s}_{c}" for s in self.segments for c in IMU_CHANNELS]

    def select_imus(self, segments: tuple[str, ...] | list[str]) -> Recording:
        """A copy with only the given IMUs (e.g. a sparse configuration)."""
        missing = [s for s in segments if s not in self.segments]
        if missing:
            raise DataFormatError(f"{self.name}: no IMU on {missing}; available: {list(self.segments)}")
        ordered = tuple(s for s in SEGMENTS if s in segments)
        idx = [self.segments.index(s) for s in ordered]
        return Recording(
            name=self.name, imu=self.imu[:, idx], segments=ordered, height=self.height, mass=self.mass,
            subject=self.subject, placement=self.placement, labels=self.labels, provenance=dict(self.provenance),
        )

    # ------------------------------------------------------------------ I/O
    def save(self, folder: str | Path) -> Path:
        """Write ``<folder>/<name>.csv`` and ``.json``; returns the CSV path."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        columns = ["time", *self.imu_columns()]
        data = [self.time[:, None], self.imu.reshape(self.n_samples, -1)]
        if self.labels is not None:
            for name in self.labels.columns():
                columns.append(name)
                data.append(self.labels.column(name)[:, None])
        check_name(self.name, folder)
        csv = folder / f"{self.name}.csv"
        with atomic_path(csv) as tmp:
            np.savetxt(tmp, np.hstack(data), delimiter=",", header=",".join(columns), comments="", fmt="%.9g")
        sidecar = {
            "format": FORMAT,
            "version": VERSION,
            "sample_rate_hz": SAMPLE_RATE_HZ,
            "subject": {"id": self.subject, "height_m": self.height, "mass_kg": self.mass},
            "imu": {
                "segments": list(self.segments),
                "placement": self.placement.to_dict(),
            },
            "labels": self.labels.columns() if self.labels is not None else [],
            "units": UNITS,
            "provenance": self.provenance,
        }
        atomic_write_text(folder / f"{self.name}.json", json.dumps(sidecar, indent=2))
        return csv

    @classmethod
    def load(cls, path: str | Path) -> Recording:
        """Read a recording from its CSV (or JSON) path, validating format, rate and units."""
        path = Path(path)
        csv, sidecar_path = path.with_suffix(".csv"), path.with_suffix(".json")
        for p in (csv, sidecar_path):
            if not p.exists():
                raise DataFormatError(f"{p}: file not found (a recording is a .csv plus a .json sidecar)")
        meta = _read_sidecar(sidecar_path)
        names, table = read_csv_table(csv)
        col = {n: i for i, n in enumerate(names)}
        if "time" not in col:
            raise DataFormatError(f"{csv}: missing column 'time'")
        t = table[:, col["time"]]
        if len(t) < 2:
            raise DataFormatError(f"{csv}: needs at least 2 samples, found {len(t)}")
        dt = np.diff(t)
        expected = 1.0 / SAMPLE_RATE_HZ
        # each step within 0.1 ms, and the clock never drifts half a sample from the 100 Hz grid
        # (a 100.9 Hz recording passes the first test: 9.91 ms steps)
        drift = np.abs((t - t[0]) - np.arange(len(t)) * expected)
        if np.abs(dt - expected).max() > 1e-4 or drift.max() > 0.5 * expected:
            k = int(np.argmax(np.abs(dt - expected))) if np.abs(dt - expected).max() > 1e-4 else int(np.argmax(drift)) - 1
            median = float(np.median(dt))
            rate = f"{1 / median:.4g} Hz" if median > 0 else "not increasing"
            raise DataFormatError(
                f"{csv}: column 'time' must advance by {expected} s (100 Hz); found a step of {dt[k]:.6g} s at row {k + 2}"
                f" and {drift.max():.4g} s of drift from the 100 Hz grid by row {int(np.argmax(drift)) + 2}"
                f" (median step {median:.6g} s, {rate}); resample to 100 Hz first"
            )
        segments = tuple(meta["imu"]["segments"])
        unknown = [s for s in segments if s not in SEGMENTS]
        if unknown:
            raise DataFormatError(f"{sidecar_path}: unknown IMU segment(s) {unknown}; known: {list(SEGMENTS)}")
        imu_cols = [f"{s}_{c}" for s in segments for c in IMU_CHANNELS]
        missing = [c for c in imu_cols if c not in col]
        if missing:
            raise DataFormatError(f"{csv}: missing IMU column(s) {missing} for the IMUs declared in {sidecar_path.name}")
        imu = table[:, [col[c] for c in imu_cols]].reshape(len(t), len(segments), 3)
        labels = None
        if meta.get("labels"):
            declared = list(meta["labels"])
            lmiss = [c for c in declared if c not in col]
            if lmiss:
                raise DataFormatError(f"{csv}: label column(s) {lmiss} declared in {sidecar_path.name} are missing")
            try:
                labels = Labels.from_columns({c: table[:, col[c]] for c in declared}, len(t))
            except DataFormatError as exc:
                raise DataFormatError(f"{sidecar_path}: {exc}") from None
        placement_meta = meta["imu"].get("placement")
        placement = IMUPlacement()
        if placement_meta:
            try:
                positions = {s: tuple(_number(sidecar_path, f"imu.placement.{s}.position_m", x) for x in v["position_m"])
                             for s, v in placement_meta.items()}
                bad = [s for s, xy in positions.items() if len(xy) != 2]
                if bad:
                    raise ValueError(f"position_m of {bad} is not [x, y]")
                angles = {s: _number(sidecar_path, f"imu.placement.{s}.angle_rad", v["angle_rad"]) for s, v in placement_meta.items()}
                check_placement_angles(angles, sidecar_path)
                placement = IMUPlacement(positions=positions, angles=angles)  # type: ignore[arg-type]
            except DataFormatError:
                raise
            except (KeyError, TypeError, ValueError, AttributeError, ParameterError) as exc:
                raise DataFormatError(f"{sidecar_path}: bad imu.placement ({type(exc).__name__}: {exc}); expected "
                                      "{segment: {position_m: [x, y], angle_rad: a}} for every segment") from None
        subject = meta["subject"]
        try:
            rec = cls(
                name=csv.stem, imu=imu, segments=segments, height=float(subject["height_m"]), mass=float(subject["mass_kg"]),
                subject=str(subject.get("id", "unknown")), placement=placement, labels=labels,
                provenance=meta.get("provenance", {}),
            )
        except DataFormatError as exc:
            raise DataFormatError(f"{csv}: {str(exc).removeprefix(csv.stem + ': ')}") from None
        check_recording(rec, str(csv))
        return rec


def check_placement_angles(angles: dict[str, float], source: object) -> None:
    """:class:`DataFormatError` naming ``source`` for a placement angle beyond ±π rad: a sensor's
    angle in its segment's plane is one turn at most, so such a number is in degrees (a degree
    value within ±π cannot be told from radians here; the gravity-direction check of
    :mod:`sspinn.data.signal_checks` judges it against the signals)."""
    bad = {s: a for s, a in angles.items() if abs(a) > np.pi}
    if bad:
        shown = ", ".join(f"imu.placement.{s}.angle_rad {a:g}" for s, a in bad.items())
        raise DataFormatError(f"{source}: {shown}: beyond ±π rad — in degrees? give radians (× π/180)")


def read_data_text(path: Path, max_bytes: int = MAX_INPUT_BYTES) -> str:
    """The UTF-8 text of a data file (a byte-order mark ignored): a regular file (not a FIFO or a
    device) of at most ``max_bytes`` (:mod:`sspinn.resource_limits`), else :class:`DataFormatError`
    naming it."""
    try:
        return read_input_text(path, max_bytes, "data file")
    except ResourceLimitError as exc:
        raise DataFormatError(str(exc)) from None


def _object_without_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object; a key given twice is an error (``json`` keeps the last silently)."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"duplicate key {key!r}")
        out[key] = value
    return out


def read_json_data(path: Path, max_bytes: int = MAX_INPUT_BYTES) -> Any:
    """A JSON data file (:func:`read_data_text`); invalid JSON, a duplicate key or nesting too
    deep for the parser is a :class:`DataFormatError` naming the file."""
    text = read_data_text(path, max_bytes)
    try:
        return json.loads(text, object_pairs_hook=_object_without_duplicates)
    except RecursionError:
        raise DataFormatError(f"{path}: JSON nested too deeply") from None
    except ValueError as exc:  # JSONDecodeError is one
        raise DataFormatError(f"{path}: not valid JSON ({exc})") from None


def _read_sidecar(path: Path) -> dict[str, Any]:
    meta = read_json_data(path, MAX_CONFIG_BYTES)
    if not isinstance(meta, dict):
        raise DataFormatError(f"{path}: expected a JSON object with format, version, subject and imu; got a {type(meta).__name__}")
    if meta.get("format") != FORMAT:
        raise DataFormatError(f"{path}: 'format' must be {FORMAT!r}, got {meta.get('format')!r}")
    if meta.get("version") != VERSION:
        raise DataFormatError(f"{path}: unsupported version {meta.get('version')!r} (this sspinn reads version {VERSION})")
    if _number(path, "sample_rate_hz", meta.get("sample_rate_hz", -1)) != SAMPLE_RATE_HZ:
        raise DataFormatError(f"{path}: sample_rate_hz must be {SAMPLE_RATE_HZ}, got {meta.get('sample_rate_hz')!r}; resample first")
    for key, sub in (("subject", ("height_m", "mass_kg")), ("imu", ("segments",))):
        if key not in meta or not isinstance(meta[key], dict):
            raise DataFormatError(f"{path}: missing section {key!r}")
        for k in sub:
            if k not in meta[key]:
                raise DataFormatError(f"{path}: missing {key}.{k}")
    for k in ("height_m", "mass_kg"):
        meta["subject"][k] = _number(path, f"subject.{k}", meta["subject"][k])
    segments = meta["imu"]["segments"]
    if not isinstance(segments, list) or not all(isinstance(x, str) for x in segments):
        raise DataFormatError(f"{path}: imu.segments must be a list of segment names, got {segments!r}")
    for key in ("placement", "provenance"):
        value = (meta["imu"] if key == "placement" else meta).get(key)
        if value is not None and not isinstance(value, dict):
            raise DataFormatError(f"{path}: {'imu.' if key == 'placement' else ''}{key} must be a JSON object, got {value!r}")
    if meta.get("labels") is not None and not (isinstance(meta["labels"], list) and all(isinstance(x, str) for x in meta["labels"])):
        raise DataFormatError(f"{path}: labels must be a list of column names, got {meta['labels']!r}")
    return meta


def _number(path: Path, field_name: str, value: Any) -> float:
    """``value`` as a float if it is a JSON number (not a string, null or bool), else a
    DataFormatError naming the field."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DataFormatError(f"{path}: {field_name} must be a number (SI units, no unit text), got {value!r}")
    return float(value)


def read_csv_table(path: Path) -> tuple[list[str], np.ndarray]:
    """(column names, (rows, columns) float array) of a comma-separated file with one header
    line; clear errors for duplicate or empty columns, unreadable numbers, ragged rows and a last
    line cut short (a file must end with a newline). A UTF-8 byte-order mark is ignored."""
    text = read_data_text(path)
    lines = text.splitlines()
    if len(lines) > MAX_ROWS + 1:
        raise DataFormatError(f"{path}: {len(lines) - 1} rows, more than the {MAX_ROWS} a table may have here "
                              f"({MAX_ROWS / SAMPLE_RATE_HZ / 3600:.1f} h at 100 Hz); split it")
    if not lines or not lines[0].strip():
        raise DataFormatError(f"{path}: empty file or empty header line (expected column names)")
    if not text.endswith(("\n", "\r")) and len(lines) > 1:
        raise DataFormatError(
            f"{path}: the last line (row {len(lines)}) does not end with a newline: the file looks cut short "
            "(an interrupted copy or export); re-export it, or add the newline if it is complete"
        )
    names = [n.strip() for n in lines[0].split(",")]
    if "" in names:
        raise DataFormatError(f"{path}: empty column name at position {names.index('') + 1} of the header")
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise DataFormatError(f"{path}: duplicate column(s) {dup}")
    if not any(line.strip() for line in lines[1:]):
        raise DataFormatError(f"{path}: no data rows after the header")
    try:  # the fast path; on failure the rows are read one by one to name the bad one
        table = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2)
    except ValueError:
        table = None
    if table is not None and table.shape[0] > 0 and table.shape[1] == len(names):
        return names, table
    for row, line in ((k + 2, line) for k, line in enumerate(lines[1:]) if line.strip()):
        fields = line.split(",")
        if len(fields) != len(names):
            raise DataFormatError(f"{path}: row {row} has {len(fields)} values but the header has {len(names)} columns")
        for name, value in zip(names, fields):
            if not _is_number(value):
                raise DataFormatError(f"{path}: row {row}, column {name!r}: {value.strip()!r} is not a number")
    raise DataFormatError(f"{path}: unreadable numbers")  # pragma: no cover - loadtxt and the row check agree


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


# ---------------------------------------------------------------------- validation
def validate_recording(rec: Recording, source: str) -> None:
    """Check shapes, finiteness and plausible units; raise DataFormatError naming the problem."""
    unknown = [s for s in rec.segments if s not in SEGMENTS]
    if unknown:
        raise DataFormatError(f"{source}: unknown IMU segment(s) {unknown}; known: {list(SEGMENTS)}")
    if list(rec.segments) != [s for s in SEGMENTS if s in rec.segments]:
        raise DataFormatError(f"{source}: IMU segments must be in the order {list(SEGMENTS)}, got {list(rec.segments)}")
    if rec.imu.ndim != 3 or rec.imu.shape[1:] != (len(rec.segments), 3):
        raise DataFormatError(f"{source}: imu must have shape (T, {len(rec.segments)}, 3), got {rec.imu.shape}")
    for name, value, lo, hi in (("height", rec.height, 0.5, 2.5), ("mass", rec.mass, 10.0, 300.0)):
        if not np.isfinite(value) or not lo <= value <= hi:
            unit = "m" if name == "height" else "kg"
            hint = " (a height in cm? give metres)" if name == "height" and value > 100 else ""
            raise DataFormatError(f"{source}: subject {name} {value} outside {lo}–{hi} {unit} (units: {unit}){hint}")
    cols = rec.imu_columns()
    flat = rec.imu.reshape(rec.n_samples, -1)
    _check_finite(source, flat, cols)
    check_imu_plausibility(source, rec.imu, rec.segments, SAMPLE_RATE_HZ, rec.height, rec.placement)
    if rec.labels is None:
        return
    for group in rec.labels.available():
        arr = np.asarray(getattr(rec.labels, group), dtype=np.float64)
        cols = LABEL_COLUMNS[group]
        if arr.ndim == 1 and len(cols) == 1:
            arr = arr[:, None]
        if arr.shape != (rec.n_samples, len(cols)):
            raise DataFormatError(f"{source}: label {group!r} must have shape ({rec.n_samples}, {len(cols)}), got {arr.shape}")
        known = [i for i, c in enumerate(cols) if c not in rec.labels.missing]
        _check_finite(source, arr[:, known], [cols[i] for i in known])
        unknown = [i for i, c in enumerate(cols) if c in rec.labels.missing]
        if unknown and not np.isnan(arr[:, unknown]).all():
            raise DataFormatError(f"{source}: label columns marked missing must be NaN: {[cols[i] for i in unknown]}")
        setattr(rec.labels, group, arr if len(cols) > 1 else arr[:, 0])
    if rec.labels.q is not None and np.nanmax(np.abs(rec.labels.q[:, 2:]), initial=0.0) > 2 * np.pi:
        raise DataFormatError(f"{source}: label angles exceed 2π: they look like degrees (need rad)")
    if rec.labels.grf is not None and rec.n_samples >= 10:
        peak = np.nansum(rec.labels.grf[:, 1::2], axis=1).max()
        if 0 < peak < 0.2 * rec.mass * GRAVITY and peak < 10.0:
            raise DataFormatError(f"{source}: vertical GRF peaks at {peak:.3g}: looks like body weights (need N)")


def _check_finite(source: str, values: np.ndarray, columns: list[str]) -> None:
    bad = ~np.isfinite(values)
    if bad.any():
        row, colidx = np.argwhere(bad)[0]
        raise DataFormatError(
            f"{source}: column {columns[colidx]!r} has a non-finite value ({values[row, colidx]}) at sample {row}"
            f" ({bad.sum()} in total)"
        )


# ---------------------------------------------------------------------- datasets
SPLITS: Final = ("train", "val", "test")


@dataclass
class Dataset:
    """A folder of recordings with a by-subject split (``dataset.json``)."""

    root: Path
    splits: dict[str, list[str]]
    info: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def open(cls, root: str | Path) -> Dataset:
        root = Path(root)
        index = root / "dataset.json"
        if not index.exists():
            raise DataFormatError(f"{index}: not found (a dataset folder needs a dataset.json index)")
        meta = read_json_data(index, MAX_CONFIG_BYTES)
        splits = meta.get("splits") if isinstance(meta, dict) else None
        if not isinstance(splits, dict) or not set(splits) <= set(SPLITS):
            raise DataFormatError(f"{index}: 'splits' must map some of {SPLITS} to lists of recording names")
        for split, names in splits.items():
            if not isinstance(names, list):
                raise DataFormatError(f"{index}: split {split!r} must be a list of recording names")
            for n in names:
                check_name(n, index)  # a name like '../outside/secret' is refused, never read
                if not (root / f"{n}.csv").exists():
                    raise DataFormatError(f"{index}: split {split!r} lists {n!r} but {root / (n + '.csv')} is missing")
        return cls(root=root, splits={k: list(v) for k, v in splits.items()}, info=meta.get("info", {}))

    def load(self, split: str) -> list[Recording]:
        if split not in self.splits:
            raise DataFormatError(f"{self.root / 'dataset.json'}: no split {split!r}; available: {list(self.splits)}")
        return [Recording.load(self.root / f"{n}.csv") for n in self.splits[split]]

    @staticmethod
    def write(root: str | Path, recordings: dict[str, list[Recording]], info: dict[str, Any] | None = None) -> Dataset:
        """Save recordings per split and the index; subjects must not cross splits."""
        root = Path(root)
        seen: dict[str, str] = {}
        for split, recs in recordings.items():
            for r in recs:
                if seen.setdefault(r.subject, split) != split:
                    raise DataFormatError(f"subject {r.subject!r} appears in splits {seen[r.subject]!r} and {split!r}")
                r.save(root)
        splits = {split: [r.name for r in recs] for split, recs in recordings.items()}
        with index_lock(root):
            _write_index(root, splits, info or {})
        return Dataset(root=root, splits=splits, info=info or {})

    @staticmethod
    def add(root: str | Path, rec: Recording, splits: tuple[str, ...], update_info: Callable[[dict[str, Any]], None] | None = None,
            overwrite: bool = False) -> Dataset:
        """Save ``rec`` into the dataset folder ``root`` and list it in ``splits`` of its index
        (created if absent), ``update_info`` changing the index's ``info`` on the way. A recording
        of the same name (its CSV or sidecar, or the index's entry) is replaced only with
        ``overwrite`` and only by one of the same subject; else :class:`DataFormatError`. The read-modify-write of ``dataset.json`` holds an
        exclusive lock on the folder's index, so concurrent adds never lose each other's entries."""
        root = Path(root)
        root.mkdir(parents=True, exist_ok=True)
        index = root / INDEX
        with index_lock(root):
            meta: dict[str, Any] = {"splits": {}, "info": {}}
            if index.exists():
                meta = read_json_data(index, MAX_CONFIG_BYTES)
                if not isinstance(meta, dict) or not isinstance(meta.get("splits"), dict):
                    raise DataFormatError(f"{index}: not a dataset index (no 'splits'); use another folder")
            check_name(rec.name, root)
            if holds_recording(root, rec.name) and not overwrite:
                raise DataFormatError(f"{root}: already holds a recording {rec.name!r}; give this one another name, or "
                                      "replace it with --overwrite")
            sidecar = root / f"{rec.name}.json"
            if sidecar.exists():
                other = _read_sidecar(sidecar).get("subject", {}).get("id")
                if other != rec.subject:
                    raise DataFormatError(f"{root}: already holds a recording {rec.name!r} of subject {other!r}, not "
                                          f"{rec.subject!r}; give this one another name")
            rec.save(root)
            current = {k: [n for n in v if n != rec.name] for k, v in meta["splits"].items()}
            for split in splits:
                current.setdefault(split, []).append(rec.name)
            info = dict(meta.get("info") or {})
            if update_info is not None:
                update_info(info)
            ordered = {k: current[k] for k in SPLITS if k in current}
            _write_index(root, ordered, info)
        return Dataset(root=root, splits=ordered, info=info)


#: The index file of a dataset folder.
INDEX: Final = "dataset.json"
#: Names a recording may not take: they would collide with the dataset's own files.
RESERVED_NAMES: Final = ("dataset",)
#: The ending of the calibration reports ``sspinn import`` writes beside a recording
#: (``<name>_calibration.md/.json/.png``): no recording name may end so, or its sidecar would be
#: another recording's report.
RESERVED_SUFFIX: Final = "_calibration"


def check_name(name: object, folder: Path) -> None:
    """A recording name is a plain, visible file stem: a non-empty string of printable
    characters, no path separators, not starting with a dot, not ``dataset``, not ending in
    ``_calibration`` (the import's reports)."""
    ok = (isinstance(name, str) and bool(name) and name.isprintable() and not name.startswith(".") and "/" not in name
          and "\\" not in name and Path(name).name == name and name not in RESERVED_NAMES
          and not name.endswith(RESERVED_SUFFIX))
    if not ok:
        raise DataFormatError(f"{folder}: {name!r} is not a usable recording name (a plain, visible file name of "
                              f"printable characters, not starting with '.', without path separators, not "
                              f"{', '.join(RESERVED_NAMES)}, not ending in {RESERVED_SUFFIX!r})")


def holds_recording(root: Path, name: str) -> bool:
    """Whether the dataset folder ``root`` already has a recording ``name`` (its CSV, its
    sidecar, or an entry in ``dataset.json``)."""
    if (root / f"{name}.csv").exists() or (root / f"{name}.json").exists():
        return True
    try:
        splits = read_json_data(root / INDEX, MAX_CONFIG_BYTES).get("splits", {})
        return any(name in names for names in splits.values())
    except (OSError, ValueError, AttributeError):  # DataFormatError is a ValueError
        return False


@contextlib.contextmanager
def index_lock(root: Path) -> Iterator[None]:
    """An exclusive advisory lock (``fcntl.flock``) on ``<root>/.dataset.lock``, waited for: the
    one writer of ``dataset.json`` holds it for its whole read-modify-write."""
    root.mkdir(parents=True, exist_ok=True)
    path = root / ".dataset.lock"
    try:  # never through a symbolic link, never truncated
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
    except OSError:
        if path.is_symlink():
            raise DataFormatError(f"{path}: is a symbolic link; it is never followed: remove it") from None
        raise
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the flock


def _write_index(root: Path, splits: dict[str, list[str]], info: dict[str, Any]) -> Path:
    """The one writer of ``dataset.json`` (atomically; callers hold :func:`index_lock`)."""
    return atomic_write_text(root / INDEX, json.dumps({"format": "sspinn-dataset", "version": VERSION, "splits": splits, "info": info}, indent=2))
