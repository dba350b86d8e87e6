"""Where a gait tracker starts its episodes: the start sample and its choice by a start-height test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from envs.sagittal_walker import SagittalWalkerEnv
from predictive.generator.closed_loop import (
    N_Z,
    GaitReference,
    GaitTracker,
    TrackerSettings,
    least_sensitive_start,
    start_costs,
)


def _standing_reference(env: SagittalWalkerEnv, n: int = 6, low: tuple[int, ...] = (2,)) -> GaitReference:
    """A 'cycle' of the standing pose, with the pelvis 0.4 m lower (below the fall height) at ``low``."""
    q = np.zeros((n, 9))
    q[:, 1] = env.standing_height
    q[list(low), 1] -= 0.4
    return GaitReference(q=q, u=np.zeros((n, 9)), action=np.zeros((n, 6)), speed=0.0, dt=env.dt)


def test_start_sample_sets_the_initial_state_and_the_clock_phase() -> None:
    rng = np.random.default_rng(2)
    ref = GaitReference(q=rng.normal(size=(8, 9)), u=rng.normal(size=(8, 9)), action=np.zeros((8, 6)), speed=1.0, dt=0.01)
    tracker = GaitTracker(ref, np.zeros((8, 6, N_Z)), phase="clock", start=3)
    q0, u0 = tracker.initial_state
    np.testing.assert_array_equal(q0, ref.q[3])
    np.testing.assert_array_equal(u0, ref.u[3])
    assert tracker.phase_of(ref.z[0], None) == 3 and tracker.phase_of(ref.z[0], 3) == 4
    assert GaitTracker(ref, np.zeros((8, 6, N_Z))).initial_state[0].tolist() == ref.q[0].tolist()  # default: sample 0
    with pytest.raises(ValueError, match="start must be a cycle sample"):
        GaitTracker(ref, np.zeros((8, 6, N_Z)), start=8)


def test_start_costs_mark_a_start_below_the_fall_height_and_grow_with_the_height_error() -> None:
    env = SagittalWalkerEnv()
    ref = _standing_reference(env)
    tracker = GaitTracker(ref, np.zeros((ref.n, 6, N_Z)), phase="state")
    costs = start_costs(env, tracker, height_error=0.05, every=2)
    assert costs.shape == (6,)
    assert math.isinf(costs[2])  # starts (and stays) below the fall height
    assert all(math.isinf(costs[s]) for s in (1, 3, 5))  # not tried with every=2
    # standing starts survive; the first step alone costs (0.05 m / 0.02 m)² in the height term
    assert np.isfinite(costs[[0, 4]]).all() and (costs[[0, 4]] >= (0.05 / 0.02) ** 2).all()
    assert start_costs(env, tracker, height_error=0.01, every=2)[0] < costs[0]
    assert least_sensitive_start(env, tracker, 0.05) in (0, 4)
    # every start falls: the cycle start is kept
    all_low = GaitTracker(_standing_reference(env, low=tuple(range(6))), np.zeros((6, 6, N_Z)))
    assert least_sensitive_start(env, all_low, 0.05) == 0
    with pytest.raises(ValueError, match="height_error must be > 0"):
        start_costs(env, tracker, height_error=0.0)


def test_build_chooses_the_start_and_settings_validate_it() -> None:
    env = SagittalWalkerEnv()
    ref = _standing_reference(env, low=(0, 1))
    assert GaitTracker.build(env, ref, start="cycle_start").start == 0
    assert GaitTracker.build(env, ref, start="least_sensitive").start in (2, 4)
    assert TrackerSettings().start == "least_sensitive" and TrackerSettings().start_height_error == 0.05
    with pytest.raises(ValueError, match="tracker.start must be one of"):
        TrackerSettings(start="middle")
    with pytest.raises(ValueError, match="start_height_error"):
        TrackerSettings(start_height_error=0.0)
    with pytest.raises(ValueError, match="start must be one of"):
        GaitTracker.build(env, ref, start="middle")


def test_open_loop_baseline_starts_where_its_tracker_starts() -> None:
    from predictive.experiments.robustness import OpenLoop

    rng = np.random.default_rng(3)
    ref = GaitReference(q=rng.normal(size=(8, 9)), u=rng.normal(size=(8, 9)), action=np.zeros((8, 6)), speed=1.0, dt=0.01)

    class Source:
        def controller_for(self, speed, body=None):
            return GaitTracker(ref, rng.normal(size=(8, 6, N_Z)), start=5)

    baseline = OpenLoop(Source()).controller_for(1.0)
    assert baseline.start == 5 and baseline.phase == "clock" and not baseline.gains.any()
    np.testing.assert_array_equal(baseline.initial_state[0], ref.q[5])
