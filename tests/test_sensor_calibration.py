"""Sensor maps and the sagittal sensor calibration: random 3D mountings of synthetic sensors on a
predicted walking gait are recovered (axis, sign, in-plane angle), hints and errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.accuracy.inverse_dynamics import measured_stride
from sspinn.imu.calibration import SensorCalibrationError, calibrate
from sspinn.imu.sensor_map import SensorAssignment, SensorMap, SensorMapError
from sspinn.model.conventions import SEGMENTS
from sspinn.testing.sensor_mounting import (
    OutOfPlane,
    calibration_errors,
    embed_in_3d,
    mounting_trials,
    random_mounting,
    read_gait_csv,
    synthetic_walk,
)
from tests.conftest import shared_data

GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def gait():
    return read_gait_csv(GAIT)


def test_sensor_map_parsing_and_errors(tmp_path) -> None:
    smap = SensorMap.from_yaml(REPO / "configs" / "sensor_maps" / "cmu_treadmill.yaml")
    assert smap.segments == SEGMENTS and smap.ignore == ("torso_imu_offset_imu",)
    assert smap.assignments["femur_r_imu_offset_imu"].segment == "femur_r"  # thigh_r alias
    placement = smap.placement(1.75)
    assert placement.positions["foot_r"] == pytest.approx((0.14, -0.03))
    assert placement.positions["femur_r"] == pytest.approx((0.0, -0.285))
    hinted = SensorMap.from_dict({"sensors": {"a": {"segment": "shank_l", "right_axis": "-Z", "up_axis": [1, 0, 0],
                                                    "position_m": [0.01, -0.2]}}}, "m.yaml")
    a = hinted.assignments["a"]
    assert a.segment == "tibia_l" and np.allclose(a.right_axis, [0, 0, -1]) and a.position == (0.01, -0.2)
    bad = [
        ({"sensors": {"a": "knee_r"}}, r"m\.yaml: sensor 'a': unknown segment 'knee_r'"),
        ({"sensors": {"a": "femur_r", "b": "thigh_r"}}, r"sensors 'a' and 'b' both on segment 'femur_r'"),
        ({"sensors": {"a": {"segment": "femur_r", "side": "r"}}}, r"sensor 'a': unknown key\(s\) \['side'\]"),
        ({"sensors": {"a": {"segment": "femur_r", "right_axis": "+W"}}}, r"sensor 'a': right_axis must be"),
        ({"sensors": {"a": {"segment": "femur_r", "position": "forefoot"}}}, r"'forefoot' needs a foot segment"),
        ({"sensors": {"a": {"segment": "foot_r", "position_m": [14, 3]}}}, r"not cm"),
        ({"sensors": {}}, r"non-empty 'sensors:'"),
    ]
    for data, message in bad:
        with pytest.raises(SensorMapError, match=message):
            SensorMap.from_dict(data, "m.yaml")
    with pytest.raises(SensorMapError, match=r"sensor 'torso_imu_offset_imu' of files.csv is not in the map"):
        SensorMap.from_dict({"sensors": {"pelvis_imu_offset_imu": "pelvis"}}, "m.yaml").check_sensors(
            ["pelvis_imu_offset_imu", "torso_imu_offset_imu"], "files.csv")
    with pytest.raises(SensorMapError, match=r"sensor 'shoe' \(mapped to foot_r\) is not in files.csv"):
        SensorMap.from_dict({"sensors": {"shoe": "foot_r"}}, "m.yaml").check_sensors(["pelvis"], "files.csv")
    (tmp_path / "broken.yaml").write_text("sensors: [a\n")
    with pytest.raises(SensorMapError, match="not valid YAML"):
        SensorMap.from_yaml(tmp_path / "broken.yaml")


def test_random_mountings_are_recovered_with_standing(gait) -> None:
    """Five random mountings of all seven sensors (35 sensors) with out-of-plane motion, bias and
    noise: every sign right, axes within 3° (median < 1°), in-plane angles within 0.5° (standing calibrates them).
    The full distribution (50 mountings): benchmarks/accuracy/validate_sensor_calibration.py."""
    res = mounting_trials(gait.q, gait.u, gait.qdd, trials=5, seed=3, standing_s=2.0, strides=30)
    assert res["sign_ok"].all()
    assert np.median(res["axis"]) < 1.0 and res["axis"].max() < 3.0  # 30 strides; 50 (a CMU trial): max 2°
    assert np.abs(res["angle"]).max() < 0.5


def test_walking_only_calibration_keeps_signs_and_axes(gait) -> None:
    """Without standing the axes and signs come out as well. The in-plane angles then come from
    the walking (tests/test_joint_centres.py); this predicted gait's feet never rest flat, so the
    feet's angles are off by their pitch in mid-stance (about 16°)."""
    res = mounting_trials(gait.q, gait.u, gait.qdd, trials=3, seed=4, standing_s=0.0, strides=30)
    assert res["sign_ok"].all() and res["axis"].max() < 2.5
    feet = np.isin(res["segment"], ["foot_r", "foot_l"])
    assert np.abs(res["angle"][~feet]).max() < 2.5 and np.abs(res["angle"][feet]).max() < 20.0


def test_a_refinement_turns_the_calibrated_in_plane_angle(gait) -> None:
    """``refine``'s correction turns exactly the sensor it names, by exactly its angle, and it
    sees the calibrated sagittal signals of all seven sensors."""
    seen = []

    def refine(imu: np.ndarray) -> dict[str, float]:
        seen.append(imu.shape)
        return {"foot_r": np.radians(5.0)}

    kwargs = dict(trials=1, seed=4, standing_s=0.0, strides=10)
    plain = mounting_trials(gait.q, gait.u, gait.qdd, **kwargs)
    turned = mounting_trials(gait.q, gait.u, gait.qdd, refine=refine, **kwargs)
    assert seen == [(10 * len(gait.q), 7, 3)]
    foot = turned["segment"] == "foot_r"
    # the signals turn by +5°: the recovered y axis, measured from the true one, by −5° (the
    # recovered z is not exactly the true one, hence the tolerance)
    assert np.allclose(turned["angle"][foot] - plain["angle"][foot], -5.0, atol=1e-2)
    assert np.allclose(turned["angle"][~foot], plain["angle"][~foot]) and np.allclose(turned["axis"], plain["axis"])


def test_the_validation_script_fits_the_feet_to_an_estimate(tiny_run, capsys: pytest.CaptureFixture[str], torch_threads) -> None:
    """``--estimate MODEL`` adds the condition whose feet are fitted to MODEL's estimate (a tiny
    model: the mechanics, not the accuracy); bad paths are one-line errors."""
    import runpy

    script = runpy.run_path(str(REPO / "benchmarks" / "accuracy" / "validate_sensor_calibration.py"), run_name="validate_sensor_calibration")
    model = tiny_run[4] / "model.pt"
    assert script["main"](["--trials", "1", "--strides", "5", "--estimate", str(model)]) == 0
    out = capsys.readouterr().out
    table = out.split("feet fitted to the estimate")[1]
    assert "| foot_r |" in table and "| foot_l |" in table
    for argv, message in ((["--estimate-data", str(REPO)], "--estimate-data needs --estimate MODEL"),
                          (["--estimate", str(REPO / "no_model.pt")], "no_model.pt: no such model file")):
        with pytest.raises(SystemExit):
            script["main"](argv)
        assert message in capsys.readouterr().err


def _signals(gait, seed: int, mounting=None):
    rng = np.random.default_rng(seed)
    imu2d = synthetic_walk(gait.q, gait.u, gait.qdd, strides=20, standing_s=2.0)
    mountings = {s: (mounting if mounting is not None else random_mounting(rng)) for s in SEGMENTS}
    signals = {s: embed_in_3d(imu2d[:, i], mountings[s], rng, OutOfPlane(), still=200) for i, s in enumerate(SEGMENTS)}
    return imu2d, mountings, signals


def test_projection_reproduces_the_sagittal_signals(gait) -> None:
    imu2d, mountings, signals = _signals(gait, 5)
    cal = calibrate(signals, {s: SensorAssignment(f"s_{s}", s) for s in SEGMENTS})
    assert cal.standing is not None and abs(cal.stride_period_s - len(gait.q) / 100) < 0.02
    for i, s in enumerate(SEGMENTS):
        projected = cal.sensors[s].project(*signals[s])
        rms = np.sqrt(np.mean((projected - imu2d[:, i]) ** 2, axis=0))
        assert rms[2] < 0.1 and rms[:2].max() < 1.0, (s, rms)  # out-of-plane motion and noise remain
        assert cal.sensors[s].sign_margin > 0.5


def test_hints_fix_the_sign_and_catch_an_upside_down_sensor(gait) -> None:
    _, mountings, signals = _signals(gait, 6, mounting=np.eye(3))
    wrong = {s: SensorAssignment(f"s_{s}", s, right_axis=np.array([0.0, 0.0, -1.0])) for s in SEGMENTS}
    cal = calibrate(signals, wrong)
    for s in SEGMENTS:
        assert calibration_errors(cal.sensors[s].rotation, mountings[s])[0] > 170  # the hint wins...
        assert "DISAGREE" in cal.sensors[s].sign_method  # ...and the report says the gait disagrees
    upside = {s: SensorAssignment(f"s_{s}", s, up_axis=np.array([0.0, 1.0, 0.0])) for s in SEGMENTS}
    calibrate(signals, upside)  # +Y is up the segment: fine
    upside["tibia_l"] = SensorAssignment("s_tibia_l", "tibia_l", up_axis=np.array([0.0, -1.0, 0.0]))
    with pytest.raises(SensorCalibrationError, match=r"sensor 's_tibia_l' \(tibia_l\): mounted upside down"):
        calibrate(signals, upside, source="x.txt")


def test_no_walking_is_an_error() -> None:
    rng = np.random.default_rng(0)
    still = {"femur_r": (np.tile([0.0, 9.81, 0.0], (1000, 1)) + rng.normal(scale=0.01, size=(1000, 3)),
                         rng.normal(scale=0.01, size=(1000, 3)))}
    with pytest.raises(SensorCalibrationError, match=r"x\.txt: 0\.0 s of walking found"):
        calibrate(still, {"femur_r": SensorAssignment("a", "femur_r")}, source="x.txt")


def test_an_accelerometer_gain_error_is_corrected_from_standing(gait) -> None:
    """A foot sensor reading 1.24 g at rest (as the CMU left forefoot sensor does): the gain is
    corrected from quiet standing, noted, and the projection matches the error-free one."""
    _, _, signals = _signals(gait, 5)
    assignments = {s: SensorAssignment(f"s_{s}", s) for s in SEGMENTS}
    clean = calibrate(signals, assignments)
    acc, gyr = signals["foot_l"]
    faulty = calibrate({**signals, "foot_l": (1.24 * acc, gyr)}, assignments)
    assert faulty.sensors["foot_l"].acc_gain == pytest.approx(1 / 1.24, rel=0.01)
    assert clean.sensors["foot_l"].acc_gain == 1.0 and clean.sensors["foot_r"].acc_gain == 1.0
    assert any("s_foot_l" in n and "scaled by" in n for n in faulty.warnings) and not clean.warnings
    np.testing.assert_allclose(faulty.sensors["foot_l"].project(1.24 * acc, gyr), clean.sensors["foot_l"].project(acc, gyr),
                               atol=0.05 * 9.81)


def test_a_measured_stride_gives_thighs_shanks_and_a_resting_foot_within_2_degrees_without_standing() -> None:
    """Real kinematics (OpenSim's subject01 walk) made one periodic stride: the walking-only
    in-plane angles of thighs and shanks from the joint centres are within 2°, and the feet, which
    rest in mid-stance in real walking, come out at the angle they rest at (the right one within
    2°), unlike on the predicted gait whose feet never rest flat."""
    gait = measured_stride(shared_data("opensim_subject01_walk"))
    assert 90 <= len(gait.q) <= 140 and np.isfinite(gait.qdd).all()
    closed = gait.q[-1, 1:] + gait.u[-1, 1:] / 100 - gait.q[0, 1:]  # one more sample closes the loop
    assert np.abs(closed).max() < 0.02
    res = mounting_trials(gait.q, gait.u, gait.qdd, trials=3, seed=0, standing_s=0.0, strides=30)
    legs = np.isin(res["segment"], ["femur_r", "femur_l", "tibia_r", "tibia_l", "foot_r"])
    assert np.abs(res["angle"][legs]).max() < 2.0 and res["sign_ok"].all()
