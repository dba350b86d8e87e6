"""Closed-loop deployment of gait cycles (feedforward + periodic LQR) in the environment."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from envs.sagittal_walker import SagittalWalkerEnv
from predictive.controller import run_controller_episode
from predictive.generator.closed_loop import (
    N_Z,
    GaitReference,
    GaitTracker,
    LQRWeights,
    TrackerSettings,
    linearise,
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


def _random_tracker(phase: str = "clock", n: int = 10) -> GaitTracker:
    rng = np.random.default_rng(1)
    ref = GaitReference(q=rng.normal(size=(n, 9)), u=rng.normal(size=(n, 9)), action=rng.uniform(-0.5, 0.5, (n, 6)), speed=1.0, dt=0.01)
    return GaitTracker(ref, rng.normal(size=(n, 6, N_Z)) * 0.1, phase=phase)


def test_tracker_applies_feedforward_on_the_reference_and_feedback_off_it() -> None:
    tracker = _random_tracker()
    ref, K, n = tracker.reference, tracker.gains, tracker.reference.n
    state = None
    for i in range(n + 3):  # wraps around the cycle
        obs = np.concatenate([ref.z[i % n], np.zeros(5)]).astype(np.float32)
        action, state = tracker.predict(obs, state, episode_start=i == 0)
        np.testing.assert_allclose(action, np.clip(ref.action[i % n], -1, 1), atol=1e-5)
        assert state.tolist() == [i % n]
    obs = np.concatenate([ref.z[0] + 0.01, np.zeros(5)])
    action, state = tracker.predict(obs, state, episode_start=True)  # a new episode: phase 0 again
    np.testing.assert_allclose(action, np.clip(ref.action[0] - K[0] @ np.full(N_Z, 0.01), -1, 1), atol=1e-6)
    with pytest.raises(ValueError, match="gains must have shape"):
        GaitTracker(ref, K[:, :5])
    with pytest.raises(ValueError, match="phase must be one of"):
        GaitTracker(ref, K, phase="steps")


def test_state_phase_finds_the_cycle_sample_and_resynchronises_after_a_jump() -> None:
    tracker = _random_tracker("state", n=40)
    ref = tracker.reference
    for i in (0, 7, 39):
        assert tracker.phase_of(ref.z[i] + 1e-4, None) == i  # episode start: the whole cycle
    # one step on, the estimate advances one sample; a state 15 samples ahead is followed at once
    assert tracker.phase_of(ref.z[8], 7) == 8
    assert tracker.phase_of(ref.z[22], 7) == 22
    # a strong prior keeps the phase near the previous one + 1
    tracker.phase_prior = 1e9
    assert tracker.phase_of(ref.z[22], 7) == 8


def test_predict_on_a_batch_matches_single_observations() -> None:
    tracker = _random_tracker("state", n=30)
    ref = tracker.reference
    obs = np.concatenate([ref.z[[3, 17, 25]] + 0.01, np.zeros((3, 5))], axis=1)
    actions, phases = tracker.predict(obs)
    assert actions.shape == (3, 6) and phases.tolist() == [3, 17, 25]
    for k in range(3):
        a, p = tracker.predict(obs[k])
        np.testing.assert_array_equal(a, actions[k])
    # only the environment whose episode starts forgets its phase
    _, after = tracker.predict(obs, phases, episode_start=np.array([False, True, False]))
    assert after[1] == 17
    with pytest.raises(ValueError, match="episode_start has 2 entries"):
        tracker.predict(obs, phases, episode_start=[True, False])


def test_tracker_settings_schedule_interpolates_log_linearly_over_speed() -> None:
    s = TrackerSettings(lqr=[{"speed": 3.0, "weights": {"action": 0.4}}, {"speed": 1.0, "weights": {"action": 0.1}}])
    assert s.lqr[0].speed == 1.0  # sorted
    assert s.weights_at(0.5).action == pytest.approx(0.1) and s.weights_at(5.0).action == pytest.approx(0.4)
    assert s.weights_at(3**0.5).action == pytest.approx(0.2)  # halfway in log speed: geometric mean
    assert s.weights_at(2.0).height == pytest.approx(LQRWeights().height)
    with pytest.raises(ValueError, match="phase must be one of"):
        TrackerSettings(phase="steps")
    with pytest.raises(ValueError, match="at one speed at least"):
        TrackerSettings(lqr=[])


@pytest.mark.slow
def test_lqr_tracks_a_small_ocp_walking_cycle_for_two_seconds() -> None:
    """A coarse predictive OCP gait (fast to solve) replayed closed loop does not fall in 2 s, also
    when the episode starts elsewhere on the cycle (state-based phase)."""
    from predictive.ocp.collocation import solve_predictive

    env = SagittalWalkerEnv(target_speed=1.3, max_episode_steps=200)
    sol = solve_predictive(1.3, env.body, contact=env.contact, n_nodes=100)
    ref = resample_cycle(sol.time, sol.q, sol.tau, sol.speed, sol.duration, env)
    A, B = linearise(env, ref)
    Q, R = LQRWeights().matrices()
    gains, metric = periodic_lqr(A, B, Q, R), np.sqrt(np.diag(Q))
    tracker = GaitTracker(ref, gains, metric, phase="state")
    episode = run_controller_episode(tracker, env, seed=0)
    assert episode.steps == 200 and not episode.fell
    assert episode.distance_m == pytest.approx(2.0 * 1.3, rel=0.1)
    # started a third of a cycle later on the cycle: the state-based phase re-synchronises, a clock does not
    later = {"initial_state": (ref.q[ref.n // 3], ref.u[ref.n // 3])}
    assert not run_controller_episode(tracker, env, seed=0, reset_options=later).fell
    assert run_controller_episode(GaitTracker(ref, gains, metric, phase="clock"), env, seed=0, reset_options=later).fell
