"""Closed-loop deployment of gait cycles (feedforward + periodic LQR) in the environment."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from envs.sagittal_walker import SagittalWalkerEnv
from predictive.generator.closed_loop import (
    N_Z,
    GaitReference,
    GaitTracker,
    LQRWeights,
    periodic_lqr,
    resample_cycle,
    step_map,
)


def test_periodic_lqr_of_a_constant_system_is_the_dare_gain() -> None:
    rng = np.random.default_rng(0)
    A = np.eye(4) + 0.1 * rng.normal(size=(4, 4))
    B = rng.normal(size=(4, 2))
    Q, R = np.eye(4), 0.5 * np.eye(2)
    K = periodic_lqr(np.repeat(A[None], 7, 0), np.repeat(B[None], 7, 0), Q, R)
    P = scipy.linalg.solve_discrete_are(A, B, Q, R)
    K_dare = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
    np.testing.assert_allclose(K, np.repeat(K_dare[None], 7, 0), atol=1e-6)


def test_step_map_is_the_environment_step() -> None:
    env = SagittalWalkerEnv()
    obs, _ = env.reset(seed=3)
    q, u = env.state
    z = np.concatenate([q[1:], u])
    action = np.array([0.3, -0.2, 0.1, -0.4, 0.2, 0.0])
    predicted = step_map(env, z, action)
    obs, *_ = env.step(action.astype(np.float32))
    q1, u1 = env.state
    np.testing.assert_allclose(predicted, np.concatenate([q1[1:], u1]), atol=1e-12)
    np.testing.assert_allclose(obs[:N_Z], predicted, atol=1e-5)  # float32 observation


def _circle_cycle(speed: float = 1.0, duration: float = 1.0, n: int = 50) -> tuple[np.ndarray, ...]:
    t = np.arange(n) * duration / n
    q = np.zeros((n, 9))
    q[:, 0] = speed * t + 0.01 * np.sin(4 * np.pi * t / duration)
    q[:, 1] = 0.9
    q[:, 3] = 0.3 * np.sin(2 * np.pi * t / duration)
    tau = np.zeros((n, 6))
    tau[:, 0] = 10 * np.cos(2 * np.pi * t / duration)
    return t, q, tau


def test_resampled_reference_is_periodic_with_its_speed_and_derivatives() -> None:
    env = SagittalWalkerEnv()
    t, q, tau = _circle_cycle(duration=1.003)
    ref = resample_cycle(t, q, tau, 1.0, 1.003, env)
    assert ref.n == 100 and ref.period == pytest.approx(1.0)
    assert ref.u[:, 0].mean() == pytest.approx(1.0, abs=1e-9)  # average speed kept
    np.testing.assert_allclose(ref.q[:, 3], 0.3 * np.sin(2 * np.pi * np.arange(100) / 100), atol=1e-3)
    np.testing.assert_allclose(ref.u[:, 3], 0.3 * 2 * np.pi * np.cos(2 * np.pi * np.arange(100) / 100), atol=2e-2)
    # feedforward: hip torque at the interval midpoints minus the passive damping, over τ_max
    mid = (np.arange(100) + 0.5) / 100
    expected = (10 * np.cos(2 * np.pi * mid) + 1.0 * 0.3 * 2 * np.pi * np.cos(2 * np.pi * mid)) / env.tau_max[0]
    np.testing.assert_allclose(ref.action[:, 0], expected, atol=2e-3)


def test_tracker_applies_feedforward_on_the_reference_and_feedback_off_it() -> None:
    rng = np.random.default_rng(1)
    n = 10
    ref = GaitReference(q=rng.normal(size=(n, 9)), u=rng.normal(size=(n, 9)), action=rng.uniform(-0.5, 0.5, (n, 6)), speed=1.0, dt=0.01)
    K = rng.normal(size=(n, 6, N_Z)) * 0.1
    tracker = GaitTracker(ref, K)
    for i in range(n + 3):  # wraps around the cycle
        obs = np.concatenate([ref.z[i % n], np.zeros(5)]).astype(np.float32)
        np.testing.assert_allclose(tracker(obs), np.clip(ref.action[i % n], -1, 1), atol=1e-5)
    tracker.reset()
    obs = np.concatenate([ref.z[0] + 0.01, np.zeros(5)])
    np.testing.assert_allclose(tracker(obs), np.clip(ref.action[0] - K[0] @ np.full(N_Z, 0.01), -1, 1), atol=1e-6)
    with pytest.raises(ValueError, match="gains must have shape"):
        GaitTracker(ref, K[:, :5])


@pytest.mark.slow
def test_lqr_tracks_a_small_ocp_walking_cycle_for_two_seconds() -> None:
    """A coarse predictive OCP gait (fast to solve) replayed closed loop does not fall in 2 s."""
    from predictive.ocp.collocation import solve_predictive

    env = SagittalWalkerEnv(target_speed=1.3, max_episode_steps=200)
    sol = solve_predictive(1.3, env.body, contact=env.contact, n_nodes=100)
    ref = resample_cycle(sol.time, sol.q, sol.tau, sol.speed, sol.duration, env)
    tracker = GaitTracker.build(env, ref, LQRWeights())
    obs, _ = env.reset(seed=0, options={"initial_state": tracker.initial_state()})
    tracker.reset()
    terminated = truncated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, info = env.step(tracker(obs))
    assert truncated and not terminated
    assert info["distance"] == pytest.approx(2.0 * 1.3, rel=0.1)
