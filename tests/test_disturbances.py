"""Disturbance tests of the environments: push, observation noise and delay, actuator strength,
body mismatch and initial-state noise (the vector environment runs the same kernels; its
trajectories with disturbances equal the single environment's in tests/test_vector_env.py)."""

from __future__ import annotations

import numpy as np
import pytest

from envs.config import WalkerConfig
from envs.disturbances import Disturbances
from envs.sagittal_walker import SagittalWalkerEnv
from envs.vector import SagittalWalkerVectorEnv
from sspinn.model import dynamics

ZERO = np.zeros(6)
#: No falls: the body may collapse without ending the episode.
NO_FALL = {"min_height_fraction": 0.01, "max_tilt": 3.0}


def _com_velocity_x(q: np.ndarray, u: np.ndarray, body) -> float:
    """Horizontal centre-of-mass velocity (m/s): row 0 of M(q)·u is the horizontal momentum (the
    hip's x is a free translation of the whole body)."""
    return float((dynamics.mass_matrix(q, body) @ u)[0] / body.segment_mass_total)


def _airborne(env: SagittalWalkerEnv, seed: int = 0, options: dict | None = None) -> None:
    q = np.zeros(9)
    q[1] = 2.0  # feet a metre above the ground: no contact force for the whole test
    env.reset(seed=seed, options={"initial_state": (q, np.zeros(9)), "reset_noise_scale": 0.0, **(options or {})})


@pytest.mark.parametrize("mass_change", [0.0, 20.0])
def test_push_changes_the_centre_of_mass_velocity_by_impulse_over_mass(mass_change: float) -> None:
    force_bw, duration, start = 30.0, 0.1, 0.05
    disturbances = {"push_force": force_bw, "push_duration": duration, "push_time": start, "mass_change": mass_change}
    pushed = SagittalWalkerEnv(disturbances=disturbances, **NO_FALL)
    plain = SagittalWalkerEnv(disturbances={"mass_change": mass_change}, **NO_FALL)
    body = Disturbances(mass_change=mass_change).body(pushed.body)  # the simulated body
    _airborne(pushed)
    _airborne(plain)
    applied = []
    for _ in range(25):
        applied.append(pushed.step(ZERO)[-1]["push_force"])
        plain.step(ZERO)
    force = force_bw / 100 * pushed.body.body_weight  # % of the nominal body weight
    expected = [force if 5 <= k < 15 else 0.0 for k in range(25)]  # steps 5–14: 0.05 s to 0.15 s
    np.testing.assert_allclose(applied, expected)
    dv = _com_velocity_x(*pushed.state, body) - _com_velocity_x(*plain.state, body)
    assert dv == pytest.approx(force * duration / body.segment_mass_total, rel=1e-3)
    assert pushed.body.segment_mass_total == pytest.approx(70.0)  # the announced body stays nominal


def test_push_at_mid_stance_starts_when_the_stance_foot_turns_from_braking_to_propulsion() -> None:
    """Single support on the right foot: a forward-sliding foot (braking force) and then a
    backward-sliding one (propulsive force) start a ``midstance_r`` push, not a ``midstance_l`` one."""
    q = np.zeros(9)
    q[6:8] = 0.6, -1.2  # left hip flexed, knee bent: the left foot is in the air
    results = {}
    for phase in ("midstance_r", "midstance_l"):
        env = SagittalWalkerEnv(disturbances={"push_force": 10.0, "push_phase": phase, "push_after": 0.0,
                                              "push_duration": 0.03}, **NO_FALL)
        q[1] = env.standing_height
        pushes = []
        for sliding in (0.1, 0.1, -0.1, -0.1, -0.1, -0.1):
            if not pushes:
                env.reset(seed=0, options={"initial_state": (q, np.zeros(9)), "reset_noise_scale": 0.0})
            u = np.zeros(9)
            u[0] = sliding  # hip and, with all joints still, the right foot slide at this speed
            env.set_state(q, u)
            grf = dynamics.contact_forces(q, u, env.body, env.contact)[0]  # at the start of the step
            pushes.append((env.step(ZERO)[-1]["push_force"], float(grf[0])))
        results[phase] = pushes
    braking = [fx for _, fx in results["midstance_r"]]
    assert braking[0] < 0 and braking[2] > 0  # the friction force follows the sliding direction
    assert [f > 0 for f, _ in results["midstance_r"]] == [False, False, True, True, True, False]
    assert all(f == 0 for f, _ in results["midstance_l"])


def test_observation_noise_has_the_given_std_per_channel_class() -> None:
    std = {"angle": 0.05, "grf": 0.1}
    noisy = SagittalWalkerEnv(disturbances={"obs_noise": std}, **NO_FALL)
    clean = SagittalWalkerEnv(**NO_FALL)
    differences = []
    actions = np.random.default_rng(0).uniform(-0.3, 0.3, (100, 6))
    for seed in (3, 4, 5):  # three episodes of 1 s (the body collapses after about 1 s)
        differences.append(noisy.reset(seed=seed)[0] - clean.reset(seed=seed)[0])
        for a in actions:
            differences.append(noisy.step(a)[0] - clean.step(a)[0])
    d = np.array(differences, dtype=np.float64)
    np.testing.assert_array_equal(d[:, [0, *range(8, 17), 21]], 0.0)  # height, speeds, target: no noise
    angles, grf = d[:, 1:8].ravel(), d[:, 17:21].ravel()
    assert angles.std() == pytest.approx(0.05, rel=0.05) and abs(angles.mean()) < 0.005
    assert grf.std() == pytest.approx(0.1, rel=0.05) and abs(grf.mean()) < 0.01
    assert abs(np.corrcoef(angles[:-1], angles[1:])[0, 1]) < 0.05  # independent draws
    again = SagittalWalkerEnv(disturbances={"obs_noise": std}, **NO_FALL)
    assert np.array_equal(again.reset(seed=3)[0], noisy.reset(seed=3)[0])  # reproducible from the seed
    assert not np.array_equal(again.reset(seed=4)[0][1:8], noisy.reset(seed=3)[0][1:8])


def test_observation_delay_returns_the_observation_of_k_steps_ago() -> None:
    k = 3
    delayed = SagittalWalkerEnv(disturbances={"obs_delay": k}, **NO_FALL)
    clean = SagittalWalkerEnv(**NO_FALL)
    first = clean.reset(seed=1)[0]
    history = [first]
    got = [delayed.reset(seed=1)[0]]
    actions = np.random.default_rng(2).uniform(-0.5, 0.5, (20, 6))
    for a in actions:
        history.append(clean.step(a)[0])
        got.append(delayed.step(a)[0])
    for t in range(len(got)):
        np.testing.assert_array_equal(got[t], history[max(t - k, 0)], err_msg=f"step {t}")
    assert not np.array_equal(history[k + 1], history[0])


def test_strength_change_scales_the_applied_torque() -> None:
    action = np.array([0.5, -1.0, 0.25, 1.3, -0.2, 0.0])  # 1.3 is clipped to 1
    for change, factor in ((-30.0, 0.7), ([10.0, 0.0, -50.0, 20.0, 0.0, 100.0], np.array([1.1, 1, 0.5, 1.2, 1, 2.0]))):
        env = SagittalWalkerEnv(disturbances={"strength_change": change})
        env.reset(seed=0)
        torques = env.step(action)[-1]["torques"]
        np.testing.assert_allclose(torques, np.clip(action, -1, 1) * env.tau_max * factor)


def test_body_mismatch_changes_the_simulated_body_not_the_announced_one() -> None:
    env = SagittalWalkerEnv(disturbances={"length_change": 10.0, "mass_change": {"femur": -20.0}}, reset_noise_scale=0.0)
    nominal = SagittalWalkerEnv(reset_noise_scale=0.0)
    obs, _ = env.reset(seed=0)
    obs_nominal, _ = nominal.reset(seed=0)
    changed = Disturbances(length_change=10.0, mass_change={"femur": -20.0}).body(env.body)
    assert changed.femur_r.length == pytest.approx(1.1 * env.body.femur_r.length)
    assert changed.femur_l.mass == pytest.approx(0.8 * env.body.femur_l.mass)
    assert changed.tibia_r.mass == env.body.tibia_r.mass
    assert changed.foot_r.toe[0] == pytest.approx(1.1 * env.body.foot_r.toe[0])
    assert changed.pelvis.inertia == pytest.approx(1.21 * env.body.pelvis.inertia)
    # the simulated body starts at its own standing height; the announced model stays nominal
    assert obs[0] == pytest.approx(obs_nominal[0] + 0.1 * (env.body.femur_r.length + env.body.tibia_r.length), abs=0.01)
    np.testing.assert_array_equal(env.body_vector, nominal.body_vector)
    assert env.standing_height == nominal.standing_height


def test_reset_noise_scale_option() -> None:
    env = SagittalWalkerEnv()
    exact, _ = env.reset(seed=0, options={"reset_noise_scale": 0.0})
    assert exact[0] == pytest.approx(env.standing_height) and np.all(exact[1:17] == 0)
    noisy, _ = env.reset(seed=0, options={"reset_noise_scale": 0.05})
    deviation = np.abs(noisy[:17] - exact[:17])
    assert deviation.max() <= 0.05 + 1e-6 and deviation.max() > 0.02
    with pytest.raises(ValueError, match=r"reset_noise_scale.*\[0, 0.1\]"):
        env.reset(options={"reset_noise_scale": 0.5})


def test_reset_option_disturbances_apply_to_that_episode_only() -> None:
    env = SagittalWalkerEnv(disturbances={"strength_change": -50.0})
    env.reset(seed=0, options={"disturbances": {"strength_change": 0.0}})
    assert env.step(np.ones(6))[-1]["torques"] == pytest.approx(env.tau_max)
    env.reset(seed=0)
    assert env.step(np.ones(6))[-1]["torques"] == pytest.approx(0.5 * env.tau_max)
    vec = SagittalWalkerVectorEnv(2, disturbances={"strength_change": -50.0})
    vec.reset(seed=0, options={"disturbances": {"strength_change": 0.0}})
    np.testing.assert_allclose(vec.step(np.ones((2, 6)))[-1]["torques"], np.tile(env.tau_max, (2, 1)))


@pytest.mark.parametrize(
    "fields, message",
    [
        ({"push_force": 20.0}, "exactly one of push_time"),
        ({"push_force": 20.0, "push_time": 1.0, "push_phase": "midstance_r"}, "exactly one of push_time"),
        ({"push_phase": "heel_strike"}, "push_phase must be None or one of"),
        ({"push_force": 500.0, "push_time": 1.0}, r"push_force must be a number in \[-200, 200\] % body weight"),
        ({"obs_noise": {"angles": 0.1}}, r"unknown channel class\(es\) \['angles'\]"),
        ({"obs_noise": {"angle": -0.1}}, "obs_noise"),
        ({"obs_delay": 2.5}, "obs_delay must be an integer"),
        ({"obs_delay": 51}, "obs_delay must be an integer"),
        ({"strength_change": -100.0}, r"strength_change must be a number in \(-100, 100\] %"),
        ({"strength_change": [1.0, 2.0]}, "strength_change needs one number or 6"),
        ({"mass_change": {"arm": 5.0}}, "unknown segment 'arm'"),
        ({"length_change": float("nan")}, "length_change must be a number"),
        ({"wind": 3.0}, r"unknown field\(s\) \['wind'\]"),
    ],
)
def test_bad_disturbances_are_clear_value_errors(fields: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SagittalWalkerEnv(disturbances=fields)


def test_disturbances_load_from_an_agent_style_mapping() -> None:
    config = WalkerConfig.from_mapping({"disturbances": {"push_force": 15, "push_phase": "midstance_l",
                                                         "obs_noise": {"angle": 0.01}, "strength_change": [0, 0, 0, 0, 0, -10]}})
    assert config.disturbances.push_force == 15 and config.disturbances.strength_change[-1] == -10
    assert config.disturbances.noise_std()[1] == 0.01
    with pytest.raises(ValueError, match="env.kwargs.*obs_delay"):
        WalkerConfig.from_mapping({"disturbances": {"obs_delay": -1}}, prefix="env.kwargs")


def test_gait_shaping_penalty_slip_and_impact() -> None:
    """The optional reward terms: the slip the friction law implies, the impact excess over the
    threshold, in both NumPy environments and the torch one."""
    import torch

    from envs import task
    from envs.batched import BatchedSagittalWalker

    bw, mu, v_s = 700.0, 0.8, 0.2
    fy = 0.5 * bw
    fx = -mu * np.tanh(0.1 / v_s) * fy  # the right foot slides at 0.1 m/s
    assert task.foot_slip(fx, fy, mu, v_s, 0.1 * bw) == pytest.approx(0.1)
    assert task.foot_slip(fx, 0.05 * bw, mu, v_s, 0.1 * bw) == 0.0  # unloaded
    penalty = task.shaping_penalty(fx, fy, 0.0, 2.5 * bw, bw, mu, v_s, 2.0, 0.3, 1.5)
    assert penalty == pytest.approx(2.0 * 0.1 + 0.3 * 1.0**2)
    weights = {"slip_weight": 2.0, "impact_weight": 0.3, "impact_threshold": 0.4}
    shaped, plain = SagittalWalkerEnv(**weights), SagittalWalkerEnv()
    shaped.reset(seed=0)
    plain.reset(seed=0)
    action = np.full(6, 0.3)
    _, r_shaped, *_, info = shaped.step(action)
    _, r_plain, *_ = plain.step(action)
    c = shaped.contact
    expected = task.shaping_penalty(*info["grf"], shaped.body.body_weight, c.friction, c.slip_velocity, 2.0, 0.3, 0.4)
    assert expected > 0.01 and r_plain - r_shaped == pytest.approx(expected, rel=1e-9)
    batched = BatchedSagittalWalker(1, dtype=torch.float64, seed=0, auto_reset=False, **weights)
    batched.reset()
    q, u = shaped.state
    shaped.reset(seed=0)
    batched.set_state(torch.tensor(shaped.state[0])[None], torch.tensor(shaped.state[1])[None],
                      target_speed=shaped.target_speed)
    _, r_torch, *_ = batched.step(torch.tensor(action)[None])
    assert r_torch.item() == pytest.approx(r_shaped, rel=1e-6)


def test_phase_penalty_for_feet_that_neither_land_nor_lift_off() -> None:
    import torch

    from envs import task
    from envs.batched import BatchedSagittalWalker

    phase = 0.0
    for loaded in (True, True, False, False, False, True):
        phase = task.next_phase(phase, loaded, 0.01)
    assert phase == pytest.approx(0.01)  # landed again: a new contact phase
    assert task.next_phase(-0.03, False, 0.01) == pytest.approx(-0.04)
    weights = {"phase_weight": 0.5, "max_phase_duration": 0.045}
    penalised, plain = SagittalWalkerEnv(**weights, **NO_FALL), SagittalWalkerEnv(**NO_FALL)
    batched = BatchedSagittalWalker(1, dtype=torch.float64, auto_reset=False, **weights, **NO_FALL)
    differences = []
    for env in (penalised, plain):
        env.reset(seed=0, options={"reset_noise_scale": 0.0})
    batched.reset()
    batched.set_state(torch.tensor(penalised.state[0])[None], torch.tensor(penalised.state[1])[None],
                      target_speed=penalised.target_speed)
    for _ in range(8):  # standing: both feet stay in contact
        r_pen = penalised.step(ZERO)[1]
        differences.append(plain.step(ZERO)[1] - r_pen)
        assert batched.step(torch.zeros(1, 6, dtype=torch.float64))[1].item() == pytest.approx(r_pen, rel=1e-6)
    np.testing.assert_allclose(differences, [0.0] * 4 + [1.0] * 4, atol=1e-12)  # 2 feet × 0.5 from 0.05 s on


def test_an_initial_state_is_shifted_to_the_simulated_bodys_standing_height() -> None:
    import gymnasium as gym

    q0 = np.zeros(9)
    q0[1], q0[3], q0[6] = 0.90, 0.3, -0.3  # a walking-like pose, hips ±0.3 rad
    u0 = np.zeros(9)
    env = gym.make("sspinn/SagittalWalker-v0").unwrapped
    env.reset(seed=0, options={"initial_state": (q0, u0), "reset_noise_scale": 0.0})
    nominal_y = env.state[0][1]
    assert nominal_y == pytest.approx(0.90)
    env.reset(seed=0, options={"initial_state": (q0, u0), "reset_noise_scale": 0.0,
                               "disturbances": {"length_change": 5.0}})
    longer = env.state[0][1]
    assert longer - nominal_y == pytest.approx(0.05 * env.body.standing_hip_height, rel=0.05)
