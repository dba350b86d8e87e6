"""Vendor IMU readers (OpenSense .trc/.sto, Xsens MT Manager .txt) and the raw-stream checks:
units, constant axes, gaps (packet counter, time stamps, blanks), resampling."""

from __future__ import annotations

import numpy as np
import pytest

from sspinn.imu.stream import IMUImportError, IMUStream, SensorSignals, check_sensor, find_gaps, resample
from sspinn.imu.vendor_readers import (
    read_imu_files,
    read_opensense,
    read_treadmill_grf,
    read_xsens_txt,
    xsens_sensor_name,
)
from sspinn.testing import walking_like_3d, write_opensense, write_xsens_txt
from tests.conftest import shared_data


def test_xsens_reader_times_counters_and_gaps(tmp_path, rng) -> None:
    acc, gyr = walking_like_3d(700, rng)
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
    acc, gyr = walking_like_3d(300, rng)
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
    acc, gyr = walking_like_3d(300, rng)
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
    acc, gyr = walking_like_3d(400, rng)
    t = np.arange(400) / 100.0
    t[250:] += 0.2
    (gap,) = find_gaps(SensorSignals("s", "f.txt", t, acc, gyr))
    assert gap.detected_by == "time stamps" and gap.missing == 20
    t[300] = t[299]
    with pytest.raises(IMUImportError, match=r"f\.txt, sensor 's': time stamps do not increase"):
        find_gaps(SensorSignals("s", "f.txt", t, acc, gyr))


def test_resampling_onto_another_streams_grid(rng) -> None:
    """A sensor resampled onto a given grid keeps its values at its own sample times; a grid it does
    not cover is an error naming the spans."""
    acc, gyr = walking_like_3d(400, rng)
    t = np.arange(400) / 100.0
    stream = IMUStream({"s": SensorSignals("s", "f.txt", t, acc, gyr)}, "f.txt")
    grid, same = resample(stream, grid=t[10:300])
    np.testing.assert_array_equal(grid, t[10:300])
    np.testing.assert_allclose(same.sensors["s"].acc, acc[10:300], atol=1e-12)
    with pytest.raises(IMUImportError, match=r"f\.txt: the sensors cover 0\.000–3\.990 s, not the grid's 1\.000–5\.000 s"):
        resample(stream, grid=np.arange(100, 501) / 100.0)


@pytest.mark.parametrize("compress", [False, True])
def test_opensense_round_trip(tmp_path, rng, compress) -> None:
    sensors = {f"{n}_imu": walking_like_3d(300, rng) for n in ("pelvis", "femur_r")}
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


def test_other_rates_are_filtered_and_resampled(tmp_path, rng) -> None:
    acc, gyr = walking_like_3d(1200, rng, rate=120.0)
    s = read_xsens_txt(write_xsens_txt(tmp_path / "fast.txt", acc, gyr, rate=120.0))
    assert s.sample_rate_hz == pytest.approx(120.0, rel=1e-3)
    grid, out = resample(IMUStream({"fast": s}, "fast.txt"))
    assert np.allclose(np.diff(grid), 0.01) and any("low-pass filtered at 40 Hz" in n for n in out.notes)
    t = grid - s.time[0]
    expected = 3 * np.sin(2 * np.pi * t + 1)  # the 1 Hz part of gyr Z survives the 40 Hz filter
    assert np.sqrt(np.mean((out.sensors["fast"].gyr[:, 2] - expected) ** 2)) < 0.03
