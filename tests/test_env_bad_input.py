"""Non-finite actions, states and target speeds, and steps after the end of an episode, follow Gymnasium's
conventions (a clear error; a warning, sticky flags and zero reward)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import torch

from envs import BatchedSagittalWalker, SagittalWalkerEnv


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_action_is_a_value_error_naming_it(bad: float) -> None:
    env = SagittalWalkerEnv()
    env.reset(seed=0)
    action = np.zeros(6, dtype=np.float32)
    action[2] = bad
    q_before = env.state[0].copy()
    with pytest.raises(ValueError, match=r"action must be finite, got \[0\.0, 0\.0, (nan|inf|-inf), 0\.0"):
        env.step(action)
    np.testing.assert_array_equal(env.state[0], q_before)  # nothing advanced
    _, reward, *_ = env.step(np.zeros(6, dtype=np.float32))
    assert np.isfinite(reward)


def test_batched_env_rejects_non_finite_actions_naming_the_rows() -> None:
    env = BatchedSagittalWalker(3, device="cpu")
    env.reset(seed=0)
    actions = torch.zeros(3, 6, dtype=env.dtype)
    actions[1, 4] = float("nan")
    with pytest.raises(ValueError, match=r"environment\(s\) \[1\] got \[0\.0, 0\.0, 0\.0, 0\.0, nan, 0\.0\]"):
        env.step(actions)


def _fall(env: SagittalWalkerEnv) -> None:
    q, u = env.state
    q[2] = 1.2  # trunk far beyond max_tilt
    env.set_state(q, u)


def test_step_after_termination_warns_once_and_stays_terminated() -> None:
    env = SagittalWalkerEnv()
    env.reset(seed=0)
    _fall(env)
    assert env.step(np.zeros(6, dtype=np.float32))[2]
    q, u = env.state
    q[2] = 0.0  # the state looks healthy again: terminated must not turn False
    env.set_state(q, u)
    with pytest.warns(UserWarning, match=r"after the episode ended .* call reset\(\)"):
        _, reward, terminated, truncated, info = env.step(np.zeros(6, dtype=np.float32))
    assert terminated and not truncated and reward == 0.0 and info["reward_alive"] == 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # warned once per episode
        assert env.step(np.zeros(6, dtype=np.float32))[2]
    env.reset(seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, reward, terminated, _, _ = env.step(np.zeros(6, dtype=np.float32))
    assert not terminated and reward != 0.0


def test_step_after_truncation_stays_truncated() -> None:
    env = SagittalWalkerEnv(max_episode_steps=2)
    env.reset(seed=0)
    assert [env.step(np.zeros(6))[3] for _ in range(2)] == [False, True]
    with pytest.warns(UserWarning, match="after the episode ended"):
        _, reward, terminated, truncated, _ = env.step(np.zeros(6))
    assert truncated and not terminated and reward == 0.0


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -1.0, 40.0])
def test_batched_env_checks_target_speeds_like_the_single_env(bad: float) -> None:
    env = BatchedSagittalWalker(3, device="cpu", dtype=torch.float64)
    with pytest.raises(ValueError, match="target_speed"):
        env.reset(options={"target_speed": bad})
    with pytest.raises(ValueError, match=r"target_speed.*row\(s\) \[1\]"):
        env.reset(options={"target_speed": torch.tensor([1.0, bad, 1.2], dtype=torch.float64)})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="target_speed"):
        env.set_state(env.q, env.u, target_speed=bad)


def test_batched_env_rejects_non_finite_states_naming_the_rows() -> None:
    env = BatchedSagittalWalker(3, device="cpu", dtype=torch.float64)
    env.reset(seed=0)
    q = env.q.clone()
    q[2, 5] = float("nan")
    with pytest.raises(ValueError, match=r"q and u must be finite; environment\(s\) \[2\]"):
        env.set_state(q, env.u)
    u = env.u.clone()
    u[0, 0] = float("inf")
    with pytest.raises(ValueError, match=r"environment\(s\) \[0\]"):
        env.set_state(env.q, u)
    assert torch.isfinite(env.q).all()  # nothing was changed
