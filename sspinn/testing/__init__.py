"""Test data shared by the tests, the benchmarks and the scripts (as ``numpy.testing`` is for NumPy).

Nothing here is used by the library itself: random but plausible model inputs, small synthetic
recordings (random, or with walking-like channels), a CSV column edit for corrupting files, a
tiny dataset + configuration + finished 4-step training run, vendor IMU files (Xsens MT
Manager text exports, OpenSense ``.trc``) written from given signals, and edits of real
OpenSense exports, GRF ``.mot`` files and sensor maps (bad files: a sensor removed, rows deleted,
a sensor turned over, a dead axis, sides swapped; force channels swapped, delayed, negated,
rescaled or zeroed).
"""

from __future__ import annotations

import contextlib
import gzip
import io
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sspinn.data.dataset import Dataset, Labels, Recording
from sspinn.imu.vendor_readers import opensense_files, read_mot, read_trc_vectors
from sspinn.model.conventions import COORDINATES, GRAVITY, SEGMENTS


def random_inputs(rng: np.random.Generator, batch: tuple[int, ...] = ()) -> dict[str, np.ndarray]:
    """Random but plausible model inputs (SI units) with leading ``batch`` dimensions: q (hip
    near standing height), u, q̈, τ, GRF, w, and the estimator's μ̂ and ankle kinematics."""
    q = rng.normal(scale=0.5, size=batch + (9,))
    q[..., 1] = rng.uniform(0.85, 1.0, size=batch)
    return {
        "q": q,
        "u": rng.normal(scale=2.0, size=batch + (9,)),
        "qdd": rng.normal(scale=10.0, size=batch + (9,)),
        "tau": rng.normal(scale=50.0, size=batch + (6,)),
        "grf": rng.normal(scale=300.0, size=batch + (4,)),
        "w": rng.uniform(size=batch + (2,)),
        "mu_hat": rng.normal(size=batch + (2,)),
        "ankle": rng.normal(scale=0.1, size=batch + (8,)),
    }


def make_recording(name: str = "rec", subject: str = "s01", n: int = 200, rng: np.random.Generator | None = None) -> Recording:
    """A recording of ``n`` samples with all seven IMUs (gravity plus noise) and random labels
    (coordinates, right-foot GRF, speed 1.3 m/s); 1.75 m, 70 kg."""
    rng = rng or np.random.default_rng(0)
    imu = np.zeros((n, len(SEGMENTS), 3))
    imu[:, :, 1] = GRAVITY
    imu += rng.normal(scale=0.1, size=imu.shape)
    q = rng.normal(scale=0.2, size=(n, 9))
    labels = Labels.from_columns(
        {**{c: q[:, i] for i, c in enumerate(COORDINATES)},
         "grf_x_r": np.zeros(n), "grf_y_r": np.full(n, 700.0), "speed": np.full(n, 1.3)},
        n,
    )
    return Recording(name=name, imu=imu, segments=SEGMENTS, height=1.75, mass=70.0, subject=subject, labels=labels)


def walking_recording(n: int = 300, seed: int = 0) -> Recording:
    """A recording whose channels move like walking (gyro ±1–8 rad/s per segment, acc ≈ g)."""
    rec = make_recording("walk", "s1", n, np.random.default_rng(seed))
    t = np.arange(n) / 100.0
    for i, s in enumerate(SEGMENTS):
        amp = {"pelvis": 1.0, "femur": 3.0, "tibia": 5.0, "foot": 8.0}[s.split("_")[0]]
        rec.imu[:, i, 2] = amp * np.sin(2 * np.pi * t / 1.1 + i)
    return rec


def on_ground(q: np.ndarray, body: Any, clearance: float) -> np.ndarray:
    """q shifted vertically so that the lowest heel/toe point is ``clearance`` m above ground."""
    from sspinn.model import kinematics

    pk = kinematics.point_kinematics(q, np.zeros(9), np.zeros(9), np.zeros(2), body)
    rows = [kinematics.point_index(f"{pt}_{s}") for pt in ("heel", "toe") for s in "rl"]
    q = q.copy()
    q[1] += clearance - pk[rows, 1].min()
    return q


def edit_column(lines: list[str], column: str, fn: Callable[[float], float]) -> list[str]:
    """The lines of a CSV file with ``fn`` applied to every value of ``column``."""
    k = lines[0].split(",").index(column)
    out = [lines[0]]
    for line in lines[1:]:
        v = line.split(",")
        v[k] = repr(float(fn(float(v[k]))))
        out.append(",".join(v))
    return out


def tiny_run(root: Path) -> tuple[Path, Path, Path]:
    """A tiny dataset (train: 2 recordings of 150 samples, test: 1 of 120), a tiny training
    configuration and a finished 4-step run below ``root``: (data folder, config path, run folder)."""
    import yaml

    from sspinn.estimator.sspinnpose import SSPINNpose
    from sspinn.estimator.training import TrainConfig

    rng = np.random.default_rng(3)
    data = root / "data"
    Dataset.write(data, {"train": [make_recording("a", "s1", 150, rng), make_recording("b", "s2", 150, rng)],
                         "test": [make_recording("c", "s3", 120, rng)]})
    cfg = root / "tiny.yaml"
    cfg.write_text(yaml.safe_dump({"train": {
        "network": {"hidden": 8, "layers": 1, "dropout": 0.0, "dense": 8}, "steps": 4, "batch_size": 2, "window": 32,
        "log_every": 1, "checkpoint_every": 2, "device": "cpu",
    }}))
    run = root / "run"
    with contextlib.redirect_stderr(io.StringIO()):  # the progress bar
        SSPINNpose(TrainConfig.from_yaml(cfg)).fit(Dataset.open(data).load("train"), out=run)
    return data, cfg, run


# ---------------------------------------------------------------------------------- vendor IMU files
def walking_like_3d(n: int, rng: np.random.Generator, rate: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
    """(acc, gyr) (n, 3) that pass the unit checks: gravity on X plus 1 Hz motion and noise."""
    t = np.arange(n) / rate
    acc = np.column_stack([9.81 + 2 * np.sin(2 * np.pi * t), np.cos(2 * np.pi * t), 0.5 * np.sin(4 * np.pi * t)])
    gyr = np.column_stack([0.3 * np.sin(2 * np.pi * t), 0.2 * np.cos(2 * np.pi * t), 3 * np.sin(2 * np.pi * t + 1)])
    return acc + rng.normal(scale=0.05, size=(n, 3)), gyr + rng.normal(scale=0.01, size=(n, 3))


def write_xsens_txt(path: Path, acc: np.ndarray, gyr: np.ndarray, rate: float = 100.0, counter0: int = 0, tick0: int = 0,
                    drop: tuple[int, ...] = (), sep: str = "\t", columns: tuple[str, ...] | None = None,
                    time_format: str = "ticks", header: bool = True, decimal_comma: bool = False) -> Path:
    """An MT Manager text export: '//' header (left out with ``header=False``), PacketCounter
    (16 bit), SampleTimeFine, Acc, Gyr, Mag, Quat, separated by ``sep`` (``" "``: aligned by
    spaces); rows listed in ``drop`` are left out (dropped packets).

    ``time_format``: SampleTimeFine as ``"ticks"`` (1e-4 s, 32 bit, from ``tick0``),
    ``"seconds"`` (from ``tick0`` × 1e-4 s), ``"blank"`` (empty in every row, as MT Manager
    writes it when the time was not exported) or ``"nan"`` (``NaN`` in every row).
    ``decimal_comma``: numbers written with a decimal comma (a European locale; use ``sep=";"``).
    """
    if time_format not in ("ticks", "seconds", "blank", "nan"):
        raise ValueError(f"time_format must be ticks, seconds, blank or nan, got {time_format!r}")
    n = len(acc)
    names = columns or ("PacketCounter", "SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z",
                        "Mag_X", "Mag_Y", "Mag_Z", "Quat_q0", "Quat_q1", "Quat_q2", "Quat_q3")
    lines = ["// Start Time: Unknown", f"// Update Rate: {rate:.1f}Hz", "// Filter Profile: human (46.1)",
             "// Option Flags: AHS Disabled ICC Disabled", "// Firmware Version: 4.0.2"] if header else []
    lines.append(sep.join(names))
    for k in range(n):
        if k in drop:
            continue
        ticks = (tick0 + round(k * 1e4 / rate)) % 2**32
        fine = {"ticks": str(ticks), "seconds": f"{(tick0 + k * 1e4 / rate) * 1e-4:.6f}", "blank": "", "nan": "NaN"}[time_format]
        values = {"PacketCounter": f"{(counter0 + k) % 65536:05d}", "SampleTimeFine": fine}
        values.update({f"Acc_{a}": f"{acc[k, i]:.6f}" for i, a in enumerate("XYZ")})
        values.update({f"Gyr_{a}": f"{gyr[k, i]:.6f}" for i, a in enumerate("XYZ")})
        values.update({f"FreeAcc_{a}": f"{acc[k, i] - (9.81 if a == 'X' else 0):.6f}" for i, a in enumerate("XYZ")})
        values.update({f"Mag_{a}": "0.5" for a in "XYZ"})
        values.update({"Quat_q0": "1", "Quat_q1": "0", "Quat_q2": "0", "Quat_q3": "0"})
        row = [values[c] for c in names]
        if decimal_comma:
            row = [v.replace(".", ",") for v in row]
        lines.append(sep.join(row))
    path.write_text("\n".join(lines) + "\n")
    return path


def write_opensense(folder: Path, stem: str, sensors: dict[str, tuple[np.ndarray, np.ndarray]], compress: bool = False,
                    time: np.ndarray | None = None) -> Path:
    """``<stem>_Accel.trc`` and ``_Gyro.trc`` as OpenSense writes them (the CMU files' header
    layout, including the stray tab on line 5), optionally gzip-compressed; returns the accel file.
    ``time``: the Time column, s (default: 100 Hz from 0)."""
    names = list(sensors)
    n = len(next(iter(sensors.values()))[0])
    time = np.arange(n) / 100 if time is None else time
    out, stray = None, "\t"  # the CMU files have a stray tab before the last sensor's Y label
    for kind, index in (("Accel", 0), ("Gyro", 1)):
        lines = [f"PathFileType\t4\t(X/Y/Z)\t{stem}_{kind}.trc",
                 "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
                 f"100\t100\t{n}\t{len(names)}\tm\t100\t1\t{n}",
                 "Frame#\tTime\t" + "\t".join(names),
                 "\t\t" + "\t".join(f"X{i + 1}\t{stray if i == len(names) - 1 else ''}Y{i + 1}\tZ{i + 1}" for i in range(len(names))) + "\t",
                 ""]
        for k in range(n):
            row = [str(k + 1), f"{time[k]:.8f}"] + [f"{v:.8f}" for s in names for v in sensors[s][index][k]]
            lines.append("\t".join(row))
        text = "\n".join(lines) + "\n"
        path = folder / f"{stem}_{kind}.trc{'.gz' if compress else ''}"
        path.write_bytes(gzip.compress(text.encode()) if compress else text.encode())
        out = out or path
    return out


#: Raw OpenSense sensors: name → (acc (n, 3), gyr (n, 3)).
OpenSenseSensors = dict[str, tuple[np.ndarray, np.ndarray]]
#: An edit of a raw OpenSense export: (time (n,), sensors) → (time, sensors).
OpenSenseEdit = Callable[[np.ndarray, OpenSenseSensors], tuple[np.ndarray, OpenSenseSensors]]


def read_opensense_raw(accel: Path, end_s: float | None = None) -> tuple[np.ndarray, OpenSenseSensors]:
    """(time, sensors) of a real OpenSense export (its ``_Accel`` file, the ``_Gyro`` beside it),
    rows with time < ``end_s`` only: the material for :func:`write_opensense` copies with errors."""
    files = opensense_files(accel)
    time, acc, _ = read_trc_vectors(files["accel"])
    _, gyr, _ = read_trc_vectors(files["gyro"])
    keep = time < (np.inf if end_s is None else end_s)
    return time[keep], {n: (acc[n][keep], gyr[n][keep]) for n in acc}


def sensor_removed(name: str) -> OpenSenseEdit:
    """An edit that removes one sensor's columns from both files."""
    return lambda time, sensors: (time, {n: v for n, v in sensors.items() if n != name})


def rows_deleted(start_s: float, seconds: float) -> OpenSenseEdit:
    """An edit that deletes the rows with ``start_s <= time < start_s + seconds`` (a gap)."""
    def edit(time: np.ndarray, sensors: OpenSenseSensors) -> tuple[np.ndarray, OpenSenseSensors]:
        keep = (time < start_s - 1e-9) | (time >= start_s + seconds - 1e-9)
        return time[keep], {n: (a[keep], g[keep]) for n, (a, g) in sensors.items()}
    return edit


def sensor_turned(name: str, axis: int) -> OpenSenseEdit:
    """An edit that turns one sensor 180° about its own axis ``axis`` (0 X, 1 Y, 2 Z): the other
    two axes of its accelerometer and gyroscope change sign (remounted upside down or back to front)."""
    flip = -np.ones(3)
    flip[axis] = 1.0
    return lambda time, sensors: (time, {**sensors, name: (sensors[name][0] * flip, sensors[name][1] * flip)})


def axis_constant(name: str, quantity: int, axis: int, value: float = 0.0) -> OpenSenseEdit:
    """An edit that sets one axis (0 X, 1 Y, 2 Z) of one sensor's accelerometer (``quantity`` 0)
    or gyroscope (1) to ``value``: a dead axis, or a 2D export padded to 3D."""
    def edit(time: np.ndarray, sensors: OpenSenseSensors) -> tuple[np.ndarray, OpenSenseSensors]:
        signals = [sensors[name][0].copy(), sensors[name][1].copy()]
        signals[quantity][:, axis] = value
        return time, {**sensors, name: (signals[0], signals[1])}
    return edit


def sensor_map_edited(path: Path, swap: tuple[str, ...] = (), **entries: object) -> dict:
    """The sensor map YAML at ``path`` as a dict, with the sides (``_r``/``_l``) of the sensors in
    ``swap`` exchanged and ``entries`` (sensor → segment or mapping) set: wrong maps for tests."""
    data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    for sensor in swap:
        entry = data["sensors"][sensor]
        segment = entry if isinstance(entry, str) else entry["segment"]
        segment = segment[:-1] + {"r": "l", "l": "r"}[segment[-1]]
        data["sensors"][sensor] = segment if isinstance(entry, str) else {**entry, "segment": segment}
    data["sensors"].update(entries)
    return data


def sensor_map_with_pelvis(path: Path, sensor: str) -> dict:
    """The sensor map YAML at ``path`` as a dict with ``sensor`` (an ignored one, e.g. the torso's)
    mapped as the pelvis and the pelvis sensor of the map ignored instead: a wrong map for tests."""
    data = sensor_map_edited(path)
    pelvis = next(name for name, entry in data["sensors"].items() if (entry if isinstance(entry, str) else entry["segment"]) == "pelvis")
    del data["sensors"][pelvis]
    data["sensors"][sensor] = "pelvis"
    data["ignore"] = [name for name in data.get("ignore", []) if name != sensor] + [pelvis]
    return data


# ---------------------------------------------------------------------------------- GRF files
#: An edit of a GRF table: (column names, (rows, columns) values, time (rows,) s) → new values.
GRFEdit = Callable[[list[str], np.ndarray, np.ndarray], np.ndarray]


def write_grf_edited(source: Path, out: Path, edit: GRFEdit) -> Path:
    """A copy of the OpenSim ``.mot`` ``source`` (plain or gzip) with ``edit`` applied to its
    values, written as a plain ``.mot`` at ``out`` (header: name, version, nRows, nColumns,
    inDegrees=no, endheader)."""
    names, table = read_mot(source)
    values = edit(names, table.copy(), table[:, names.index("time")])
    lines = [out.name, "version=1", f"nRows={len(values)}", f"nColumns={len(names)}", "inDegrees=no", "endheader",
             "\t".join(names)] + ["\t".join(f"{v:.8f}" for v in row) for row in values]
    out.write_text("\n".join(lines) + "\n")
    return out


def _force_columns(names: list[str], side: str) -> list[int]:
    return [k for k, n in enumerate(names) if n.startswith(f"{side}F") or n.startswith(f"{side}COP") or n.startswith(f"{side}M")]


def grf_sides_swapped(names: list[str], values: np.ndarray, time: np.ndarray) -> np.ndarray:
    """A GRF edit: the right and left columns (``r*``/``l*`` forces, centres of pressure, moments) exchanged."""
    r, l = _force_columns(names, "r"), _force_columns(names, "l")
    values[:, r + l] = values[:, l + r]
    return values


def grf_side_delayed(side: str, seconds: float) -> GRFEdit:
    """A GRF edit: one side's columns delayed by ``seconds`` (its first value repeated before)."""
    def edit(names: list[str], values: np.ndarray, time: np.ndarray) -> np.ndarray:
        k = int(round(seconds / float(np.median(np.diff(time)))))
        cols = _force_columns(names, side)
        values[k:, cols] = values[:-k, cols].copy()
        values[:k, cols] = values[k, cols]
        return values
    return edit


def grf_scaled(factor: float) -> GRFEdit:
    """A GRF edit: every force column (``*F*``) times ``factor`` (−1: negated; 1/9.81: kgf)."""
    def edit(names: list[str], values: np.ndarray, time: np.ndarray) -> np.ndarray:
        cols = [k for k, n in enumerate(names) if n[1:2] == "F"]
        values[:, cols] *= factor
        return values
    return edit


def grf_clock_jump(at_s: float, seconds: float) -> GRFEdit:
    """A GRF edit: ``seconds`` of samples lost at ``at_s`` without their time stamps (every later
    row moves up; the last row repeated at the end): from ``at_s`` the forces run early."""
    def edit(names: list[str], values: np.ndarray, time: np.ndarray) -> np.ndarray:
        k = int(round(seconds / float(np.median(np.diff(time)))))
        i = int(np.searchsorted(time, at_s))
        cols = [c for c, n in enumerate(names) if n != "time"]
        values[i:-k, cols] = values[i + k:, cols].copy()
        values[-k:, cols] = values[-k - 1, cols]
        return values
    return edit


def grf_unloaded(start_s: float, seconds: float) -> GRFEdit:
    """A GRF edit: both feet's forces zero from ``start_s`` for ``seconds`` (contact with the plates lost)."""
    def edit(names: list[str], values: np.ndarray, time: np.ndarray) -> np.ndarray:
        rows = (time >= start_s) & (time < start_s + seconds)
        values[np.ix_(rows, [k for k, n in enumerate(names) if n[1:2] == "F"])] = 0.0
        return values
    return edit
