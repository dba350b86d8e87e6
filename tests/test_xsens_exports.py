"""Xsens MT Manager exports as users have them: the real static export in
``../shared/data/xsens_mt_static_S01`` (blank SampleTimeFine, device ID at the end of
``<trial>-000_<ID>.txt``, two files without a header), and generated variants (separators, time
columns in ticks, seconds, blank or NaN, counter and clock wrap-around, gaps, no header, decimal
commas, file names, maps keyed by file stem); OpenSim's ``.sto`` IMU tables and case variants
of the OpenSense file names."""

from __future__ import annotations

import runpy
import shutil
from pathlib import Path

import numpy as np
import pytest

from sspinn.imu.stream import IMUImportError, check_sensor, find_gaps, resample, standing_statistics
from sspinn.imu.vendor_readers import (
    read_imu_files,
    read_opensense,
    read_xsens_files,
    read_xsens_txt,
    xsens_device_id,
    xsens_sensor_name,
)
from sspinn.model.conventions import GRAVITY
from sspinn.testing import walking_like_3d, write_opensense, write_xsens_txt
from tests.conftest import shared_data

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
#: The real static export: 11 MTw sensors, 366 rows each at 100 Hz; two files (00B40C44 and
#: 00B40C47) have no '//' header and 'NaN' time fields, and hold the same values as 00B40C49 and
#: 00B40C4A (copies in the source data).
STATIC = "xsens_mt_static_S01"
#: Tolerance on the mean |specific force| of a still, working accelerometer: 2 % of g (the 11
#: real sensors read +0.2 … +1.5 %).
ACC_TOLERANCE = 0.02 * GRAVITY
#: Largest plausible gyroscope bias of a still MEMS sensor, rad/s (the 11 real ones: 0.006–0.030).
MAX_GYRO_BIAS = 0.05


# ---------------------------------------------------------------------------------- the real export
@pytest.fixture(scope="module")
def static_files() -> list[Path]:
    return sorted(shared_data(STATIC).glob("*.txt"))


def test_real_static_export_reads_and_stands_at_g(static_files) -> None:
    stream = read_imu_files(static_files)
    assert len(static_files) == 11 and stream.names == [xsens_device_id(p) for p in static_files]
    assert all(n.startswith("00B4") for n in stream.names)
    notes = "\n".join(stream.notes)
    assert notes.count("SampleTimeFine blank in every row: time = PacketCounter (16-bit, unwrapped) / 100 Hz") == 11
    assert notes.count("(the other files' header)") == 2  # the two files without '//' lines
    for s in stream.sensors.values():
        assert len(s.time) == 366 and s.sample_rate_hz == pytest.approx(100.0) and s.counter[0] == 19741
        check_sensor(s)
        assert find_gaps(s) == []
        stats = standing_statistics(s)
        assert abs(stats.acc_norm_m_s2 - GRAVITY) < ACC_TOLERANCE, stats.describe()
        assert np.linalg.norm(stats.gyro_bias_rad_s) < MAX_GYRO_BIAS, stats.describe()
        assert "gyro bias (" in stats.describe() and "from g" in stats.describe()
    # the source's two copied files are named
    assert len(stream.warnings) == 2 and "'00B40C44' and '00B40C49' hold identical" in stream.warnings[0]
    grid, _ = resample(stream)
    assert len(grid) == 366


def test_real_file_alone_needs_a_rate_and_a_map_may_name_it_by_stem(static_files) -> None:
    headerless = next(p for p in static_files if p.stem.endswith("00B40C44"))
    with pytest.raises(IMUImportError, match=rf"{headerless.name}, sensor '00B40C44', column PacketCounter: SampleTimeFine blank "
                                             r"in every row, so time = PacketCounter / update rate, but no rate is known.*--imu-rate"):
        read_xsens_txt(headerless)
    assert read_xsens_txt(headerless, rate_hz=100.0).sample_rate_hz == pytest.approx(100.0)
    with pytest.raises(IMUImportError, match=r"00B40B91.txt, sensor '00B40B91': its header says 100 Hz, the given rate is 60 Hz"):
        read_xsens_files(static_files[:1], rate_hz=60.0)
    stem = static_files[0].stem
    assert read_imu_files(static_files[:2], known=(stem, "00b40ba5")).names == [stem, "00b40ba5"]


def test_check_imu_files_script_prints_the_bias(static_files, capsys) -> None:
    script = runpy.run_path(str(SCRIPTS / "check_imu_files.py"), run_name="check_imu_files")
    assert script["main"]([str(p) for p in static_files[:3]]) == 0
    out = capsys.readouterr().out
    assert out.count("gyro bias (") == 3 and "units ok, 0 gap(s)" in out and "00B40B91" in out


# ---------------------------------------------------------------------------------- generated variants
@pytest.mark.parametrize("sep", [",", "\t", ";", " "], ids=["comma", "tab", "semicolon", "whitespace"])
@pytest.mark.parametrize("time_format, rate", [("ticks", 100.0), ("seconds", 40.0), ("blank", 100.0), ("nan", 40.0)])
def test_separators_and_time_columns(tmp_path, rng, sep, time_format, rate) -> None:
    acc, gyr = walking_like_3d(500, rng, rate=rate)
    path = write_xsens_txt(tmp_path / "S07-Walk-000_00B4ABCD.txt", acc, gyr, rate=rate, sep=sep, time_format=time_format,
                           counter0=65400, tick0=2**32 - 1500, drop=(300, 301))
    if sep == " " and time_format == "blank":  # a blank field cannot be seen between spaces
        with pytest.raises(IMUImportError, match=r"line 7 has 14 values, the header 15 columns: in a whitespace-separated table"):
            read_xsens_txt(path)
        return
    stream = read_xsens_files([path])
    s = stream.sensors["00B4ABCD"]
    assert len(s.time) == 498 and s.sample_rate_hz == pytest.approx(rate, rel=1e-3)
    assert np.all(np.diff(s.time) > 0)  # the counter (65,535 → 0) and the ticks (2^32 → 0) unwrapped
    np.testing.assert_allclose(s.acc, np.delete(acc, [300, 301], axis=0), atol=1e-6)
    (gap,) = find_gaps(s)
    assert gap.missing == 2 and gap.detected_by == "packet counter" and gap.duration_s == pytest.approx(3 / rate)
    expected = {"ticks": "SampleTimeFine read as 1e-4 s ticks", "seconds": "SampleTimeFine read as seconds",
                "blank": "SampleTimeFine blank in every row", "nan": "SampleTimeFine blank in every row"}[time_format]
    assert expected in "\n".join(stream.notes)


def test_no_header_decimal_comma_and_empty_packet_rows(tmp_path, rng) -> None:
    acc, gyr = walking_like_3d(300, rng)
    plain = write_xsens_txt(tmp_path / "a_00B40001.txt", acc, gyr, sep=";", decimal_comma=True, time_format="blank")
    np.testing.assert_allclose(read_xsens_txt(plain).gyr, gyr, atol=1e-6)
    bare = write_xsens_txt(tmp_path / "b_00B40002.txt", acc, gyr, header=False, time_format="blank")
    stream = read_xsens_files([plain, bare])
    assert "b_00B40002.txt, sensor '00B40002': SampleTimeFine blank in every row: time = PacketCounter (16-bit, unwrapped) / 100 Hz " \
           "(the other files' header)" in "\n".join(stream.notes)
    np.testing.assert_allclose(stream.sensors["00B40002"].time, stream.sensors["00B40001"].time)
    # MT Manager may write a row with only the counter for a missing packet: left out, the counter shows the gap
    lines = write_xsens_txt(tmp_path / "c.txt", acc, gyr, time_format="ticks").read_text().splitlines()
    lines[6 + 50] = lines[6 + 50].split("\t")[0] + "\t" * 14
    (tmp_path / "c.txt").write_text("\n".join(lines) + "\n")
    stream = read_xsens_files([tmp_path / "c.txt"])
    (gap,) = find_gaps(stream.sensors["c"])
    assert gap.missing == 1 and "1 row(s) without data left out (missing packets)" in "\n".join(stream.notes)


def test_time_column_errors_name_file_column_and_assumption(tmp_path, rng) -> None:
    acc, gyr = walking_like_3d(200, rng)
    path = write_xsens_txt(tmp_path / "x.txt", acc, gyr)
    lines = path.read_text().splitlines()

    def edited(name: str, column: int, value) -> Path:
        out = []
        for k, line in enumerate(lines):
            fields = line.split("\t")
            if k >= 6:
                fields[column] = value(k - 6, fields[column])
            out.append("\t".join(fields))
        (tmp_path / name).write_text("\n".join(out) + "\n")
        return tmp_path / name

    ms = edited("ms.txt", 1, lambda k, v: str(k * 10))  # milliseconds: 1,000 Hz as ticks, but the header says 100 Hz
    with pytest.raises(IMUImportError, match=r"ms\.txt, sensor 'ms', column SampleTimeFine: read as 1e-4 s ticks it steps at "
                                             r"1000 Hz, but the file's header says 100 Hz"):
        read_xsens_txt(ms)
    odd = edited("odd.txt", 1, lambda k, v: str(2.5 * k))  # neither ticks (integers) nor seconds (≤ 1 s per sample)
    with pytest.raises(IMUImportError, match=r"odd\.txt, sensor 'odd', column SampleTimeFine: median step 2\.5 fits neither "
                                             r"assumption: 1e-4 s ticks .* nor seconds"):
        read_xsens_txt(odd)
    partial = edited("partial.txt", 1, lambda k, v: "" if k == 40 else v)  # one blank time: the counter times the file
    stream = read_xsens_files([partial])
    assert "SampleTimeFine blank in 1 of 200 rows: time = PacketCounter" in "\n".join(stream.notes)
    counter = edited("counter.txt", 0, lambda k, v: "" if k == 40 else v)
    with pytest.raises(IMUImportError, match=r"counter\.txt, sensor 'counter', column PacketCounter: blank at line 47 .*16-bit"):
        read_xsens_txt(counter)
    text = edited("text.txt", 3, lambda k, v: "abc" if k == 10 else v)
    with pytest.raises(IMUImportError, match=r"text\.txt, sensor 'text', column Acc_Y: line 17: 'abc' is not a number"):
        read_xsens_txt(text)
    cols = ("PacketCounter", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z")
    bare = write_xsens_txt(tmp_path / "bare.txt", acc, gyr, columns=cols, header=False)
    with pytest.raises(IMUImportError, match=r"bare\.txt, sensor 'bare', column PacketCounter: no SampleTimeFine column, so time "
                                             r"= PacketCounter / update rate, but no rate is known"):
        read_xsens_txt(bare)
    assert read_xsens_txt(bare, rate_hz=100.0).sample_rate_hz == pytest.approx(100.0)


@pytest.mark.parametrize("file_name, known, expected", [
    ("S01-Trial-Static-1-000_00B40B91.txt", (), "00B40B91"),
    ("MT_01200627_000-000_00B41234.txt", (), "00B41234"),
    ("walk_00b4abcd.csv", (), "00B4ABCD"),
    ("walk_00b4abcd.txt", ("00b4abcd",), "00b4abcd"),  # the map's spelling
    ("S01-Trial-000_00B40B91.txt", ("S01-Trial-000_00B40B91",), "S01-Trial-000_00B40B91"),  # a map keyed by file stem
    ("left_shank.txt", (), "left_shank"),
    ("trial_00B40B91_123456789.txt", (), "00B40B91"),  # a 9-character hex run is no device ID
])
def test_sensor_names_from_file_names(file_name, known, expected) -> None:
    assert xsens_sensor_name(Path(file_name), known) == expected


# ---------------------------------------------------------------------------------- OpenSense variants
def _write_sto(path: Path, time: np.ndarray, sensors: dict[str, np.ndarray]) -> None:
    """An OpenSim .sto of comma-separated vector cells, as OpenSim's IMU readers write them."""
    rows = ["\t".join([f"{t:.4f}"] + [",".join(f"{v:.8f}" for v in sensors[n][k]) for n in sensors]) for k, t in enumerate(time)]
    path.write_text("DataRate=100.000000\nDataType=Vec3\nversion=3\nOpenSimVersion=4.4\nendheader\n"
                    + "\t".join(["time", *sensors]) + "\n" + "\n".join(rows) + "\n")


def test_opensim_sto_tables_and_lower_case_names(tmp_path, rng) -> None:
    sensors = {f"{n}_imu": walking_like_3d(300, rng) for n in ("pelvis", "tibia_r")}
    time = np.arange(300) / 100.0
    _write_sto(tmp_path / "walk_linear_accelerations.sto", time, {n: v[0] for n, v in sensors.items()})
    _write_sto(tmp_path / "walk_angular_velocity.sto", time, {n: v[1] for n, v in sensors.items()})
    stream = read_imu_files([tmp_path / "walk_angular_velocity.sto"])
    assert stream.names == ["pelvis_imu", "tibia_r_imu"] and stream.sensors["pelvis_imu"].sample_rate_hz == pytest.approx(100.0)
    for name, (acc, gyr) in sensors.items():
        np.testing.assert_allclose(stream.sensors[name].acc, acc, atol=1e-7)
        np.testing.assert_allclose(stream.sensors[name].gyr, gyr, atol=1e-7)
    (tmp_path / "walk_angular_velocity.sto").unlink()
    with pytest.raises(IMUImportError, match=r"lacks walk_angular_velocity\.sto\[\.gz\] beside it"):
        read_imu_files([tmp_path / "walk_linear_accelerations.sto"])
    # the .trc export with lower-case suffixes and no DataRate in its header
    folder = tmp_path / "trc"
    folder.mkdir()
    write_opensense(folder, "Walk", sensors)
    for kind in ("Accel", "Gyro"):
        text = (folder / f"Walk_{kind}.trc").read_text().splitlines()
        text[2] = "\t".join(["x"] + text[2].split("\t")[1:])  # DataRate unreadable: from the Time column
        (folder / f"walk_{kind.lower()}.trc").write_text("\n".join(text) + "\n")
        (folder / f"Walk_{kind}.trc").unlink()
    stream = read_opensense(folder / "walk_accel.trc")
    assert stream.sensors["tibia_r_imu"].sample_rate_hz == pytest.approx(100.0)
    np.testing.assert_allclose(stream.sensors["tibia_r_imu"].gyr, sensors["tibia_r_imu"][1], atol=1e-7)


def test_copied_sensor_file_is_warned(tmp_path, rng) -> None:
    acc, gyr = walking_like_3d(200, rng)
    a = write_xsens_txt(tmp_path / "t_00B40001.txt", acc, gyr)
    b = tmp_path / "t_00B40002.txt"
    shutil.copy(a, b)
    (warning,) = read_xsens_files([a, b]).warnings
    assert "t_00B40001.txt and " in warning and "sensors '00B40001' and '00B40002' hold identical" in warning
