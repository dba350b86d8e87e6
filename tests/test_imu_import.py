"""``sspinn import``: synthetic Xsens files with random mountings end to end, one-line errors, and
a 10 s excerpt of a real CMU trial (with GRF) that ``Dataset``, ``open_recordings`` and
``sspinn infer`` read unchanged; bad files (a wrong sensor map, a missing sensor, a
gap, a sensor mounted upside down, a constant axis), synthetic and edited copies of the real CMU
OpenSense files, give one-line errors or warnings naming file and sensor."""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from sspinn.cli import main
from sspinn.data.dataset import Dataset, Recording
from sspinn.data.loading import open_recordings
from sspinn.imu import pipeline as imu_import
from sspinn.model.conventions import SEGMENTS
from sspinn.testing import (
    OpenSenseEdit,
    OpenSenseSensors,
    axis_constant,
    read_opensense_raw,
    rows_deleted,
    sensor_map_edited,
    sensor_map_with_pelvis,
    sensor_removed,
    sensor_turned,
    walking_like_3d,
    write_opensense,
    write_xsens_txt,
)
from sspinn.testing.sensor_mounting import OutOfPlane, embed_in_3d, random_mounting, read_gait_csv, synthetic_walk
from tests.conftest import shared_data

GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"
REPO = Path(__file__).resolve().parents[1]
IDS = {s: f"00B4{i:04X}" for i, s in enumerate(SEGMENTS)}
CMU_MAP = REPO / "configs" / "sensor_maps" / "cmu_treadmill.yaml"
CMU_STEM = "OpenSim_Sub01_CSBaseline"
#: A lab protocol (sensor-from-segment rotations): every sensor's X axis up its segment, Z out of
#: the skin (lateral on the legs, backwards on the pelvis).
PROTOCOL = {"pelvis": [[0, 1, 0], [0, 0, -1], [-1, 0, 0]], "r": [[0, 1, 0], [-1, 0, 0], [0, 0, 1]], "l": [[0, 1, 0], [1, 0, 0], [0, 0, -1]]}


def _xsens_files(folder: Path, signals: dict[str, tuple[np.ndarray, np.ndarray]]) -> list[Path]:
    """One MT Manager file per segment's (acc, gyr), named by :data:`IDS`."""
    return [write_xsens_txt(folder / f"MT_01200627_000-000_{IDS[s]}.txt", *signals[s], counter0=100 * i) for i, s in enumerate(SEGMENTS)]


def _xsens_signals(truth: np.ndarray, mountings: dict[str, np.ndarray],
                   rng: np.random.Generator) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    return {s: embed_in_3d(truth[:, i], mountings[s], rng, OutOfPlane(), still=200) for i, s in enumerate(SEGMENTS)}


@pytest.fixture(scope="module")
def xsens_truth() -> np.ndarray:
    """The 2D truth of the synthetic trials: a predicted gait, 2 s standing + 20 strides."""
    gait = read_gait_csv(GAIT)
    return synthetic_walk(gait.q, gait.u, gait.qdd, strides=20, standing_s=2.0)


@pytest.fixture(scope="module")
def xsens_trial(tmp_path_factory, xsens_truth):
    """Seven MT Manager files (random mountings on a predicted gait, 2 s standing + 20 strides),
    an eighth unused sensor, a sensor map; returns (folder, files, map path, 2D truth, mountings)."""
    folder = tmp_path_factory.mktemp("xsens")
    rng = np.random.default_rng(11)
    mountings = {s: random_mounting(rng) for s in SEGMENTS}
    files = _xsens_files(folder, _xsens_signals(xsens_truth, mountings, rng))
    files.append(write_xsens_txt(folder / "MT_01200627_000-000_00B4FFFF.txt", *walking_like_3d(len(xsens_truth), rng)))
    smap = folder / "map.yaml"
    smap.write_text(yaml.safe_dump({"sensors": _xsens_map(), "ignore": ["00B4FFFF"]}))
    return folder, files, smap, xsens_truth, mountings


def _xsens_map(**segments: str) -> dict:
    """The synthetic trials' sensor map (sensor ID → segment); ``segments`` overrides segment → mapped segment."""
    names = {"pelvis": "pelvis", "femur_r": "thigh_r", "tibia_r": "shank_r", "femur_l": "thigh_l", "tibia_l": "shank_l"}
    entry = {s: names.get(s, {"segment": s, "position": "forefoot"}) for s in SEGMENTS}
    return {IDS[s]: entry[segments.get(s, s)] for s in SEGMENTS}


@pytest.fixture(scope="module")
def protocol_signals(xsens_truth) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The synthetic gait with every sensor mounted by :data:`PROTOCOL`: segment → (acc, gyr)."""
    mountings = {s: np.array(PROTOCOL[s if s == "pelvis" else s[-1]], dtype=float) for s in SEGMENTS}
    return _xsens_signals(xsens_truth, mountings, np.random.default_rng(5))


@pytest.fixture()
def no_figure(monkeypatch) -> None:
    """Skip the calibration figure (most of an import's time; tested elsewhere)."""
    monkeypatch.setattr(imu_import, "plot_calibration", lambda path, *args, **kwargs: Path(path))


def _import(files, smap, out, *extra) -> list[str]:
    return ["import", "--imu", *map(str, files), "--sensor-map", str(smap), "--height", "1.75", "--mass", "70",
            "--out", str(out), *extra]


def _one_line_error(status: int, err: str, message: str) -> None:
    """A user error: exit status 2 and one line ``sspinn: error: ...`` matching ``message``."""
    assert status == 2 and len(err.strip().splitlines()) == 1, err
    assert err.startswith("sspinn: error: ") and re.search(message, err), err


#: Start of the warning every CMU import prints: the left forefoot sensor reads 1.24 g standing (a fault of the data).
CMU_GAIN_WARNING = "sensor 'toes_l_imu_offset_imu' (foot_"  # + side: the map may swap sides


def _warnings(printed: str) -> list[str]:
    """The WARNING lines of an import, less the CMU left forefoot gain warning (asserted apart)."""
    return [line.strip() for line in printed.splitlines()
            if line.strip().startswith("WARNING:") and not (CMU_GAIN_WARNING in line and "|specific force|" in line)]


@pytest.mark.slow
def test_xsens_import_recovers_the_sagittal_signals(xsens_trial, tmp_path, capsys) -> None:
    folder, files, smap, truth, _ = xsens_trial
    out = tmp_path / "imported"
    assert main(_import(files, smap, out, "--subject", "s1", "--name", "walk", "--speed", "1.3")) == 0
    printed = capsys.readouterr().out
    assert "walk: 2480 samples" in printed and "calibration report" in printed
    rec = Recording.load(out / "walk.csv")
    assert rec.segments == SEGMENTS and rec.subject == "s1" and rec.n_samples == len(truth)
    assert rec.placement.positions["foot_r"] == pytest.approx((0.14, -0.03))
    rms = np.sqrt(np.mean((rec.imu - truth) ** 2, axis=0))  # (7, 3): out-of-plane motion and noise remain
    assert rms[:, 2].max() < 0.1 and rms[:, :2].max() < 1.0
    np.testing.assert_allclose(rec.labels.speed, 1.3)
    assert set(rec.provenance["calibration"]) == set(SEGMENTS) and rec.provenance["standing_s"] is not None
    index = json.loads((out / "dataset.json").read_text())
    assert index["splits"] == {"train": ["walk"], "val": ["walk"], "test": ["walk"]}
    for split in ("train", "test"):
        (again,) = open_recordings(out, split)
        np.testing.assert_allclose(again.imu, rec.imu)
    report = (out / "walk_calibration.md").read_text()
    assert "| 00B40003 | foot_r |" in report and (out / "walk_calibration.png").stat().st_size > 10_000
    # a second subject into the same folder, test split only
    assert main(_import(files, smap, out, "--subject", "s2", "--name", "walk2", "--split", "test")) == 0
    assert Dataset.open(out).splits == {"train": ["walk"], "val": ["walk"], "test": ["walk", "walk2"]}


def test_import_errors_are_one_line(xsens_trial, tmp_path, capsys) -> None:
    folder, files, smap, _, mountings = xsens_trial
    data = yaml.safe_load(smap.read_text())
    cases = []
    missing = dict(data, sensors={**data["sensors"], "00B4AAAA": "pelvis"})
    missing["sensors"].pop(IDS["pelvis"])
    cases.append((missing, [], r"sensor '00B4AAAA' \(mapped to pelvis\) is not in"))
    cases.append(({"sensors": data["sensors"]}, [], r"sensor '00B4FFFF' of .* is not in the map"))
    down = (-mountings["tibia_l"][:, 1]).tolist()  # the sensor-frame direction pointing down the shank
    upside = dict(data, sensors={**data["sensors"], IDS["tibia_l"]: {"segment": "tibia_l", "up_axis": down}})
    cases.append((upside, [], rf"sensor '{IDS['tibia_l']}' \(tibia_l\): mounted upside down"))
    cases.append((data, ["--end", "3"], r"s of walking found"))
    for k, (content, extra, message) in enumerate(cases):
        path = tmp_path / f"map{k}.yaml"
        path.write_text(yaml.safe_dump(content))
        status = main(_import(files, path, tmp_path / f"out{k}", *extra))
        _one_line_error(status, capsys.readouterr().err, message)
    # a gap: drop 20 packets (0.2 s) from one sensor
    text = files[3].read_text().splitlines()
    gap_file = tmp_path / files[3].name
    gap_file.write_text("\n".join(text[:506] + text[526:]) + "\n")
    status = main(_import([*files[:3], gap_file, *files[4:]], smap, tmp_path / "gap"))
    err = capsys.readouterr().err
    assert status == 2 and f"sensor '{IDS['foot_r']}': 20 sample(s) missing" in err and "cannot be bridged" in err


@pytest.mark.slow
def test_cmu_excerpt_imports_and_is_read_unchanged(tmp_path, tiny_run, capsys) -> None:
    folder = shared_data("cmu_treadmill_imu_grf") / "Sub01" / "CSBaseline"
    out = tmp_path / "cmu"
    args = ["import", "--imu", str(folder / "OpenSim_Sub01_CSBaseline_Accel.trc.gz"),
            "--sensor-map", str(REPO / "configs" / "sensor_maps" / "cmu_treadmill.yaml"),
            "--height", "1.81", "--mass", "66.7", "--subject", "Sub01", "--speed", "0.7692", "--end", "10",
            "--grf", str(folder / "OpenSim_Sub01_CSBaseline_GRF.mot.gz"), "--out", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "GRF: lag" in printed
    # the left forefoot sensor reads 12.1 m/s² standing: its gain is corrected, and said
    assert f"WARNING: {CMU_GAIN_WARNING}l): |specific force| 12.1" in printed and "scaled by 0.8" in printed
    (rec,) = Dataset.open(out).load("train")
    assert rec.provenance["calibration"]["foot_l"]["acc_gain"] == pytest.approx(9.81 / 12.13, abs=0.01)
    assert rec.name == "OpenSim_Sub01_CSBaseline" and rec.segments == SEGMENTS and 990 <= rec.n_samples <= 1000
    assert np.isfinite(rec.imu).all() and rec.labels.grf is not None and np.isfinite(rec.labels.grf).all()
    weight = 66.7 * 9.81
    assert 0.8 < np.mean(rec.labels.grf[:, 1] + rec.labels.grf[:, 3]) / weight < 1.2
    lag = rec.provenance["grf_alignment"]["lag_s"]
    assert abs(lag) < 0.15 and rec.provenance["grf_alignment"]["convention"] == "t_reference = t_imu + lag_s"
    assert (out / "OpenSim_Sub01_CSBaseline_calibration.md").exists()
    (again,) = open_recordings(out, "test")
    np.testing.assert_allclose(again.imu, rec.imu)
    _, _, _, _, run = tiny_run
    assert main(["infer", "--model", str(run / "model.pt"), "--data", str(out), "--out", str(tmp_path / "inf")]) == 0
    assert (tmp_path / "inf" / "OpenSim_Sub01_CSBaseline_estimate.csv").exists()


# ---------------------------------------------------------------------------------- bad files
def test_xsens_missing_file_dead_gyro_axis_and_short_gap(xsens_trial, tmp_path, capsys, no_figure) -> None:
    folder, files, smap, _, _ = xsens_trial
    status = main(_import([*files[:6], files[7]], smap, tmp_path / "missing"))  # foot_l's file left out
    _one_line_error(status, capsys.readouterr().err,
                    rf"map\.yaml: sensor '{IDS['foot_l']}' \(mapped to foot_l\) is not in .*remove it from the map")
    shank = imu_import.read_imu_files([files[2]]).sensors[IDS["tibia_r"]]
    gyr = shank.gyr.copy()
    gyr[:, 1] = 0.0  # a dead gyroscope axis
    dead = write_xsens_txt(tmp_path / files[2].name, shank.acc, gyr, counter0=200)
    status = main(_import([*files[:2], dead, *files[3:]], smap, tmp_path / "dead"))
    _one_line_error(status, capsys.readouterr().err,
                    rf"{re.escape(str(dead))}, sensor '{IDS['tibia_r']}': gyr axis Y is constant \(0 rad/s\)")
    text = files[3].read_text().splitlines()  # drop 3 packets (0.03 s) from one sensor: bridged
    short = tmp_path / files[3].name
    short.write_text("\n".join(text[:506] + text[509:]) + "\n")
    assert main(_import([*files[:3], short, *files[4:]], smap, tmp_path / "short", "--name", "walk")) == 0
    assert "1 gap(s) interpolated (listed in the report)" in capsys.readouterr().out
    (gap,) = Recording.load(tmp_path / "short" / "walk.csv").provenance["gaps"]
    assert f"{short}, sensor '{IDS['foot_r']}': 3 sample(s) missing after t = 4.990 s" in gap
    assert "gap interpolated" in (tmp_path / "short" / "walk_calibration.md").read_text()


def test_xsens_upside_down_sensor_without_hint_is_calibrated_and_reported(protocol_signals, tmp_path, capsys, no_figure) -> None:
    smap = tmp_path / "map.yaml"
    smap.write_text(yaml.safe_dump({"sensors": _xsens_map()}))
    acc, gyr = protocol_signals["tibia_l"]
    flip = np.array([-1.0, -1.0, 1.0])  # turned 180° about its medio-lateral axis Z: its X axis points down the shank
    results = []
    for name, signals in (("as_mounted", protocol_signals), ("upside_down", {**protocol_signals, "tibia_l": (acc * flip, gyr * flip)})):
        (tmp_path / name).mkdir()
        assert main(_import(_xsens_files(tmp_path / name, signals), smap, tmp_path / name / "out", "--name", "walk")) == 0
        results.append((Recording.load(tmp_path / name / "out" / "walk.csv"), _warnings(capsys.readouterr().out)))
    (good, none), (turned, warned) = results
    assert none == [] and good.provenance["warnings"] == []
    sensor = IDS["tibia_l"]
    assert len(warned) == 1 and re.fullmatch(
        rf"WARNING: \S+_{sensor}\.txt, sensor '{sensor}' \(tibia_l\): appears mounted upside down: its -X axis points up the "
        r"segment, but \+X does on 6 other sensors \(pelvis, femur_r, tibia_r, foot_r, femur_l, foot_l\); calibrated "
        r"accordingly .*", warned[0]), warned
    np.testing.assert_allclose(turned.imu, good.imu, atol=1e-5)  # the same projected signals
    assert turned.provenance["warnings"] == [warned[0].removeprefix("WARNING: ")]
    assert "## Warnings" in (tmp_path / "upside_down" / "out" / "walk_calibration.md").read_text()


def test_xsens_thighs_swapped_in_the_map_are_reported(xsens_trial, tmp_path, capsys, no_figure) -> None:
    _, files, _, _, _ = xsens_trial
    smap = tmp_path / "swapped.yaml"
    smap.write_text(yaml.safe_dump({"sensors": _xsens_map(femur_r="femur_l", femur_l="femur_r"), "ignore": ["00B4FFFF"]}))
    assert main(_import(files, smap, tmp_path / "out")) == 0
    warned = [w for w in _warnings(capsys.readouterr().out) if "like one leg" in w]  # the random mountings differ too
    assert len(warned) == 2, warned
    for (side, thigh), text in zip((("right", "femur_l"), ("left", "femur_r")), warned):
        other = {"femur_l": "r", "femur_r": "l"}[thigh]
        assert re.search(rf"the {side}-leg sensors do not move like one leg .*'{IDS[thigh]}' \(femur_{other}\) leads "
                         rf"'{IDS['tibia_' + other]}' \(tibia_{other}\) by", text), text


def test_xsens_files_as_mt_manager_writes_them(xsens_trial, tmp_path, no_figure) -> None:
    """The synthetic trial rewritten as the real MT Manager exports are (``<trial>-000_<ID>.txt``,
    comma-separated, SampleTimeFine blank, one packet counter shared by all sensors, two files
    without the '//' header, the pelvis keyed by its file stem in the map) imports to the same
    recording as the tick-timed files."""
    _, files, smap, _, _ = xsens_trial
    stream = imu_import.read_imu_files(files[:7])
    (tmp_path / "real").mkdir()
    rewritten = [write_xsens_txt(tmp_path / "real" / f"S01-Walk-1-000_{name}.txt", s.acc, s.gyr, sep=",", time_format="blank",
                                 counter0=19741, header=k not in (2, 5)) for k, (name, s) in enumerate(stream.sensors.items())]
    pelvis_stem = rewritten[0].stem
    data = yaml.safe_load(smap.read_text())
    data["sensors"] = {(pelvis_stem if k == IDS["pelvis"] else k): v for k, v in data["sensors"].items()}
    data["ignore"] = []
    real_map = _write_map(tmp_path / "real_map.yaml", data)
    tick_map = _write_map(tmp_path / "tick_map.yaml", {"sensors": yaml.safe_load(smap.read_text())["sensors"]})
    assert main(_import(files[:7], tick_map, tmp_path / "ticks", "--name", "w")) == 0
    assert main(_import(rewritten, real_map, tmp_path / "blank", "--name", "w")) == 0
    ticks, blank = Recording.load(tmp_path / "ticks" / "w.csv"), Recording.load(tmp_path / "blank" / "w.csv")
    assert len(blank.provenance["warnings"]) == len(ticks.provenance["warnings"])  # the random mountings' upside-down warnings
    assert blank.n_samples == ticks.n_samples
    np.testing.assert_allclose(blank.imu, ticks.imu, atol=1e-4)
    notes = " ".join(blank.provenance["notes"])
    assert f"sensor '{pelvis_stem}' (the file stem (named in the sensor map))" in notes
    assert notes.count("SampleTimeFine blank in every row: time = PacketCounter") == 7 and notes.count("the other files' header") == 2


def _skip_figure(path: str | Path, *args: object, **kwargs: object) -> Path:
    return Path(path)


@pytest.fixture(scope="module")
def cmu_raw() -> tuple[np.ndarray, OpenSenseSensors]:
    """The first 12 s of the real Sub01 CSBaseline OpenSense export: (time, sensors)."""
    folder = shared_data("cmu_treadmill_imu_grf") / "Sub01" / "CSBaseline"
    return read_opensense_raw(folder / f"{CMU_STEM}_Accel.trc.gz", end_s=12.0)


def _cmu_import(raw: tuple[np.ndarray, OpenSenseSensors], folder: Path, edit: OpenSenseEdit | None = None,
                smap: Path = CMU_MAP) -> tuple[int, str, str]:
    """Write a copy of the CMU excerpt (edited) into ``folder`` and import its first 10 s into
    ``folder/out`` (no figure): (exit status, stdout, stderr)."""
    folder.mkdir()
    time, sensors = edit(*raw) if edit else raw
    accel = write_opensense(folder, CMU_STEM, sensors, time=time)
    out, err = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as patch, contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        patch.setattr(imu_import, "plot_calibration", _skip_figure)
        status = main(["import", "--imu", str(accel), "--sensor-map", str(smap), "--height", "1.81", "--mass", "66.7",
                       "--end", "10", "--out", str(folder / "out")])
    return status, out.getvalue(), err.getvalue()


def _write_map(path: Path, data: dict) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def cmu_as_recorded(cmu_raw, tmp_path_factory) -> tuple[Recording, str]:
    """The unedited CMU excerpt imported: (recording, stdout)."""
    folder = tmp_path_factory.mktemp("cmu") / "as_recorded"
    status, out, err = _cmu_import(cmu_raw, folder)
    assert status == 0, err
    return Recording.load(folder / "out" / f"{CMU_STEM}.csv"), out


CMU_FILES = rf"{CMU_STEM}_Accel\.trc \+ {CMU_STEM}_Gyro\.trc"


@pytest.mark.parametrize("edit, smap, message", [
    (sensor_removed("tibia_l_imu_offset_imu"), None,
     rf"cmu_treadmill\.yaml: sensor 'tibia_l_imu_offset_imu' \(mapped to tibia_l\) is not in \S+{CMU_FILES}; the files have "
     r"\['torso_imu_offset_imu', .*remove it from the map to import without a tibia_l IMU"),
    (rows_deleted(5.0, 0.2), None,
     rf"{CMU_FILES}, sensor 'pelvis_imu_offset_imu': 20 sample\(s\) missing after t = 4\.990 s \(0\.210 s between samples; "
     r"found from the time stamps\) \(the same gap in 6 other sensor\(s\)\): a gap longer than 0\.05 s cannot be bridged"),
    (axis_constant("tibia_l_imu_offset_imu", 0, 1), None,
     rf"{CMU_FILES}, sensor 'tibia_l_imu_offset_imu': acc axis Y is constant \(0 m/s²\) over all 1000 samples"),
    (axis_constant("femur_r_imu_offset_imu", 1, 2), None,
     rf"{CMU_FILES}, sensor 'femur_r_imu_offset_imu': gyr axis Z is constant \(0 rad/s\) over all 1000 samples"),
    (None, sensor_map_edited(CMU_MAP, femur_r_imu_offset_imu="upperleg_r"),
     r"map\.yaml: sensor 'femur_r_imu_offset_imu': unknown segment 'upperleg_r'"),
    (None, {"sensors": {f"{s}_imu": s for s in SEGMENTS}},
     rf"map\.yaml: sensor 'pelvis_imu' \(mapped to pelvis\) is not in \S+{CMU_FILES}"),
], ids=["sensor column removed", "gap of 0.2 s", "dead accelerometer axis", "dead gyroscope axis", "unknown segment",
        "map of another export"])
def test_cmu_bad_files_are_one_line_errors(cmu_raw, tmp_path, edit, smap, message) -> None:
    path = CMU_MAP if smap is None else _write_map(tmp_path / "map.yaml", smap)
    status, _, err = _cmu_import(cmu_raw, tmp_path / "copy", edit, path)
    _one_line_error(status, err, message)


def test_cmu_short_gap_is_interpolated_and_listed(cmu_raw, cmu_as_recorded, tmp_path) -> None:
    status, out, err = _cmu_import(cmu_raw, tmp_path / "gap", rows_deleted(5.0, 0.03))
    assert status == 0 and "7 gap(s) interpolated (listed in the report)" in out, err
    rec = Recording.load(tmp_path / "gap" / "out" / f"{CMU_STEM}.csv")
    gaps = rec.provenance["gaps"]
    assert len(gaps) == 7 and all(re.search(rf"{CMU_FILES}, sensor '\w+': 3 sample\(s\) missing after t = 4\.990 s", g) for g in gaps)
    assert any("'tibia_l_imu_offset_imu'" in g for g in gaps)
    assert np.sqrt(np.mean((rec.imu - cmu_as_recorded[0].imu) ** 2)) < 0.05  # bridged, calibrated as before


@pytest.mark.parametrize("axis, reported", [(2, True), (0, False)], ids=["about its medio-lateral axis", "about its long axis"])
def test_cmu_sensor_turned_over_is_calibrated_alike(cmu_raw, cmu_as_recorded, tmp_path, axis, reported) -> None:
    """tibia_l turned 180° about its Z axis (medio-lateral: upside down, its X axis points down
    the shank) or its X axis (long: facing the skin) gives the same projected signals; only upside
    down is reported (the other sensors have +X up)."""
    status, out, err = _cmu_import(cmu_raw, tmp_path / "turned", sensor_turned("tibia_l_imu_offset_imu", axis))
    assert status == 0, err
    rec = Recording.load(tmp_path / "turned" / "out" / f"{CMU_STEM}.csv")
    np.testing.assert_allclose(rec.imu, cmu_as_recorded[0].imu, atol=1e-6)
    assert _warnings(cmu_as_recorded[1]) == []
    warned = _warnings(out)
    assert len(warned) == reported, warned
    if reported:
        assert re.search(rf"{CMU_FILES}, sensor 'tibia_l_imu_offset_imu' \(tibia_l\): appears mounted upside down: its -X axis "
                         r"points up the segment, but \+X does on 4 other sensors \(pelvis, femur_r, tibia_r, femur_l\)", warned[0])


@pytest.mark.parametrize("swap, expected", [
    (("femur_r_imu_offset_imu", "femur_l_imu_offset_imu"),
     [r"the right-leg sensors do not move like one leg .*'femur_l_imu_offset_imu' \(femur_r\) leads 'tibia_r_imu_offset_imu'",
      r"the left-leg sensors do not move like one leg .*'femur_r_imu_offset_imu' \(femur_l\) leads 'tibia_l_imu_offset_imu'"]),
    (tuple(f"{k}_{s}_imu_offset_imu" for k in ("femur", "tibia", "toes") for s in "rl"),
     [r"right and left look swapped in the sensor map .*'pelvis_imu_offset_imu' \(pelvis\) is pushed to the right while "
      r"'toes_l_imu_offset_imu' \(foot_r\) is in stance .*\(correlation \+0\.\d\d"]),
], ids=["thighs", "all leg sensors"])
def test_cmu_sides_swapped_in_the_map_are_reported(cmu_raw, cmu_as_recorded, tmp_path, swap, expected) -> None:
    rec, printed = cmu_as_recorded
    assert _warnings(printed) == [] and re.search(r"side check: .* correlates -0\.[5-9]", " ".join(rec.provenance["notes"]))
    status, out, err = _cmu_import(cmu_raw, tmp_path / "copy", smap=_write_map(tmp_path / "map.yaml", sensor_map_edited(CMU_MAP, swap)))
    assert status == 0, err
    warned = _warnings(out)
    assert len(warned) == len(expected) and all(re.search(rf"{CMU_FILES}: {e}", w) for e, w in zip(expected, warned)), warned


def test_the_torso_sensor_mapped_as_the_pelvis_is_reported(tmp_path, no_figure) -> None:
    """The pelvis sensor fits the hip joints better than the torso sensor: on 30 s of a real trial
    the map with the two swapped warns, naming both, and the right map does not."""
    accel = shared_data("cmu_treadmill_imu_grf") / "Sub01" / "CSBaseline" / f"{CMU_STEM}_Accel.trc.gz"
    found = {}
    for name, smap in (("right", CMU_MAP), ("swapped", _write_map(tmp_path / "map.yaml", sensor_map_with_pelvis(CMU_MAP, "torso_imu_offset_imu")))):
        with contextlib.redirect_stdout(io.StringIO()):
            cal = imu_import.import_imu([accel], smap, 1.81, 66.7, tmp_path / name, end_s=30.0).calibration
        found[name] = [w for w in cal.warnings if "fits the hip joints better" in w]
    assert found["right"] == []
    assert len(found["swapped"]) == 1
    assert "ignored sensor 'pelvis_imu_offset_imu'" in found["swapped"][0] and "'torso_imu_offset_imu' (pelvis)" in found["swapped"][0]


def test_a_short_import_does_not_compare_the_pelvis_candidates(cmu_raw, tmp_path) -> None:
    """10 s are too short to judge (the comparison scatters by 10 %): the swapped map imports
    without the warning."""
    status, _, err = _cmu_import(cmu_raw, tmp_path / "short", smap=_write_map(tmp_path / "map.yaml", sensor_map_with_pelvis(CMU_MAP, "torso_imu_offset_imu")))
    assert status == 0 and "fits the hip joints better" not in err
