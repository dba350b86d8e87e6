"""The Gymnasium environment ``sspinn/SagittalWalker-v0`` and its batched torch twin."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
import torch
from gymnasium.utils.env_checker import check_env

import envs
from envs import task
from envs.batched import BatchedSagittalWalker
from envs.sagittal_walker import SagittalWalkerEnv
from sspinn.model import dynamics, simulation
from sspinn.model.conventions import COORDINATES, GRF, JOINTS

#: Gymnasium warns about unbounded Box spaces (as for its own MuJoCo environments); nothing else
#: may be reported.
_EXPECTED_WARNINGS = ("observation space minimum value is -infinity", "observation space maximum value is infinity")


@pytest.fixture(scope="module")
def env() -> SagittalWalkerEnv:
    return SagittalWalkerEnv(render_mode="rgb_array")


def _random_actions(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, (n, 6)).astype(np.float32)


def test_check_env_passes_including_both_render_modes() -> None:
    """check_env with the registered spec, so it also builds a "human" env (headless: SDL dummy)."""
    made = gymnasium.make(envs.ENV_ID, render_mode="rgb_array")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(made.unwrapped)
    unexpected = [str(w.message) for w in caught if not any(e in str(w.message) for e in _EXPECTED_WARNINGS)]
    assert not unexpected, unexpected
    made.close()


def test_make_with_module_prefix_registers_without_import() -> None:
    env = gymnasium.make("envs:sspinn/SagittalWalker-v0", target_speed=2.0)
    obs, info = env.reset(seed=3)
    assert info["target_speed"] == 2.0 and obs[task.OBS_INDEX["target_speed"]] == np.float32(2.0)
    env.close()


def test_seeded_rollouts_are_reproducible() -> None:
    actions = _random_actions(60)

    def rollout(seed: int) -> tuple[np.ndarray, np.ndarray]:
        e = SagittalWalkerEnv(target_speed=(0.5, 3.0))
        obs, _ = e.reset(seed=seed)
        observations, rewards = [obs], []
        for a in actions:
            obs, r, terminated, truncated, _ = e.step(a)
            observations.append(obs)
            rewards.append(r)
            if terminated or truncated:
                obs, _ = e.reset()
                observations.append(obs)
        return np.array(observations), np.array(rewards)

    o1, r1 = rollout(7)
    o2, r2 = rollout(7)
    o3, _ = rollout(8)
    np.testing.assert_array_equal(o1, o2)
    np.testing.assert_array_equal(r1, r2)
    assert not np.array_equal(o1[0], o3[0])


def test_observation_layout_matches_documented_indices(env: SagittalWalkerEnv) -> None:
    assert task.OBS_SIZE == len(task.OBSERVATION_UNITS) == 22
    assert task.OBSERVATION_NAMES[0] == "pelvis_ty" and task.OBSERVATION_NAMES[21] == "target_speed"
    env.reset(seed=1, options={"target_speed": 1.7})
    obs, *_, info = env.step(_random_actions(1)[0])
    q, u = env.state
    assert obs.dtype == np.float32 and obs.shape == env.observation_space.shape
    bw = env.body.body_weight
    expected = {
        **{name: q[i] for i, name in enumerate(COORDINATES) if name != "pelvis_tx"},
        **{f"d_{name}": u[i] for i, name in enumerate(COORDINATES)},
        **{name: info["grf"][i] / bw for i, name in enumerate(GRF)},
        "target_speed": 1.7,
    }
    assert set(expected) == set(task.OBSERVATION_NAMES)
    for name, value in expected.items():
        assert obs[task.OBS_INDEX[name]] == pytest.approx(value, rel=1e-6, abs=1e-6), name
    # the documented index table: 2–7 joint angles, 8 forward speed, 17–20 contact forces
    assert [task.OBSERVATION_NAMES[i] for i in range(2, 8)] == list(JOINTS)
    assert task.OBSERVATION_NAMES[8] == "d_pelvis_tx" and task.OBSERVATION_NAMES[17:21] == GRF
    # standing start: each foot carries about half the body weight
    obs0, _ = env.reset(seed=2)
    assert obs0[18] == pytest.approx(0.5, abs=0.25) and obs0[20] == pytest.approx(0.5, abs=0.25)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"target_speed": -0.5}, "target_speed must be >= 0"),
        ({"target_speed": (2.0, 1.0)}, "low <= high"),
        ({"target_speed": "fast"}, "target_speed must be a number"),
        ({"target_speed": 40.0}, "beyond human sprinting"),
        ({"height": "tall"}, "height must be a number"),
        ({"height": 17.5}, "plausible human range"),
        ({"mass": -70.0}, "mass must be > 0"),
        ({"body": {"height": 1.7, "mass": 60.0, "wings": 2}}, "unknown body parameter"),
        ({"body": 42}, "body must be a BodyParameters"),
        ({"body": {"height": 1.7, "mass": 60.0}, "height": 1.8}, "either body or height/mass"),
        ({"max_torque": {"elbow": 1.0}}, "unknown joint type"),
        ({"max_torque": [3.0, 3.0]}, "needs 6 values"),
        ({"max_torque": {"hip": -1.0}}, r"in \(0, 20\) N·m/kg"),
        ({"joint_range": {"knee": (0.1, 0.5)}}, "must contain the standing pose"),
        ({"substeps": 0}, "substeps must be an integer >= 1"),
        ({"substeps": 2.5}, "substeps must be an integer"),
        ({"method": "euler"}, "unknown integrator"),
        ({"slip_velocity": 0.0}, "slip_velocity must be a positive number"),
        ({"tracking_width": 0.0}, "tracking_width must be > 0"),
        ({"min_height_fraction": 1.5}, r"min_height_fraction must lie in \(0, 1\)"),
        ({"max_episode_steps": 0}, "max_episode_steps must be an integer >= 1"),
        ({"render_mode": "video"}, "render_mode must be None or one of"),
    ],
)
def test_bad_arguments_raise_clear_value_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SagittalWalkerEnv(**kwargs)


def test_bad_reset_options_and_actions(env: SagittalWalkerEnv) -> None:
    with pytest.raises(ValueError, match="target_speed must be >= 0"):
        env.reset(options={"target_speed": -1.0})
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must have shape \(6,\)"):
        env.step(np.zeros(5))
    with pytest.raises(ValueError, match="num_envs must be an integer"):
        BatchedSagittalWalker(0)


def test_target_speed_sampling_truncation_and_info() -> None:
    e = SagittalWalkerEnv(target_speed=(0.8, 2.0), max_episode_steps=3)
    speeds = {e.reset(seed=s)[1]["target_speed"] for s in range(5)}
    assert len(speeds) == 5 and all(0.8 <= s <= 2.0 for s in speeds)
    assert e.reset(seed=0, options={"target_speed": 1.1})[1]["target_speed"] == 1.1
    flags = [e.step(np.zeros(6, dtype=np.float32))[2:4] for _ in range(3)]
    assert flags == [(False, False), (False, False), (False, True)]
    with pytest.warns(UserWarning, match="after the episode ended"):
        *_, info = e.step(np.full(6, 0.5, dtype=np.float32))
    np.testing.assert_allclose(info["torques"], 0.5 * 3.0 * e.body.segment_mass_total)
    assert {"speed", "distance", "cost_of_transport", "grf", "torques", "x_position"} <= set(info)


def test_fall_terminates_and_alive_bonus_stops(env: SagittalWalkerEnv) -> None:
    env.reset(seed=0)
    q, u = env.state
    q[2] = 1.2  # trunk leaning back beyond max_tilt
    env.set_state(q, u)
    _, reward, terminated, truncated, info = env.step(np.zeros(6, dtype=np.float32))
    assert terminated and not truncated and info["reward_alive"] == 0.0


def test_env_step_is_sspinn_step_with_the_passive_moments() -> None:
    """One env step = sspinn.model.simulation.step over the control interval with the env's torques and
    passive parameters (the stepper itself is checked against the torch integrators in test_dynamics)."""
    e = SagittalWalkerEnv()
    e.reset(seed=4)
    q0, u0 = e.state
    u0 += np.random.default_rng(0).normal(0, 0.5, 9)
    e.set_state(q0, u0)
    action = np.array([0.2, -0.15, 0.1, -0.05, 0.12, -0.07], dtype=np.float32)
    *_, info = e.step(action)
    q_ref, u_ref, grf_ref = simulation.step(
        q0, u0, info["torques"], e.body_vector, e.contact_vector, 0.01 / 50, 50, "semi_implicit_euler", True, passive=task.passive_parameters()
    )
    q, u = e.state
    np.testing.assert_array_equal(q, q_ref)
    np.testing.assert_array_equal(u, u_ref)
    np.testing.assert_array_equal(info["grf"], grf_ref)
    q_bare = simulation.step(q0, u0, info["torques"], e.body_vector, e.contact_vector, 0.01 / 50, 50, "semi_implicit_euler", True)[0]
    assert np.abs(q_bare - q).max() > 1e-6, "the passive moments must change the motion"


def test_random_and_passive_episodes_stay_finite_and_energy_sane() -> None:
    """Random actions never produce a non-finite state; without torques the body only loses
    mechanical energy (contact and joint damping dissipate; springs start almost unloaded)."""
    e = SagittalWalkerEnv()
    actions = _random_actions(400, seed=1)
    e.reset(seed=0)
    for a in actions:
        *_, terminated, truncated, info = e.step(a)
        assert not info["physics_failure"]
        if terminated or truncated:
            e.reset()
    e = SagittalWalkerEnv(min_height_fraction=0.01, max_tilt=3.0)
    e.reset(seed=0)
    q, u = e.state
    e0 = sum(dynamics.energy(q, u, e.body))
    energies = []
    for _ in range(150):  # 1.5 s: the body collapses onto the ground
        e.step(np.zeros(6, dtype=np.float32))
        energies.append(sum(dynamics.energy(*e.state, e.body)))
    assert np.all(np.isfinite(energies))
    assert max(energies) <= e0 + 2.0, f"energy rose by {max(energies) - e0:.2f} J"  # 2 J: contact spring at rest
    assert min(energies) < e0 - 100.0, "the passive body should fall and dissipate energy"


def test_batched_env_matches_single_env_for_one_step() -> None:
    single = SagittalWalkerEnv(target_speed=1.4)
    states, actions = [], _random_actions(3, seed=9)
    for i in range(3):
        single.reset(seed=i)
        for a in _random_actions(4, seed=10 + i):
            single.step(a)
        states.append(single.state)
    q = np.array([s[0] for s in states])
    u = np.array([s[1] for s in states])
    expected = []
    for i in range(3):
        single.set_state(q[i], u[i])
        expected.append(single.step(actions[i]))
    for dtype, rtol, atol in ((torch.float64, 1e-7, 1e-6), (torch.float32, 1e-3, 2e-3)):
        batched = BatchedSagittalWalker(3, dtype=dtype, seed=0, target_speed=1.4, auto_reset=False)
        batched.reset()
        batched.set_state(torch.tensor(q), torch.tensor(u))
        obs, reward, terminated, truncated, info = batched.step(torch.tensor(actions))
        for i, (obs_i, r_i, te_i, tr_i, info_i) in enumerate(expected):
            np.testing.assert_allclose(obs[i].numpy(), obs_i, rtol=rtol, atol=atol)
            assert reward[i].item() == pytest.approx(r_i, rel=rtol, abs=atol)
            assert bool(terminated[i]) == te_i and bool(truncated[i]) == tr_i
            np.testing.assert_allclose(info["grf"][i].numpy(), info_i["grf"], rtol=rtol, atol=1e3 * atol)


def test_batched_auto_reset_and_gradients() -> None:
    env = BatchedSagittalWalker(4, dtype=torch.float64, seed=1, substeps=10, target_speed=(1.0, 2.0))
    obs, info = env.reset(seed=2)
    assert obs.shape == (4, 22) and bool(((info["target_speed"] >= 1.0) & (info["target_speed"] <= 2.0)).all())
    q = env.q.clone()
    q[1, 2] = 1.5  # env 1 beyond the tilt limit: terminates and is reset in the same step
    env.set_state(q, env.u)
    actions = torch.zeros(4, 6, dtype=torch.float64, requires_grad=True)
    obs, reward, terminated, truncated, info = env.step(actions)
    assert terminated.tolist() == [False, True, False, False]
    assert info["_final_obs"].tolist() == [False, True, False, False]
    assert info["final_obs"][1, 1].item() == pytest.approx(1.5, abs=0.05)  # the old tilt
    assert abs(obs[1, 1].item()) < 0.01  # the new episode starts upright
    reward[[0, 2, 3]].sum().backward()  # differentiable through step_torch
    assert actions.grad is not None and torch.isfinite(actions.grad).all() and actions.grad.abs().sum() > 0


@pytest.mark.slow
def test_compiled_batched_env_agrees_with_the_eager_one() -> None:
    """``compile=True`` (``torch.compile`` of a substep) gives the eager path's observations and
    rewards to round-off in float64, over steps with an auto-reset; compile errors surface here."""
    envs_ = [BatchedSagittalWalker(3, dtype=torch.float64, seed=5, substeps=4, compile=flag) for flag in (False, True)]
    outs = []
    for env in envs_:
        env.reset(seed=3)
        q = env.q.clone()
        q[2, 2] = 1.5  # env 2 terminates at its first step and is reset
        env.set_state(q, env.u)
        gen = torch.Generator().manual_seed(0)
        rows = []
        for _ in range(3):
            obs, reward, terminated, *_ = env.step(torch.rand(3, 6, generator=gen, dtype=torch.float64) * 2 - 1)
            rows.append((obs, reward, terminated))
        outs.append(rows)
    for (o1, r1, t1), (o2, r2, t2) in zip(*outs):
        torch.testing.assert_close(o2, o1, rtol=1e-9, atol=1e-9)
        torch.testing.assert_close(r2, r1, rtol=1e-9, atol=1e-9)
        assert t1.tolist() == t2.tolist()
    with pytest.raises(ValueError, match="compile must be a bool or a torch.compile mode"):
        BatchedSagittalWalker(2, compile=1)


def test_batched_env_compile_option_is_checked() -> None:
    """``compile`` takes a bool or a mode name; the recorded control interval needs CUDA."""
    with pytest.raises(ValueError, match="compile must be a bool or a torch.compile mode"):
        BatchedSagittalWalker(2, compile=1)
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="needs a CUDA device"):
            BatchedSagittalWalker(2, compile="step-graph")


def test_rendered_frame_has_the_right_shape_and_is_not_blank(env: SagittalWalkerEnv) -> None:
    env.reset(seed=0)
    q, u = env.state
    q[[3, 6]] = 0.3, -0.3  # legs apart, so that the left (far) leg is not hidden behind the right one
    env.set_state(q, u)
    frame = env.render()
    assert frame.shape == (400, 600, 3) and frame.dtype == np.uint8
    colours = {tuple(c) for c in frame.reshape(-1, 3)[::7]}
    assert len(colours) > 10, "frame is (nearly) one colour"
    red = (frame[..., 0] > 150) & (frame[..., 1] < 90) & (frame[..., 2] < 90)
    blue = (frame[..., 2] > 140) & (frame[..., 0] < 90)
    assert red.sum() > 50 and blue.sum() > 20, "right (red) and left (blue) legs must be drawn"
    with pytest.warns(UserWarning, match="without a render mode"):
        assert SagittalWalkerEnv().render() is None


def test_reset_from_an_initial_state(env: SagittalWalkerEnv) -> None:
    q = np.zeros(9)
    q[:3] = (5.0, 0.95, 0.1)
    q[3:] = (0.3, -0.2, 0.1, -0.1, -0.5, 0.0)
    u = np.full(9, 0.5)
    env.reset(seed=0, options={"initial_state": (q, u)})
    q1, u1 = env.state
    assert q1[0] == 0.0  # pelvis_tx starts at 0
    noise = env.config.reset_noise_scale
    assert np.abs(q1[1:] - q[1:]).max() <= noise and np.abs(u1 - u).max() <= noise
    with pytest.raises(ValueError, match="initial_state"):
        env.reset(options={"initial_state": (np.zeros(8), np.zeros(9))})
    with pytest.raises(ValueError, match="initial_state"):
        env.reset(options={"initial_state": "standing"})


def test_step_state_is_step_without_touching_the_environment() -> None:
    """The public one-step model (what model-based controllers linearise) equals ``step`` bit for bit
    and leaves the environment's state and random generator alone."""
    e = SagittalWalkerEnv()
    e.reset(seed=5)
    q0, u0 = e.state
    action = np.array([1.4, -0.3, 0.2, -2.0, 0.5, 0.0])  # out of range entries are clipped by both
    q1, u1, grf1 = e.step_state(q0, u0, action)
    assert np.array_equal(e.state[0], q0) and np.array_equal(e.state[1], u0)
    *_, info = e.step(action)
    np.testing.assert_array_equal(q1, e.state[0])
    np.testing.assert_array_equal(u1, e.state[1])
    np.testing.assert_array_equal(grf1, info["grf"])
    np.testing.assert_array_equal(info["torques"], np.clip(action, -1, 1) * e.tau_max)
    with pytest.raises(ValueError, match="action must be finite"):
        e.step_state(q0, u0, np.full(6, np.nan))
    with pytest.raises(ValueError, match=r"q and u must be finite arrays of shape \(9,\)"):
        e.step_state(q0[:8], u0, action)


def test_public_model_parameters_of_both_environments() -> None:
    e = SagittalWalkerEnv(substeps=25, max_torque={"knee": 2.0})
    m = e.body.segment_mass_total
    np.testing.assert_allclose(e.tau_max, m * np.array([3.0, 2.0, 3.0, 3.0, 2.0, 3.0]))
    np.testing.assert_array_equal(e.passive_parameters, task.passive_parameters())
    np.testing.assert_array_equal(e.body_vector, e.body.vector())
    np.testing.assert_array_equal(e.contact_vector, e.contact.vector())
    assert (e.dt, e.substeps, e.physics_dt, e.method) == (0.01, 25, 0.01 / 25, "semi_implicit_euler")
    assert e.contact.slip_velocity == 0.2 and e.standing_height == pytest.approx(0.92, abs=0.05)
    angles, rates = np.array([[2.1, 0.0, 0.0, 0.0, -2.5, 0.0]]), np.ones((1, 6))
    np.testing.assert_allclose(e.passive_torque(angles, rates)[0], [-1e4 * 0.01 - 1, -1, -1, -1, 1e4 * 0.01 - 1, -1])
    e.tau_max[:] = 0.0  # copies: the environment is unchanged
    assert e.tau_max.min() > 0
    batched = BatchedSagittalWalker(2, config=e.config)
    assert batched.config is e.config and batched.substeps == 25
    np.testing.assert_array_equal(batched.tau_max, e.tau_max)


def test_one_walker_config_for_both_environments_with_keyword_overrides() -> None:
    from envs.config import WalkerConfig

    cfg = WalkerConfig(target_speed=[1.0, 2.0], max_episode_steps=7)
    assert cfg.target_speed == (1.0, 2.0) and cfg.target_range == (1.0, 2.0)
    single = SagittalWalkerEnv(config=cfg, target_speed=1.3)
    assert single.config.target_speed == 1.3 and single.config.max_episode_steps == 7
    assert cfg.target_speed == (1.0, 2.0)  # the given config is not changed
    made = gymnasium.make(envs.ENV_ID, config=cfg, alive_bonus=0.5)
    assert made.unwrapped.config.alive_bonus == 0.5 and made.unwrapped.config.max_episode_steps == 7
    made.close()
    assert BatchedSagittalWalker(2, config=cfg, target_speed=1.5).config.target_range == (1.5, 1.5)
    with pytest.raises(ValueError, match="tracking_width must be > 0"):
        WalkerConfig(tracking_width=-1.0)
    with pytest.raises(ValueError, match="max_tilt must be a finite number"):
        WalkerConfig(max_tilt=float("nan"))
    with pytest.raises(TypeError, match=r"unknown environment argument\(s\) \['speed'\]"):
        SagittalWalkerEnv(speed=1.3)
    with pytest.raises(TypeError, match="config must be a WalkerConfig"):
        BatchedSagittalWalker(2, config={"target_speed": 1.3})
