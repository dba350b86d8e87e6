"""Gait metrics on synthetic gaits with known answers: symmetric and shifted cycles, a sliding
foot, impact peaks, cost of transport, angle RMSD."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sspinn.data.gait_metrics import (
    WALKING_TARGETS,
    GaitMetrics,
    ReferenceGait,
    gait_metrics,
    load_winter,
    symmetry_index,
)
from sspinn.model import kinematics
from sspinn.model.body import BodyParameters
from sspinn.model.trajectory import Trajectory

BODY = BodyParameters.from_anthropometry(1.75, 70.0)
BW = BODY.body_weight
T, DT = 1.1, 0.01  # stride duration (110 samples), sample interval (s)
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def _gait(offset: float = 0.5, stance: tuple[float, float] = (0.6, 0.6), speed: float = 1.2, hip_amplitude: float = 0.3,
          strides: int = 6, hip_torque: float = 0.0, left_hip_offset: float = 0.0) -> Trajectory:
    """A walk of ``strides`` cycles: the left foot's cycle lags the right one by ``offset`` of a
    stride; each foot carries 1 BW plus a 0.5 BW impact bump 30 ms after its heel strike during
    its stance fraction; the hips swing ±``hip_amplitude`` rad (flexed at heel strike), the left
    one about ``left_hip_offset`` rad."""
    n = int(round(strides * T / DT)) + 1
    t = np.arange(n) * DT
    q, u = np.zeros((n, 9)), np.zeros((n, 9))
    grf = np.zeros((n, 4))
    q[:, 0], u[:, 0], q[:, 1] = speed * t, speed, 0.9
    for f, lag in enumerate((0.0, offset)):
        phase = np.round((t / T - lag) * 110) / 110 % 1.0  # on the sample grid
        since = phase * T
        grf[:, 2 * f + 1] = np.where(phase < stance[f] - 1e-9, BW * (1.0 + 0.5 * np.exp(-(((since - 0.03) / 0.01) ** 2))), 0.0)
        q[:, 3 + 3 * f] = hip_amplitude * np.cos(2 * np.pi * phase) + (left_hip_offset if f else 0.0)
        u[:, 3 + 3 * f] = -hip_amplitude * 2 * np.pi / T * np.sin(2 * np.pi * phase)
    tau = np.zeros((n, 6))
    tau[:, 0] = hip_torque
    return Trajectory(time=t, q=q, u=u, qdd=np.zeros((n, 9)), tau=tau, grf=grf, w=np.full((n, 2), 0.5))


def _heel_distance(hip_r: float, hip_l: float) -> float:
    """Forward distance of the right heel ahead of the left one (m) in a pose with only hip angles."""
    q = np.zeros(9)
    q[1], q[3], q[6] = 0.9, hip_r, hip_l
    points = np.asarray(kinematics.point_kinematics(q, np.zeros(9), np.zeros(9), np.full(2, 0.5), BODY))
    return float(points[kinematics.point_index("heel_r"), 0] - points[kinematics.point_index("heel_l"), 0])


def test_symmetric_cycle_has_no_asymmetry() -> None:
    m = gait_metrics(_gait(), BODY)
    assert m.steps_r >= 5 and m.steps_l >= 5
    assert m.step_time_r == pytest.approx(T / 2) and m.step_time_l == pytest.approx(T / 2)
    assert m.step_time_asymmetry == pytest.approx(0.0, abs=1e-9)
    assert m.step_length_asymmetry == pytest.approx(0.0, abs=1e-6)
    assert m.stance_percent_r == pytest.approx(60.0) and m.stance_asymmetry == pytest.approx(0.0, abs=1e-9)
    assert m.step_length_r == pytest.approx(_heel_distance(0.3, -0.3)) and m.step_length_l == pytest.approx(m.step_length_r)
    assert m.cadence_steps_per_min == pytest.approx(60 / (T / 2))
    assert m.flight_percent == 0.0  # stance 60 % of each stride: double support, never flight
    running = gait_metrics(_gait(stance=(0.3, 0.3)), BODY)  # each foot down 30 % of the stride, half a stride apart
    assert running.flight_percent == pytest.approx(40.0, abs=1.5)


def test_feet_landing_together_give_no_cadence_instead_of_an_error() -> None:
    """Both feet strike at the same sample (a two-footed hop), once after the settling time: the
    one step lasts 0 s."""
    m = gait_metrics(_gait(offset=0.0, strides=2), BODY, settle_s=0.5)
    assert m.steps_l == 1 and m.step_time_l == 0.0
    assert math.isnan(m.cadence_steps_per_min)


def test_shifted_cycle_gives_the_known_asymmetry() -> None:
    """Left heel strike at 60 % of the right stride instead of 50 %: left steps 0.66 s, right steps
    0.44 s, SI = 100 · 0.22 / 0.55 = 40 %; left stance 70 % against 60 %: SI = 100 · 10 / 65."""
    m = gait_metrics(_gait(offset=0.6, stance=(0.6, 0.7)), BODY)
    assert m.step_time_l == pytest.approx(0.66) and m.step_time_r == pytest.approx(0.44)
    assert m.step_time_asymmetry == pytest.approx(40.0)
    assert m.stance_percent_l == pytest.approx(70.0) and m.stance_asymmetry == pytest.approx(100 * 10 / 65)
    assert m.contact_share_l == pytest.approx(70.0, abs=0.5) and m.contact_asymmetry == pytest.approx(100 * 10 / 65, rel=0.03)
    assert m.step_length_asymmetry == pytest.approx(0.0, abs=1e-6)  # cos(0.8π) = cos(1.2π): same hip angles
    # a left leg held 0.1 rad further back: right steps (left at −0.4 rad) are longer than left ones
    m = gait_metrics(_gait(left_hip_offset=-0.1), BODY)
    right, left = _heel_distance(0.3, -0.4), -_heel_distance(-0.3, 0.2)
    assert m.step_length_r == pytest.approx(right) and m.step_length_l == pytest.approx(left)
    assert m.step_length_asymmetry == pytest.approx(100 * abs(right - left) / ((right + left) / 2))
    assert symmetry_index(1.0, 1.0) == 0.0 and math.isnan(symmetry_index(float("nan"), 1.0))


def test_foot_sliding_impact_peak_and_cost_of_transport() -> None:
    """Legs still while the hip moves at 0.1 m/s: each contact point slides 0.1 m/s × 0.66 s."""
    m = gait_metrics(_gait(speed=0.1, hip_amplitude=0.0, stance=(0.6, 0.6)), BODY)
    assert m.foot_slide_per_step_cm == pytest.approx(0.1 * 0.66 * 100, rel=1e-6)
    assert m.peak_impact_bw == pytest.approx(1.5) and m.max_vertical_grf_bw == pytest.approx(1.5)
    walk = _gait(hip_torque=10.0)
    m = gait_metrics(walk, BODY)
    distance = walk.q[-1, 0] - walk.q[0, 0]
    assert m.cost_of_transport == pytest.approx(10.0 * 6 * 4 * 0.3 / (BW * distance))  # hip_r: 1.2 rad of travel per stride
    standing = _gait(speed=0.0)
    assert math.isnan(gait_metrics(standing, BODY).cost_of_transport)


def test_a_dragging_foot_shows_in_the_contact_share() -> None:
    """The left foot never leaves the ground: no left heel strikes or steps, stance % undefined,
    contact share 100 % against the right foot's 60 %."""
    walk = _gait()
    walk.grf[:, 3] = BW
    m = gait_metrics(walk, BODY)
    assert m.heel_strikes_l == 0 and m.heel_strikes_r >= 5 and m.steps_l == 0
    assert math.isnan(m.step_time_asymmetry) and math.isnan(m.stance_asymmetry)
    assert m.contact_share_l == 100.0 and m.contact_share_r == pytest.approx(60.0, abs=0.5)
    assert m.contact_asymmetry == pytest.approx(100 * 40 / 80, rel=0.02)
    percent = np.arange(50) * 2.0
    knee = np.full(50, np.radians(5.0))
    reference = ReferenceGait(percent=percent, hip=0.3 * np.cos(2 * np.pi * percent / 100), knee=knee, ankle=knee * 0,
                              grf_x=knee * 0, grf_y=knee * 0, speed=1.2, duration=T)
    assert gait_metrics(walk, BODY, reference=reference).rmsd_knee_deg == pytest.approx(5.0)  # the right leg alone


def test_settle_time_ignores_the_first_events() -> None:
    assert gait_metrics(_gait(), BODY, settle_s=3.0).steps_r < gait_metrics(_gait(), BODY).steps_r


def test_angle_rmsd_to_a_reference_cycle() -> None:
    percent = np.arange(50) * 2.0
    phase = percent / 100
    reference = ReferenceGait(percent=percent, hip=0.3 * np.cos(2 * np.pi * phase), knee=np.zeros(50),
                              ankle=np.zeros(50), grf_x=np.zeros(50), grf_y=np.zeros(50), speed=1.2, duration=T)
    m = gait_metrics(_gait(), BODY, reference=reference)
    assert m.rmsd_hip_deg < 0.2 and m.rmsd_knee_deg == pytest.approx(0.0, abs=1e-9)
    shifted = ReferenceGait(**{**reference.__dict__, "knee": np.full(50, np.radians(5.0))})
    assert gait_metrics(_gait(), BODY, reference=shifted).rmsd_knee_deg == pytest.approx(5.0)
    assert math.isnan(gait_metrics(_gait(), BODY).rmsd_hip_deg)
    assert gait_metrics(_gait(), BODY).as_dict()["rmsd_hip_deg"] is None


def test_winter_reference_when_the_shared_data_exists() -> None:
    if not (SHARED / "winter_walking").is_dir():
        pytest.skip("../shared/data/winter_walking is not available")
    winter = load_winter(SHARED)
    assert len(winter.percent) == 50 and winter.speed == pytest.approx(1.325)
    assert np.degrees(winter.hip.max()) == pytest.approx(20, abs=8) and np.degrees(winter.knee.min()) < -55
    with pytest.raises(FileNotFoundError, match="optional"):
        load_winter(SHARED / "nowhere")


def test_contact_point_velocity_is_the_slip_of_the_friction_law() -> None:
    """The sliding speed the metric integrates (the contact point's v_x from the kinematics) is the
    one the environment's friction law F_x = −μ·tanh(v/v_s)·F_y acts on."""
    from envs.sagittal_walker import SagittalWalkerEnv
    from sspinn.model.dynamics import contact_forces

    env = SagittalWalkerEnv(min_height_fraction=0.01, max_tilt=3.0)
    env.reset(seed=2)
    states = []
    for a in np.random.default_rng(0).uniform(-0.4, 0.4, (60, 6)):
        env.step(a)
        states.append(env.state)
    q, u = (np.array(x) for x in zip(*states))
    grf, w = (np.asarray(x) for x in contact_forces(q, u, env.body, env.contact))
    points = np.asarray(kinematics.point_kinematics(q, u, np.zeros_like(q), w, env.body))
    mu, v_s = env.contact.friction, env.contact.slip_velocity
    checked = 0
    for f, row in enumerate((kinematics.point_index("contact_r"), kinematics.point_index("contact_l"))):
        fx, fy = grf[:, 2 * f], grf[:, 2 * f + 1]
        ok = (fy > 0.1 * BODY.body_weight) & (np.abs(fx) < 0.9 * mu * fy)
        slip = -v_s * np.arctanh(fx[ok] / (mu * fy[ok]))
        np.testing.assert_allclose(points[ok, row, 2], slip, atol=1e-6)
        checked += int(ok.sum())
    assert checked > 30


def test_too_short_a_trajectory_gives_undefined_metrics() -> None:
    m = gait_metrics(_gait()[:2], BODY)
    assert m.steps_r == 0 and m.heel_strikes_l == 0 and math.isnan(m.peak_impact_bw) and m.as_dict()["foot_slide_m"] is None


def test_the_optional_data_is_found_only_where_it_is_told(monkeypatch, tmp_path) -> None:
    """No default location: without ``SSPINN_SHARED_DATA`` or an argument, a one-line error names
    the variable and the folder; with the variable, its folder is used."""
    from sspinn.data.gait_metrics import winter_or_none
    from sspinn.data.shared_data import shared_data_dir, shared_data_folder

    monkeypatch.delenv("SSPINN_SHARED_DATA", raising=False)
    assert shared_data_dir() is None and winter_or_none() is None
    with pytest.raises(FileNotFoundError, match=r"^winter_walking: no data folder given; .*SSPINN_SHARED_DATA"):
        load_winter()
    (tmp_path / "winter_walking").mkdir()
    monkeypatch.setenv("SSPINN_SHARED_DATA", str(tmp_path))
    assert shared_data_folder("winter_walking") == tmp_path / "winter_walking"
    with pytest.raises(FileNotFoundError, match=r"signals.csv: not found"):
        load_winter()
    with pytest.raises(FileNotFoundError, match=r"opensim_hamner_run: not found"):
        shared_data_folder("opensim_hamner_run")


# ---------------------------------------------------------------------------------------------
# Gaits that must be scored as what they are: taps, hops, shuffles, flight, human walking
# ---------------------------------------------------------------------------------------------
def _contacts(contacts: list[tuple[int, float, float]], duration: float, speed: float = 1.2, hip_amplitude: float = 0.3,
              stride: float = 1.06) -> Trajectory:
    """A trajectory at 100 Hz whose feet carry 1 BW during the given (foot, start s, end s)
    contacts (foot 0 right, 1 left) and nothing else; the pelvis moves at ``speed``, the hips swing
    ±``hip_amplitude`` rad with period ``stride`` (the left half a period later)."""
    n = int(round(duration / DT)) + 1
    t = np.arange(n) * DT
    q, u, grf = np.zeros((n, 9)), np.zeros((n, 9)), np.zeros((n, 4))
    q[:, 0], u[:, 0], q[:, 1] = speed * t, speed, 0.9
    for f in range(2):
        q[:, 3 + 3 * f] = hip_amplitude * np.cos(2 * np.pi * (t / stride - 0.5 * f))
    for foot, start, end in contacts:
        grf[int(round(start / DT)) : int(round(end / DT)), 2 * foot + 1] = BW
    return Trajectory(time=t, q=q, u=u, qdd=np.zeros((n, 9)), tau=np.zeros((n, 6)), grf=grf, w=np.full((n, 2), 0.5))


def test_a_tapping_swing_foot_is_no_step() -> None:
    """The walker that passed every target on taps: single stances of 0.50 s separated by 30 ms
    of flight, and the swing foot tapping the ground for 60 ms 30 ms after the other foot lands.
    Steps are the 0.53-s stance-to-stance steps (113 steps/min), not 0.03-s tap-to-landing ones;
    the taps, the flight and the missing double support miss their targets."""
    contacts = []
    for k in range(18):
        foot, start = k % 2, 0.2 + 0.53 * k
        contacts += [(foot, start, start + 0.50), (1 - foot, start + 0.03, start + 0.09)]
    m = gait_metrics(_contacts(contacts, 9.7), BODY)  # ends with the last stance
    assert m.taps_r + m.taps_l >= 16 and m.taps_per_step == pytest.approx(1.0, abs=0.1)
    assert m.heel_strikes_r == 9 and m.heel_strikes_l == 9 and m.steps_r + m.steps_l == 17
    assert m.step_time_r == pytest.approx(0.53) and m.cadence_steps_per_min == pytest.approx(60 / 0.53, rel=1e-6)
    assert m.flight_percent == pytest.approx(100 * (0.2 + 17 * 0.03) / 9.7, abs=0.2)  # before the first landing and between stances
    assert m.double_support_percent == 0.0
    misses = " ".join(WALKING_TARGETS.misses(m))
    assert "taps" in misses and "flight_percent" in misses and "double_support_percent" in misses
    assert "cadence" not in misses


def test_hopping_on_one_leg_has_no_steps_and_misses_the_targets() -> None:
    contacts = [(0, 0.2 + 0.6 * k, 0.2 + 0.6 * k + 0.4) for k in range(16)]
    m = gait_metrics(_contacts(contacts, 9.6), BODY)  # ends with the last hop
    assert m.heel_strikes_r == 16 and m.heel_strikes_l == 0 and m.steps_r == m.steps_l == 0
    assert math.isnan(m.cadence_steps_per_min) and m.taps_r + m.taps_l == 0
    assert m.flight_percent == pytest.approx(100 * 0.2 / 0.6, abs=2.0)
    misses = " ".join(WALKING_TARGETS.misses(m))
    assert "cadence" in misses and "step_time_asymmetry" in misses and "flight" in misses


def test_a_shuffle_slides_and_its_steps_do_not_carry_the_body() -> None:
    """Both feet down 90 % of a 1.1-s stride, legs held still while the pelvis moves at 0.5 m/s:
    the feet slide ~0.5 m per stance and the heels never step past each other, so the step length
    (0) disagrees with the distance per step (0.275 m)."""
    contacts = [(f, 0.2 + 0.55 * f + 1.1 * k, 0.2 + 0.55 * f + 1.1 * k + 0.99) for k in range(9) for f in range(2)]
    m = gait_metrics(_contacts(contacts, 10.0, speed=0.5, hip_amplitude=0.0), BODY, settle_s=1.0)  # after the first stride
    assert m.double_support_percent == pytest.approx(80.0, abs=2.0) and m.taps_r + m.taps_l == 0
    assert m.foot_slide_per_step_cm == pytest.approx(0.5 * 99, rel=0.02)
    assert m.distance_per_step_m == pytest.approx(0.275, rel=0.02) and abs(m.step_length_r) < 1e-9
    assert any("foot_slide" in miss for miss in WALKING_TARGETS.misses(m))


def test_a_walk_with_flight_misses_flight_and_double_support() -> None:
    """Each foot down 45 % of a 1.1-s stride, half a stride apart: 10 % flight, no double support."""
    contacts = [(f, 0.2 + 0.55 * f + 1.1 * k, 0.2 + 0.55 * f + 1.1 * k + 0.495) for k in range(9) for f in range(2)]
    m = gait_metrics(_contacts(contacts, 10.0, stride=1.1), BODY, settle_s=1.0)
    assert m.flight_percent == pytest.approx(10.0, abs=1.0) and m.double_support_percent == 0.0
    assert m.taps_r + m.taps_l == 0 and m.cadence_steps_per_min == pytest.approx(60 / 0.55)
    misses = " ".join(WALKING_TARGETS.misses(m))
    assert "flight_percent" in misses and "double_support_percent" in misses and "cadence" not in misses


def test_cadence_and_step_length_agree_with_distance_per_step() -> None:
    """The 1.3 m/s optimal-control walk (configs/agents/gaits/walk_1.3.npz, feet planted by the
    contact model), repeated for 8 strides: the mean step length is the pelvis's travel per step,
    and cadence × distance per step is the speed."""
    gait = np.load(Path(__file__).resolve().parents[1] / "configs" / "agents" / "gaits" / "walk_1.3.npz")
    n, period = len(gait["time"]) - 1, float(gait["time"][-1])
    advance = gait["q"][-1, 0] - gait["q"][0, 0]
    reps = 8
    q = np.concatenate([gait["q"][:n] + np.eye(9)[0] * advance * k for k in range(reps)])
    walk = Trajectory(time=np.arange(reps * n) * DT, q=q, u=np.tile(gait["u"][:n], (reps, 1)), qdd=np.zeros((reps * n, 9)),
                      tau=np.tile(gait["tau"][:n], (reps, 1)), grf=np.tile(gait["grf"][:n], (reps, 1)),
                      w=np.tile(gait["w"][:n], (reps, 1)))
    m = gait_metrics(walk, BODY)
    speed = advance / period
    step_length = 0.5 * (m.step_length_r + m.step_length_l)
    assert m.distance_per_step_m == pytest.approx(speed * period / 2, rel=0.02)
    assert step_length == pytest.approx(m.distance_per_step_m, rel=0.05)
    assert m.cadence_steps_per_min / 60 * m.distance_per_step_m == pytest.approx(speed, rel=0.02)
    assert m.taps_r + m.taps_l == 0 and m.flight_percent == 0.0 and m.double_support_percent > 5.0


def test_winters_walking_is_scored_as_human_walking() -> None:
    """Winter's averaged stride (both legs' angles and GRF, 1.325 m/s), repeated: no taps, no
    flight, ≈ 20 % double support, ≈ 105 steps/min, symmetric steps, and its own angles' RMSD to
    its reference is small."""
    folder = SHARED / "winter_walking"
    if not folder.is_dir():
        pytest.skip("../shared/data/winter_walking is not available")
    winter = load_winter(SHARED)
    data = np.genfromtxt(folder / "signals.csv", delimiter=",", names=True)
    body = BodyParameters.from_anthropometry(1.62, 56.7)
    reps, rate = 8, len(data) / winter.duration
    n = reps * len(data)
    t = np.arange(n) / rate
    q, u = np.zeros((n, 9)), np.zeros((n, 9))
    q[:, 0], u[:, 0], q[:, 1] = winter.speed * t, winter.speed, 0.85
    for j, name in enumerate(("hip_flexion", "knee_angle", "ankle_angle")):
        q[:, 3 + j], q[:, 6 + j] = np.tile(data[f"{name}_r_angle"], reps), np.tile(data[f"{name}_l_angle"], reps)
    grf = np.tile(np.stack([data["grf_x_r"], data["grf_y_r"], data["grf_x_l"], data["grf_y_l"]], axis=1), (reps, 1))
    walk = Trajectory(time=t, q=q, u=u, qdd=np.zeros((n, 9)), tau=np.zeros((n, 6)), grf=grf * body.body_weight,
                      w=np.full((n, 2), 0.5))
    m = gait_metrics(walk, body, reference=winter)
    assert m.taps_r + m.taps_l == 0 and m.flight_percent == 0.0
    assert m.double_support_percent == pytest.approx(20.0, abs=3.0)
    assert m.cadence_steps_per_min == pytest.approx(60 / (winter.duration / 2), rel=0.03)
    assert m.step_time_asymmetry < 5.0 and m.stance_asymmetry < 5.0
    assert m.rmsd_knee_deg < 5.0 and m.rmsd_hip_deg < 5.0
    assert m.distance_per_step_m == pytest.approx(winter.speed * winter.duration / 2, rel=0.03)
    misses = " ".join(WALKING_TARGETS.misses(m))
    for target in ("taps", "flight", "double_support", "cadence", "step_time_asymmetry", "stance_asymmetry"):
        assert target not in misses, misses


def test_each_walking_target_is_checked_once() -> None:
    """A gait inside every target has no misses; pushing one metric out misses that target alone,
    and an undefined metric (too few steps) misses it too."""
    from dataclasses import replace

    good = replace(GaitMetrics.undefined(), steps_r=8, steps_l=8, step_time_asymmetry=1.0, step_length_asymmetry=2.0,
                   stance_asymmetry=1.0, foot_slide_per_step_cm=1.0, peak_impact_bw=1.5, flight_percent=0.0,
                   double_support_percent=20.0, cadence_steps_per_min=110.0)
    assert WALKING_TARGETS.misses(good, distance_m=12.0) == []
    for field, value, word in [("step_length_asymmetry", 12.0, "step_length_asymmetry"), ("foot_slide_per_step_cm", 2.5, "foot_slide"),
                               ("peak_impact_bw", 2.1, "peak_impact"), ("flight_percent", 5.0, "flight"),
                               ("double_support_percent", 8.0, "double_support"), ("cadence_steps_per_min", 1225.0, "cadence"),
                               ("cadence_steps_per_min", float("nan"), "cadence"), ("taps_r", 1, "taps")]:
        misses = WALKING_TARGETS.misses(replace(good, **{field: value}), distance_m=12.0)
        assert len(misses) == 1 and word in misses[0], (field, misses)
    assert WALKING_TARGETS.misses(good, fell=True, distance_m=4.0) == ["fell", "distance 4.00 m < 10 m"]
    assert WALKING_TARGETS.misses(good, distance_m=6.0, duration_s=5.0) == []  # 10 m per 10 s
