"""In-plane sensor angles from walking alone (sspinn.imu.joint_centres): joint centres fitted to
pairs of exact rigid-body sensors, and the foot's mid-stance rests."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from sspinn.imu.joint_centres import foot_flat_up, joint_centre, plane_signals, segment_axis, sensor_placement
from sspinn.model.body import WINTER, BodyParameters, IMUPlacement
from sspinn.model.conventions import SEGMENTS
from sspinn.testing.sensor_mounting import mounting_trials, read_gait_csv, synthetic_walk

GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"
E = np.eye(3)


@pytest.fixture(scope="module")
def gait():
    return read_gait_csv(GAIT)


@pytest.fixture(scope="module")
def planes(gait):
    """Every sensor's plane signals in its segment frame (sensor at the typical place, angle 0)."""
    imu = synthetic_walk(gait.q, gait.u, gait.qdd, strides=10, standing_s=0.0)
    out = {}
    for k, seg in enumerate(SEGMENTS):
        acc = np.column_stack((imu[:, k, 0], imu[:, k, 1], np.zeros(len(imu))))
        gyr = np.column_stack((np.zeros((len(imu), 2)), imu[:, k, 2]))
        out[seg] = plane_signals(acc, gyr, E[0], E[1], E[2], 100.0)
    return out


def test_the_knee_and_ankle_centres_are_found_on_exact_sensors(planes) -> None:
    body = BodyParameters.from_anthropometry(1.75, 70.0)
    place = IMUPlacement.default(body.height).positions
    femur, tibia = WINTER["femur"][1] * body.height, WINTER["tibia"][1] * body.height
    knee = joint_centre(planes["femur_r"], planes["tibia_r"], np.array([0.0, -0.1]), np.array([0.0, 0.2]))
    # within 2 cm (m): ω̇ is differentiated from the low-passed rate, as it must be from real gyroscopes
    np.testing.assert_allclose(knee.r_a, [0.0, -femur - place["femur_r"][1]], atol=0.02)
    np.testing.assert_allclose(knee.r_b, [0.0, -place["tibia_r"][1]], atol=0.02)
    ankle = joint_centre(planes["tibia_r"], planes["foot_r"], np.array([0.0, -0.2]), np.array([-0.1, 0.0]))
    np.testing.assert_allclose(ankle.r_a, [0.0, -tibia - place["tibia_r"][1]], atol=0.02)
    np.testing.assert_allclose(ankle.r_b, [-place["foot_r"][0], 0.0], atol=0.02)
    axis = segment_axis(knee, ankle, "b", "a")
    assert abs(np.degrees(np.arctan2(-axis[0], axis[1]))) < 1.5  # the shank's y axis
    assert segment_axis(None, ankle, "b", "a") is None
    assert segment_axis(knee, dataclasses.replace(ankle, r_a=ankle.r_a + [0.0, -1.0]), "b", "a") is None  # a 1.4 m shank: implausible


def test_the_foot_rests_give_gravity_in_the_foot_frame() -> None:
    """A foot sensor mounted pitched by 20°: 0.3-s rests (flat foot, 1.25 × g: a gain error) between
    swings whose turning points are brief; gravity's direction is found from the rests alone."""
    rate, pitch = 100.0, np.radians(20.0)
    t = np.arange(1200) / rate
    omega = np.where((t % 1.0) < 0.3, 0.0, 6.0 * np.sin(2 * np.pi * ((t % 1.0) - 0.3) / 0.7))  # rad/s
    g = 1.25 * 9.81
    f = np.column_stack((g * np.sin(pitch) + np.where(omega != 0, 8.0 * np.cos(7 * t), 0.0), g * np.cos(pitch) + np.where(omega != 0, 5.0, 0.0)))
    up = foot_flat_up(f, omega, rate, np.ones(len(t), dtype=bool))
    assert up is not None and np.degrees(np.arctan2(up[0], up[1])) == pytest.approx(20.0, abs=0.1)
    assert foot_flat_up(f, omega, rate, np.zeros(len(t), dtype=bool)) is None  # outside the walking: nothing
    assert foot_flat_up(f, omega + 2.0, rate, np.ones(len(t), dtype=bool)) is None  # never at rest


def test_walking_only_calibration_recovers_thigh_and_shank_angles(gait) -> None:
    """Random 3D mountings with out-of-plane motion, bias and noise, no standing: thighs and shanks
    within 2.5° from their joint centres (50 mountings: ≤ 1.95°, benchmarks/accuracy/validate_sensor_calibration.py)."""
    res = mounting_trials(gait.q, gait.u, gait.qdd, trials=3, seed=4, standing_s=0.0, strides=30)
    legs = np.isin(res["segment"], ["femur_r", "tibia_r", "femur_l", "tibia_l"])
    assert np.abs(res["angle"][legs]).max() < 2.5
    typical = mounting_trials(gait.q, gait.u, gait.qdd, trials=3, seed=4, standing_s=0.0, strides=30, walking_angles="typical")
    assert np.abs(typical["angle"][legs]).min() > 5.0  # the typical orientations miss this gait's


@pytest.mark.parametrize("angle_deg", [0.0, 12.0])
def test_a_sensors_placement_follows_from_its_two_joint_centres(planes, angle_deg) -> None:
    """The shank sensor (typical place) mounted turned by θ: the knee and ankle centres fitted in
    its plane give back its position in the shank frame and θ."""
    theta = np.radians(angle_deg)
    c, s = np.cos(theta), np.sin(theta)
    f, omega, domega = planes["tibia_r"]
    turned = (f @ np.array([[c, -s], [s, c]]), omega, domega)  # f_sensor = R(θ)ᵀ f_segment, row-wise
    r_knee = joint_centre(planes["femur_r"], turned, np.array([0.0, -0.1]), np.array([0.0, 0.2])).r_b
    r_ankle = joint_centre(turned, planes["foot_r"], np.array([0.0, -0.2]), np.array([-0.1, 0.0])).r_a
    position, angle = sensor_placement(r_knee, r_ankle)
    place = IMUPlacement.default(1.75).positions["tibia_r"]
    np.testing.assert_allclose(position, place, atol=0.02)
    assert abs(np.degrees(angle) - angle_deg) < 1.5
