"""Vendor IMU readers (OpenSense .trc/.sto, Xsens MT Manager .txt) and the raw-stream checks:
units, constant axes, gaps (packet counter, time stamps, blanks), resampling."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from sspinn.imu_stream import IMUImportError, IMUStream, SensorSignals, check_sensor, find_gaps, resample
from sspinn.vendor_formats import (
    read_imu_files,
    read_opensense,
    read_treadmill_grf,
    read_xsens_txt,
    xsens_sensor_name,
)
from tests.conftest import shared_data


def walking_like(n: int, rng: np.random.Generator, rate: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
    """(acc, gyr) (n, 3) that pass the unit checks: gravity on X plus 1 Hz motion and noise."""
    t = np.arange(n) / rate
    acc = np.column_stack([9.81 + 2 * np.sin(2 * np.pi * t), np.cos(2 * np.pi * t), 0.5 * np.sin(4 * np.pi * t)])
    gyr = np.column_stack([0.3 * np.sin(2 * np.pi * t), 0.2 * np.cos(2 * np.pi * t), 3 * np.sin(2 * np.pi * t + 1)])
    return acc + rng.normal(scale=0.05, size=(n, 3)), gyr + rng.normal(scale=0.01, size=(n, 3))


def write_xsens_txt(path: Path, acc: np.ndarray, gyr: np.ndarray, rate: float = 100.0, counter0: int = 0, tick0: int = 0,
                    drop: tuple[int, ...] = (), sep: str = "\t", columns: tuple[str, ...] | None = None) -> Path:
    """An MT Manager text export: '//' header, PacketCounter (16 bit), SampleTimeFine (1e-4 s
    ticks, 32 bit), Acc, Gyr, Mag, Quat; rows listed in ``drop`` are left out (dropped packets)."""
    n = len(acc)
    header = columns or ("PacketCounter", "SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z",
                         "Mag_X", "Mag_Y", "Mag_Z", "Quat_q0", "Quat_q1", "Quat_q2", "Quat_q3")
    lines = ["// Start Time: Unknown", f"// Update Rate: {rate:.1f}Hz", "// Filter Profile: human (46.1)",
             "// Option Flags: AHS Disabled ICC Disabled", "// Firmware Version: 4.0.2", sep.join(header)]
    for k in range(n):
        if k in drop:
            continue
        values = {"PacketCounter": f"{(counter0 + k) % 65536:05d}", "SampleTimeFine": str((tick0 + round(k * 1e4 / rate)) % 2**32)}
        values.update({f"Acc_{a}": f"{acc[k, i]:.6f}" for i, a in enumerate("XYZ")})
        values.update({f"Gyr_{a}": f"{gyr[k, i]:.6f}" for i, a in enumerate("XYZ")})
        values.update({f"FreeAcc_{a}": f"{acc[k, i] - (9.81 if a == 'X' else 0):.6f}" for i, a in enumerate("XYZ")})
        values.update({f"Mag_{a}": "0.5" for a in "XYZ"})
        values.update({"Quat_q0": "1", "Quat_q1": "0", "Quat_q2": "0", "Quat_q3": "0"})
        lines.append(sep.join(values[c] for c in header))
    path.write_text("\n".join(lines) + "\n")
    return path


def write_opensense(folder: Path, stem: str, sensors: dict[str, tuple[np.ndarray, np.ndarray]], compress: bool = False) -> Path:
    """``<stem>_Accel.trc`` and ``_Gyro.trc`` as OpenSense writes them (the CMU files' header
    layout, including the stray tab on line 5), optionally gzip-compressed; returns the accel file."""
    names = list(sensors)
    n = len(next(iter(sensors.values()))[0])
    out, stray = None, "\t"  # the CMU files have a stray tab before the last sensor's Y label
    for kind, index in (("Accel", 0), ("Gyro", 1)):
        lines = [f"PathFileType\t4\t(X/Y/Z)\t{stem}_{kind}.trc",
                 "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
                 f"100\t100\t{n}\t{len(names)}\tm\t100\t1\t{n}",
                 "Frame#\tTime\t" + "\t".join(names),
                 "\t\t" + "\t".join(f"X{i + 1}\t{stray if i == len(names) - 1 else ''}Y{i + 1}\tZ{i + 1}" for i in range(len(names))) + "\t",
                 ""]
        for k in range(n):
            row = [str(k + 1), f"{k / 100:.8f}"] + [f"{v:.8f}" for s in names for v in sensors[s][index][k]]
            lines.append("\t".join(row))
        text = "\n".join(lines) + "\n"
        path = folder / f"{stem}_{kind}.trc{'.gz' if compress else ''}"
        path.write_bytes(gzip.compress(text.encode()) if compress else text.encode())
        out = out or path
    return out


def test_xsens_reader_times_counters_and_gaps(tmp_path, rng) -> None:
    acc, gyr = walking_like(700, rng)
    path = write_xsens_txt(tmp_path / "MT_01200627_000-000_00B41234.txt", acc, gyr, counter0=65500, tick0=2**32 - 3000,
                           drop=(200, 201, 202))
    s = read_xsens_txt(path)
    assert s.name == "00B41234" == xsens_sensor_name(path)
    assert len(s.time) == 697 and s.sample_rate_hz == pytest.approx(100.0)
    assert np.all(np.diff(s.time) > 0), "SampleTimeFine wraps at 2^32 and is unwrapped"
    assert s.orientation is not None and s.orientation.shape == (697, 4)
    gaps = find_gaps(s)
    assert len(gaps) == 1 and gaps[0].missing == 3 and gaps[0].detected_by == "packet counter"
    assert gaps[0].start_s == pytest.approx(s.time[199])
    grid, out = resample(IMUStream({s.name: s}, str(path)), max_gap_s=0.05)
    assert np.allclose(np.diff(grid), 0.01) and any("gap interpolated" in n for n in out.notes)
    np.testing.assert_allclose(out.sensors[s.name].acc[:150], acc[:150], atol=1e-5)
    with pytest.raises(IMUImportError, match=r"00B41234.*3 sample\(s\) missing.*cannot be bridged"):
        resample(IMUStream({s.name: s}, str(path)), max_gap_s=0.02)


def test_xsens_comma_separated_and_blank_values(tmp_path, rng) -> None:
    acc, gyr = walking_like(300, rng)
    path = write_xsens_txt(tmp_path / "shank.csv", acc, gyr, sep=",")
    text = path.read_text().splitlines()
    fields = text[6 + 100].split(",")
    fields[2] = ""  # a missing Acc_X: a gap of one sample found from the blanks
    text[6 + 100] = ",".join(fields)
    path.write_text("\n".join(text) + "\n")
    s = read_xsens_txt(path)
    assert s.name == "shank" and np.isnan(s.acc[100, 0])
    (gap,) = find_gaps(s)
    assert gap.detected_by == "non-finite values" and gap.missing == 1


def test_xsens_rejects_free_acceleration_and_bad_units(tmp_path, rng) -> None:
    acc, gyr = walking_like(300, rng)
    cols = ("PacketCounter", "SampleTimeFine", "FreeAcc_X", "FreeAcc_Y", "FreeAcc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z")
    with pytest.raises(IMUImportError, match=r"foot\.txt, sensor 'foot': missing column.*FreeAcc"):
        read_xsens_txt(write_xsens_txt(tmp_path / "foot.txt", acc, gyr, columns=cols))
    deg = read_xsens_txt(write_xsens_txt(tmp_path / "deg.txt", acc, gyr * 180 / np.pi * 5))
    with pytest.raises(IMUImportError, match=r"deg\.txt, sensor 'deg': gyroscope reaches .* looks like deg/s"):
        check_sensor(deg)
    in_g = read_xsens_txt(write_xsens_txt(tmp_path / "g.txt", acc / 9.81, gyr))
    with pytest.raises(IMUImportError, match=r"g\.txt, sensor 'g': median \|acc\| .* units of g"):
        check_sensor(in_g)
    flat = acc.copy()
    flat[:, 2] = 0.25
    with pytest.raises(IMUImportError, match=r"flat\.txt, sensor 'flat': acc axis Z is constant"):
        check_sensor(read_xsens_txt(write_xsens_txt(tmp_path / "flat.txt", flat, gyr)))


def test_time_stamp_gap_and_reset_clock(rng) -> None:
    acc, gyr = walking_like(400, rng)
    t = np.arange(400) / 100.0
    t[250:] += 0.2
    (gap,) = find_gaps(SensorSignals("s", "f.txt", t, acc, gyr))
    assert gap.detected_by == "time stamps" and gap.missing == 20
    t[300] = t[299]
    with pytest.raises(IMUImportError, match=r"f\.txt, sensor 's': time stamps do not increase"):
        find_gaps(SensorSignals("s", "f.txt", t, acc, gyr))


@pytest.mark.parametrize("compress", [False, True])
def test_opensense_round_trip(tmp_path, rng, compress) -> None:
    sensors = {f"{n}_imu": walking_like(300, rng) for n in ("pelvis", "femur_r")}
    accel = write_opensense(tmp_path, "OpenSim_S1_T1", sensors, compress)
    stream = read_imu_files([accel])
    assert stream.names == ["pelvis_imu", "femur_r_imu"]
    for name, (acc, gyr) in sensors.items():
        np.testing.assert_allclose(stream.sensors[name].acc, acc, atol=1e-7)
        np.testing.assert_allclose(stream.sensors[name].gyr, gyr, atol=1e-7)
    quats = "\t".join(["time", *sensors]) + "\n" + "\n".join(
        "\t".join([f"{k / 100:.2f}"] + ["1,0,0,0"] * 2) for k in range(300))
    (tmp_path / "OpenSim_S1_T1_Orientations.sto").write_text(f"DataRate=100\nDataType=Quaternion\nendheader\n{quats}\n")
    assert read_opensense(accel).sensors["femur_r_imu"].orientation.shape == (300, 4)
    (tmp_path / f"OpenSim_S1_T1_Gyro.trc{'.gz' if compress else ''}").unlink()
    with pytest.raises(IMUImportError, match=r"lacks OpenSim_S1_T1_Gyro\.trc"):
        read_imu_files([accel])


def test_cmu_opensense_files_and_grf() -> None:
    folder = shared_data("cmu_treadmill_imu_grf") / "Sub01" / "CSBaseline"
    stream = read_imu_files([folder / "OpenSim_Sub01_CSBaseline_Gyro.trc.gz"])
    assert len(stream.names) == 8 and all(n.endswith("_imu_offset_imu") for n in stream.names)
    s = stream.sensors["tibia_r_imu_offset_imu"]
    assert s.time.shape == (5950,) and s.sample_rate_hz == pytest.approx(100.0)
    check_sensor(s)
    assert find_gaps(s) == []
    t, forces = read_treadmill_grf(folder / "OpenSim_Sub01_CSBaseline_GRF.mot.gz")
    assert t.shape == (5950,) and forces["r"].shape == (5950, 2)
    assert 0.8 < (forces["r"][:, 1] + forces["l"][:, 1]).mean() / (66.7 * 9.81) < 1.2  # ≈ body weight
