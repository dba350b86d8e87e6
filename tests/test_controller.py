"""The controller protocol: one controller object runs any number of episodes."""

from __future__ import annotations

import numpy as np
import pytest

from agents.rollout import run_episode
from envs.sagittal_walker import SagittalWalkerEnv
from predictive.controller import Controller, ControllerSource, run_controller_episode, start_options
from predictive.generator.closed_loop import TrackerSettings
from predictive.generator.controllers import GeneratorControllers
from predictive.generator.gait_generator import GeneratorConfig, GeneratorTrainer
from sspinn.model.body import BodyParameters


@pytest.fixture(scope="module")
def source(tmp_path_factory) -> GeneratorControllers:
    out = tmp_path_factory.mktemp("gen")
    cfg = GeneratorConfig(harmonics=3, hidden=16, layers=1, points=8, batch_size=4, warmup_steps=20, steps=1, snapshot_every=0)
    GeneratorTrainer(cfg, out).fit()
    return GeneratorControllers.from_file(out / "generator.pt")


@pytest.mark.parametrize("phase", ["state", "clock"])
def test_reusing_a_controller_gives_the_episode_of_a_fresh_one(source, phase) -> None:
    source.tracker = TrackerSettings(phase=phase)
    used = source.controller_for(1.3)
    assert isinstance(used, Controller) and isinstance(source, ControllerSource)
    env = SagittalWalkerEnv(target_speed=1.3, max_episode_steps=80)
    first = run_controller_episode(used, env, seed=1, record=True)
    again = run_controller_episode(used, env, seed=2, record=True)
    fresh = run_controller_episode(source.controller_for(1.3), env, seed=2, record=True)
    assert again.steps == fresh.steps > 5
    np.testing.assert_array_equal(again.actions, fresh.actions)
    np.testing.assert_array_equal(again.states, fresh.states)
    assert first.states[0, 0] == 0.0 and not np.array_equal(first.states[:5], again.states[:5])
    # agents.rollout.run_episode drives the same used controller through predict: the same episode
    rollout = run_episode(used, env, seed=2, reset_options=start_options(used))
    assert rollout.steps == fresh.steps
    np.testing.assert_array_equal(rollout.trajectory.q, fresh.states[:, :9])
    np.testing.assert_array_equal(rollout.trajectory.tau[:-1], fresh.actions * env.tau_max)


def test_controller_for_another_body_tracks_that_body(source) -> None:
    body = BodyParameters.from_anthropometry(1.6, 55.0)
    tracker = source.controller_for(1.1, body)
    assert tracker.reference.speed == pytest.approx(1.1)
    assert tracker.initial_state[0][1] == pytest.approx(tracker.info["plan"].q[0, 1])
    assert tracker.info["plan"].body_parameters["mass"] == pytest.approx(body.mass)
    assert tracker.info["plan_time_s"] > 0 and tracker.info["lqr_time_s"] > 0


def test_start_options_merge_the_controllers_start_and_the_callers_options() -> None:
    class Standing:
        initial_state = None

        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            return np.zeros(6, np.float32), state

    assert start_options(Standing()) is None
    assert start_options(Standing(), {"target_speed": 2.0}) == {"target_speed": 2.0}
    env = SagittalWalkerEnv(max_episode_steps=3)
    assert run_controller_episode(Standing(), env, seed=0).steps == 3
