"""The native vector environment: the same trajectories as N single environments, Gymnasium's
registration and auto-reset conventions, input checks."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import envs
from envs.config import WalkerConfig
from envs.sagittal_walker import SagittalWalkerEnv
from envs.vector import SagittalWalkerVectorEnv

#: Short episodes (truncation after 25 steps) and a target-speed range (a random draw per reset), so
#: that a few dozen random-action steps contain terminations (the hip below 95 % of its standing
#: height), truncations and auto-resets.
_KWARGS = {"target_speed": (0.8, 1.6), "max_episode_steps": 25, "min_height_fraction": 0.95}


def _actions(steps: int, n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.2, 1.2, (steps, n, 6))


def _single_rollouts(n: int, seed: int, actions: np.ndarray, next_step: bool, **kwargs) -> list[dict[str, np.ndarray]]:
    """What N single environments give for the vector env's actions: with NEXT_STEP, the step after
    an episode's end is a reset (reward 0, flags False) and its action is not used; with SAME_STEP
    the reset follows within the step."""
    out = []
    for j in range(n):
        env = SagittalWalkerEnv(**kwargs)
        obs, _ = env.reset(seed=seed + j)
        rows = {"obs": [obs], "reward": [], "terminated": [], "truncated": []}
        ended = False
        for a in actions[:, j]:
            if ended and next_step:
                obs, _ = env.reset()
                reward, terminated, truncated = 0.0, False, False
            else:
                obs, reward, terminated, truncated, _ = env.step(a)
                if (terminated or truncated) and not next_step:
                    obs, _ = env.reset()
            ended = terminated or truncated
            for key, value in (("obs", obs), ("reward", reward), ("terminated", terminated), ("truncated", truncated)):
                rows[key].append(value)
        out.append({key: np.array(v) for key, v in rows.items()})
    return out


def _vector_rollout(env: SagittalWalkerVectorEnv, seed: int, actions: np.ndarray) -> dict[str, np.ndarray]:
    obs, _ = env.reset(seed=seed)
    rows = {"obs": [obs], "reward": [], "terminated": [], "truncated": []}
    for a in actions:
        obs, reward, terminated, truncated, _ = env.step(a)
        for key, value in (("obs", obs), ("reward", reward), ("terminated", terminated), ("truncated", truncated)):
            rows[key].append(value)
    return {key: np.array(v) for key, v in rows.items()}


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_same_trajectories_as_single_envs_across_auto_resets(mode: AutoresetMode) -> None:
    n, steps, seed = 4, 70, 11
    actions = _actions(steps, n)
    vector = SagittalWalkerVectorEnv(n, autoreset_mode=mode, **_KWARGS)
    got = _vector_rollout(vector, seed, actions)
    expected = _single_rollouts(n, seed, actions, mode == AutoresetMode.NEXT_STEP, **_KWARGS)
    assert got["terminated"].any() and got["truncated"].any(), "the rollout must contain both kinds of episode end"
    for j in range(n):
        for key in ("obs", "reward", "terminated", "truncated"):
            np.testing.assert_array_equal(got[key][:, j], expected[j][key], err_msg=f"env {j}, {key}")


def test_disturbed_trajectories_match_and_parallel_equals_serial() -> None:
    """Noise, delay, a timed push, strength and body changes, gait shaping: the same numbers in both
    environments, and prange over walkers gives the serial result bit for bit."""
    kwargs = {
        **_KWARGS, "slip_weight": 1.0, "impact_weight": 0.2, "impact_threshold": 1.0, "phase_weight": 0.3,
        "max_phase_duration": 0.1,
        "disturbances": {
            "obs_noise": {"angle": 0.01, "grf": 0.05}, "obs_delay": 2, "push_force": 10.0, "push_time": 0.05,
            "push_duration": 0.05, "strength_change": -20.0, "mass_change": {"pelvis": 10.0}, "length_change": 3.0,
        },
    }
    n, steps, seed = 3, 40, 5
    actions = _actions(steps, n, seed=3)
    got = _vector_rollout(SagittalWalkerVectorEnv(n, parallel=True, **kwargs), seed, actions)
    serial = _vector_rollout(SagittalWalkerVectorEnv(n, parallel=False, **kwargs), seed, actions)
    expected = _single_rollouts(n, seed, actions, True, **kwargs)
    for key in got:
        np.testing.assert_array_equal(got[key], serial[key])
    for j in range(n):
        for key in ("obs", "reward", "terminated", "truncated"):
            np.testing.assert_array_equal(got[key][:, j], expected[j][key], err_msg=f"env {j}, {key}")


def test_next_step_auto_reset_conventions() -> None:
    env = SagittalWalkerVectorEnv(2, max_episode_steps=3)
    assert env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    env.reset(seed=0)
    zeros = np.zeros((2, 6))
    for _ in range(2):
        _, _, terminated, truncated, _ = env.step(zeros)
        assert not (terminated.any() or truncated.any())
    obs, reward, terminated, truncated, info = env.step(zeros)
    assert truncated.all() and not terminated.any() and info["_speed"].all()
    obs, reward, terminated, truncated, info = env.step(np.ones((2, 6)))  # the reset step: action ignored
    assert (reward == 0).all() and not (terminated.any() or truncated.any())
    assert not info["_speed"].any() and info["_target_speed"].all()
    np.testing.assert_allclose(obs[:, 0], env.standing_height, atol=0.01)  # standing again
    assert (env.state[0][:, 0] == 0).all()  # the new episode starts at x = 0


def test_same_step_auto_reset_gives_final_obs_and_final_info() -> None:
    env = SagittalWalkerVectorEnv(2, autoreset_mode="SameStep", max_episode_steps=2)
    env.reset(seed=0)
    env.step(np.zeros((2, 6)))
    obs, _, _, truncated, info = env.step(np.zeros((2, 6)))
    assert truncated.all() and info["_final_obs"].all()
    assert info["final_info"]["distance"].shape == (2,) and info["final_info"]["_distance"].all()
    assert not info["_distance"].any() and info["_target_speed"].all()
    assert np.abs(info["final_obs"] - obs).max() > 0  # the last observation differs from the new first one


def test_make_vec_with_the_vector_entry_point_and_the_registered_time_limit() -> None:
    assert gymnasium.spec(envs.ENV_ID).max_episode_steps == envs.MAX_EPISODE_STEPS == WalkerConfig().max_episode_steps
    vec = gymnasium.make_vec(envs.ENV_ID, num_envs=3, vectorization_mode="vector_entry_point", target_speed=1.4)
    assert isinstance(vec.unwrapped, SagittalWalkerVectorEnv) and vec.num_envs == 3
    assert vec.unwrapped.config.max_episode_steps == envs.MAX_EPISODE_STEPS  # passed on by make_vec
    obs, info = vec.reset(seed=1)
    assert obs.shape == (3, 22) and obs.dtype == np.float32 and (info["target_speed"] == 1.4).all()
    obs, reward, terminated, truncated, info = vec.step(vec.action_space.sample())
    assert reward.shape == (3,) and terminated.dtype == bool
    vec.close()
    short = gymnasium.make_vec(envs.ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=7)
    assert short.unwrapped.config.max_episode_steps == 7
    single = gymnasium.make(envs.ENV_ID)
    assert isinstance(single, gymnasium.wrappers.TimeLimit) and single.spec.max_episode_steps == 1000


def test_step_after_truncation_never_turns_into_termination() -> None:
    """Gymnasium's convention: the flags of the step that ended the episode stay, even if the body
    falls while it is stepped on."""
    env = SagittalWalkerEnv(max_episode_steps=2)
    env.reset(seed=0)
    env.step(np.zeros(6))
    assert env.step(np.zeros(6))[2:4] == (False, True)
    q, u = env.state
    q[2] = 1.5  # beyond max_tilt: this step alone would terminate
    env.set_state(q, u)
    with pytest.warns(UserWarning, match="after the episode ended"):
        _, reward, terminated, truncated, _ = env.step(np.zeros(6))
    assert (terminated, truncated, reward) == (False, True, 0.0)
    wrapped = gymnasium.make(envs.ENV_ID, max_episode_steps=2, config=WalkerConfig(max_episode_steps=2))
    wrapped.reset(seed=0)
    flags = [wrapped.step(np.zeros(6, dtype=np.float32))[2:4] for _ in range(2)]
    assert flags == [(False, False), (False, True)]


def test_bad_inputs_are_clear_value_errors() -> None:
    env = SagittalWalkerVectorEnv(3)
    env.reset(seed=0)
    actions = np.zeros((3, 6))
    actions[2, 1] = np.inf
    with pytest.raises(ValueError, match=r"environment\(s\) \[2\]"):
        env.step(actions)
    with pytest.raises(ValueError, match=r"actions must have shape \(3, 6\)"):
        env.step(np.zeros((2, 6)))
    q, u = env.state
    q[1, 4] = np.nan
    with pytest.raises(ValueError, match=r"must be finite; environment\(s\) \[1\]"):
        env.set_state(q, u)
    for bad in (np.nan, np.inf, -0.5, 40.0, [1.0, 2.0]):
        with pytest.raises(ValueError, match="target_speed"):
            env.reset(options={"target_speed": bad})
    with pytest.raises(ValueError, match=r"unknown reset option\(s\) \['push'\]"):
        env.reset(options={"push": 1})
    with pytest.raises(ValueError, match="autoreset_mode must be one of"):
        SagittalWalkerVectorEnv(2, autoreset_mode="sometimes")
    obs, info = env.reset(seed=0, options={"target_speed": [1.0, 1.2, 1.4]})
    np.testing.assert_array_equal(info["target_speed"], [1.0, 1.2, 1.4])
    mask = np.array([False, True, False])
    obs2, info2 = env.reset(seed=4, options={"reset_mask": mask, "target_speed": 2.0})
    np.testing.assert_array_equal(env.target_speed, [1.0, 2.0, 1.4])
    assert info2["_target_speed"].tolist() == [False, True, False]


def _reference_start(seed: int, env: SagittalWalkerVectorEnv, starts: np.ndarray | None, share: float) -> tuple:
    """The start of one episode drawn by hand in the documented order (envs.walker_state): target
    speed, [start-state choice], 8 coordinate then 9 speed noise values."""
    rng, _ = gymnasium.utils.seeding.np_random(seed)
    low, high = env.config.target_range
    target = rng.uniform(low, high)
    q, u = np.zeros(9), np.zeros(9)
    q[1] = env.standing_height
    if starts is not None and rng.uniform() < share:
        row = starts[int(rng.integers(len(starts)))]
        q, u = row[:9].copy(), row[9:].copy()
    q[0] = 0.0
    noise = env.config.reset_noise_scale
    q[1:] += rng.uniform(-noise, noise, 8)
    u = u + rng.uniform(-noise, noise, 9)
    return target, q, u


@pytest.mark.parametrize("with_starts", [False, True])
def test_resets_draw_in_the_documented_order_bit_for_bit(with_starts: bool) -> None:
    """The compiled reset writes exactly the states that the per-walker draws give (both environments
    share it, so the vector-equals-single tests alone could not see a change of the draws)."""
    starts = np.zeros((3, 18))
    starts[:, 1] = 0.9
    starts[:, 2:9] = np.linspace(-0.1, 0.1, 3)[:, None]
    starts[:, 9] = [0.5, 1.0, 1.5]
    kwargs = {**_KWARGS, "reset_states": starts, "reset_state_share": 0.5} if with_starts else _KWARGS
    n, seed = 8, 21
    env = SagittalWalkerVectorEnv(n, **kwargs)
    env.reset(seed=seed)
    q, u = env.state
    for j in range(n):
        target, q_ref, u_ref = _reference_start(seed + j, env, starts if with_starts else None, 0.5)
        assert env.target_speed[j] == target
        np.testing.assert_array_equal(q[j], q_ref, err_msg=f"env {j}")
        np.testing.assert_array_equal(u[j], u_ref, err_msg=f"env {j}")
    if with_starts:
        assert (q[:, 1] != env.standing_height).sum() > 0 and np.isin(u[:, 0].round(1), [0.5, 1.0, 1.5]).any()


@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
def test_info_arrays_are_each_steps_own_and_writable(mode: str) -> None:
    """Every info array and mask has its own memory (Gymnasium's ``_add_info`` writes into masks),
    and a later step changes none of them."""
    env = SagittalWalkerVectorEnv(3, autoreset_mode=mode, max_episode_steps=2)
    env.reset(seed=0)
    _, _, _, _, first = env.step(np.zeros((3, 6)))
    kept = {key: np.copy(v) for key, v in first.items() if isinstance(v, np.ndarray)}
    _, _, _, _, second = env.step(np.zeros((3, 6)))  # episodes end here (max_episode_steps=2)
    for key, value in kept.items():
        np.testing.assert_array_equal(first[key], value, err_msg=key)
    assert all(first[key].flags.writeable for key in kept)
    info = second if mode == "SameStep" else env.step(np.zeros((3, 6)))[4]  # SameStep: final_info; NextStep: the reset step
    masks = [key for key in info if key.startswith("_") and isinstance(info[key], np.ndarray)]
    before = {key: info[key].copy() for key in masks}
    info["_speed"][:] = ~info["_speed"]
    for key in masks:
        if key != "_speed":
            np.testing.assert_array_equal(info[key], before[key], err_msg=key)
    if mode == "SameStep":
        final = info["final_info"]
        assert final["_speed"].all() and not info["_distance"].any()
        final["_distance"][0] = False
        assert not info["_distance"][0] and final["_target_speed"].all()
        assert info["_speed"].all()  # the flipped mask, nowhere else


def test_passive_openmp_is_asked_for_only_before_openmp_loads(monkeypatch) -> None:
    """``prefer_passive_openmp`` sets ``OMP_WAIT_POLICY=passive`` only while OpenMP is not loaded
    and the user has not chosen a policy (libgomp reads it once, when it loads)."""
    import os

    from envs import openmp

    monkeypatch.delenv("OMP_WAIT_POLICY", raising=False)
    monkeypatch.setattr(openmp, "openmp_loaded", lambda: True)
    assert not openmp.prefer_passive_openmp() and "OMP_WAIT_POLICY" not in os.environ
    monkeypatch.setattr(openmp, "openmp_loaded", lambda: False)
    assert openmp.prefer_passive_openmp() and os.environ["OMP_WAIT_POLICY"] == "passive"
    monkeypatch.setenv("OMP_WAIT_POLICY", "active")
    assert not openmp.prefer_passive_openmp() and os.environ["OMP_WAIT_POLICY"] == "active"
