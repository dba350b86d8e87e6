"""The gait-prior training reward (agents.gait_prior): its value on known states, the wrapper's
reward and info, the shipped reference strides and configurations, and a tiny training run with it."""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents.config import config_from_dict, load_config  # noqa: E402
from agents.gait_prior import GaitPrior, GaitPriorReward  # noqa: E402
from agents.train import train  # noqa: E402
from agents.vec_env import WalkerVecEnv  # noqa: E402
from envs.task import observation  # noqa: E402
from sspinn.errors import UserError  # noqa: E402
from sspinn.model.trajectory import Trajectory  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
WALK = ROOT / "configs" / "agents" / "gaits" / "walk_1.3.npz"
RUN = ROOT / "configs" / "agents" / "gaits" / "run_3.5.npz"


def _obs(q: np.ndarray, u: np.ndarray) -> np.ndarray:
    return observation(q, u, np.zeros((len(q), 4)), np.full(len(q), 1.3), 700.0)


def _mirrored(x: np.ndarray) -> np.ndarray:
    m = x.copy()
    m[:, 3:6], m[:, 6:9] = x[:, 6:9], x[:, 3:6]
    return m


def test_prior_is_its_weight_on_the_stride_and_its_mirror_and_low_off_it() -> None:
    prior = GaitPrior.from_file(WALK, weight=2.0, angle_scale=0.2, speed_scale=3.0)
    t = Trajectory.load(WALK)
    np.testing.assert_allclose(prior.reward(_obs(t.q, t.u)), 2.0)
    # the stride holds both legs: the left/right mirror of a sample is (close to) another sample
    assert prior.reward(_obs(_mirrored(t.q), _mirrored(t.u))).min() > 1.9
    frozen_q, frozen_u = t.q.copy(), t.u.copy()
    frozen_q[:, 6:9] = t.q[:, 6:9].mean(axis=0)
    frozen_u[:, 6:9] = 0.0
    assert prior.reward(_obs(frozen_q, frozen_u)).mean() < 1.3  # < 65 % of the weight
    standing = np.zeros((1, 9))
    standing[0, 1] = 0.93
    assert prior.reward(_obs(standing, np.zeros((1, 9))))[0] < 0.9
    # the running stride is far from the walking one
    run = GaitPrior.from_file(RUN, weight=1.0, angle_scale=0.2, speed_scale=3.0)
    assert run.reward(_obs(t.q, t.u)).mean() < 0.25


def test_bad_prior_settings_are_user_errors(tmp_path: Path) -> None:
    with pytest.raises(UserError, match="angle_scale must be a positive number"):
        GaitPrior.from_file(WALK, weight=1.0, angle_scale=0.0, speed_scale=1.5)
    with pytest.raises(UserError, match="missing.npz"):
        GaitPrior.from_file(tmp_path / "missing.npz", weight=1.0, angle_scale=0.1, speed_scale=1.5)


def test_wrapper_adds_the_prior_of_the_resulting_observation() -> None:
    prior = GaitPrior.from_file(WALK, weight=1.0, angle_scale=0.1, speed_scale=1.5)
    plain, wrapped = WalkerVecEnv(3, target_speed=1.3), GaitPriorReward(WalkerVecEnv(3, target_speed=1.3), prior)
    plain.seed(5)
    wrapped.seed(5)
    np.testing.assert_array_equal(plain.reset(), wrapped.reset())
    actions = np.random.default_rng(0).uniform(-1, 1, (60, 3, 6)).astype(np.float32)
    ended = 0
    for a in actions:
        obs0, r0, d0, i0 = plain.step(a)
        obs1, r1, d1, i1 = wrapped.step(a)
        np.testing.assert_array_equal(obs0, obs1)
        np.testing.assert_array_equal(d0, d1)
        seen = np.array([i0[k]["terminal_observation"] if d0[k] else obs0[k] for k in range(3)])
        np.testing.assert_allclose(r1 - r0, prior.reward(seen), rtol=1e-5, atol=1e-6)
        assert [info["reward_prior"] for info in i1] == pytest.approx(prior.reward(seen).tolist())
        ended += int(d0.sum())
    assert ended > 0  # random actions end episodes: the terminal-observation branch ran


@pytest.mark.parametrize("name, speed", [("ppo_prior_walk", 1.3), ("ppo_prior_run", 3.5), ("ppo_clock_walk", 1.3),
                                         ("ppo_clock_run", 3.5), ("sac_clock_walk", 1.3)])
def test_shipped_prior_configs_load(name: str, speed: float) -> None:
    config = load_config(ROOT / "configs" / "agents" / f"{name}.yaml")
    assert config.env.target_speed == speed
    assert config.prior.gait is not None and (ROOT / config.prior.gait).is_file()


def test_training_with_a_prior_runs(tmp_path: Path) -> None:
    config = config_from_dict({
        "algo": "ppo", "seed": 1, "total_timesteps": 128,
        "env": {"n_envs": 2, "kwargs": {"target_speed": 1.3, "max_episode_steps": 50}},
        "prior": {"gait": str(WALK), "weight": 1.0},
        "policy": {"net_arch": [16]},
        "hyperparameters": {"n_steps": 64, "batch_size": 32, "n_epochs": 1},
        "logging": {"checkpoint_freq": 10_000, "eval_freq": 0, "tensorboard": False},
    })
    model = train(config, tmp_path / "run")
    assert model.num_timesteps >= 128
    assert (tmp_path / "run" / "final_model.zip").is_file()


def test_foot_balance_term_follows_the_loaded_shares() -> None:
    prior = GaitPrior.from_file(WALK, weight=1.0, angle_scale=0.2, speed_scale=3.0, symmetry_weight=2.0,
                                symmetry_time=0.5)
    env = GaitPriorReward(WalkerVecEnv(2, target_speed=1.3), prior)
    env.seed(3)
    env.reset()
    share = np.ones((2, 2))
    actions = np.random.default_rng(1).uniform(-1, 1, (80, 2, 6)).astype(np.float32)
    penalties = []
    for a in actions:
        obs, _, dones, infos = env.step(a)
        seen = np.array([infos[k]["terminal_observation"] if dones[k] else obs[k] for k in range(2)])
        share += 0.01 / 0.5 * ((seen[:, [18, 20]] > 0.1) - share)  # grf_y_r, grf_y_l in BW
        balance = 2.0 * (1.0 - np.abs(share[:, 0] - share[:, 1]))
        got = np.array([info["reward_prior"] for info in infos]) - prior.reward(seen)
        np.testing.assert_allclose(got, balance, atol=1e-9)
        penalties.append(balance.min())
        share[dones] = 1.0
    assert min(penalties) < 1.9  # random actions unload the feet unequally at some point
    with pytest.raises(UserError, match="symmetry_weight must be ≥ 0"):
        GaitPrior.from_file(WALK, weight=1.0, angle_scale=0.2, speed_scale=3.0, symmetry_weight=-1.0)


class _Replay(gymnasium.Env):
    """Replays fixed observations (a reference stride, possibly altered) with zero reward."""

    observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (22,), np.float32)
    action_space = gymnasium.spaces.Box(-1.0, 1.0, (6,), np.float32)

    def __init__(self, observations: np.ndarray) -> None:
        self.observations, self.k = observations.astype(np.float32), 0

    def reset(self, *, seed=None, options=None):  # type: ignore[no-untyped-def]
        self.k = 0
        return self.observations[0], {}

    def step(self, action):  # type: ignore[no-untyped-def]
        self.k += 1
        return self.observations[self.k % len(self.observations)], 0.0, False, False, {}


def test_mirror_term_is_zero_on_the_stride_and_charges_a_frozen_leg() -> None:
    from stable_baselines3.common.vec_env import DummyVecEnv

    t = Trajectory.load(WALK)
    prior = GaitPrior.from_file(WALK, weight=1.0, angle_scale=0.2, speed_scale=3.0, mirror_weight=1.0)
    assert prior.half_stride_steps == round(len(t.q) / 2)
    frozen_q = t.q.copy()
    frozen_q[:, 6:9] = t.q[:, 6:9].mean(axis=0)
    penalties = {}
    for name, q in (("stride", t.q), ("frozen", frozen_q)):
        obs = _obs(q, t.u)
        env = GaitPriorReward(DummyVecEnv([lambda obs=obs: _Replay(obs)]), prior)
        env.reset()
        added = []
        for _ in range(3 * len(obs)):
            o, _, _, infos = env.step(np.zeros((1, 6), np.float32))
            added.append(infos[0]["reward_prior"] - prior.reward(o)[0])
        added = np.array(added)
        assert np.all(added[: prior.half_stride_steps - 1] == 0.0)  # no history yet
        penalties[name] = 1.0 - added[prior.half_stride_steps:].mean()  # the bonus' shortfall
    assert penalties["stride"] < 0.5  # the (1 − exp(−d_same)) factor: the legs differ by ~1.5 σ on average
    assert penalties["frozen"] > penalties["stride"] + 0.2


def test_reset_states_start_a_share_of_episodes_on_the_stride_in_both_environments() -> None:
    import gymnasium as gym

    from envs.vector import SagittalWalkerVectorEnv

    t = Trajectory.load(WALK)
    states = np.concatenate([t.q, t.u], axis=1)
    single = gym.make("sspinn/SagittalWalker-v0", reset_states=states, reset_state_share=0.5).unwrapped
    vector = SagittalWalkerVectorEnv(1, reset_states=states, reset_state_share=0.5)
    on_stride = 0
    for seed in range(40):
        obs, _ = single.reset(seed=seed)
        vobs, _ = vector.reset(seed=seed)
        np.testing.assert_array_equal(obs, vobs[0])  # the same draws in both environments
        q = single.state[0]
        on_stride += int(np.min(np.abs(t.q[:, 3:] - q[3:]).max(axis=1)) < 0.02)
    assert 10 <= on_stride <= 30  # about half, within a wide binomial band
    with pytest.raises(ValueError, match="reset_state_share > 0 needs reset_states"):
        gym.make("sspinn/SagittalWalker-v0", reset_state_share=0.5)
    with pytest.raises(ValueError, match="reset_states must be a finite"):
        gym.make("sspinn/SagittalWalker-v0", reset_states=np.zeros((3, 5)), reset_state_share=0.5)



def test_clock_wrapper_appends_the_clock_and_rewards_the_clock_sample() -> None:
    prior = GaitPrior.from_file(WALK, weight=1.0, angle_scale=0.2, speed_scale=3.0, clock=True)
    k = prior.period_steps
    plain, wrapped = WalkerVecEnv(3, target_speed=1.3), GaitPriorReward(WalkerVecEnv(3, target_speed=1.3), prior)
    assert wrapped.observation_space.shape == (24,)
    plain.seed(5)
    wrapped.seed(5)
    raw = plain.reset()
    obs = wrapped.reset()
    phase = prior.start_phase(raw)
    np.testing.assert_array_equal(obs[:, :22], raw)
    np.testing.assert_allclose(obs[:, 22:], np.stack([np.sin(2 * np.pi * phase / k), np.cos(2 * np.pi * phase / k)], 1),
                               atol=1e-6)
    actions = np.random.default_rng(0).uniform(-1, 1, (60, 3, 6)).astype(np.float32)
    ended = 0
    for a in actions:
        obs0, r0, d0, i0 = plain.step(a)
        obs1, r1, d1, i1 = wrapped.step(a)
        clock = (phase + 1) % k
        seen = np.array([i0[j]["terminal_observation"] if d0[j] else obs0[j] for j in range(3)])
        np.testing.assert_allclose(r1 - r0, prior.reward(seen, clock), rtol=1e-5, atol=1e-6)
        for j in np.flatnonzero(d0):  # the final observation carries the clock of its step
            np.testing.assert_allclose(i1[j]["terminal_observation"], prior.policy_input(seen[j:j + 1], clock[j:j + 1])[0])
        clock[d0] = prior.start_phase(obs0[d0]) if d0.any() else clock[d0]  # a new episode restarts its clock
        np.testing.assert_allclose(obs1, prior.policy_input(obs0, clock))
        phase = clock
        ended += int(d0.sum())
    assert ended > 0
    # on the stride, the clock's sample is the right one and the nearest one
    t = Trajectory.load(WALK)
    np.testing.assert_array_equal(prior.start_phase(_obs(t.q, t.u)), np.arange(k))
    np.testing.assert_allclose(prior.reward(_obs(t.q, t.u), np.arange(k)), 1.0)
    # half a stride off the clock, the same states score low though each is near another sample
    assert prior.reward(_obs(t.q, t.u), np.arange(k) + k // 2).mean() < 0.3


def test_a_clock_agent_restarts_its_clock_with_every_episode(tmp_path: Path) -> None:
    from agents.checkpoints import load_agent
    from agents.rollout import run_episode

    config = config_from_dict({
        "algo": "ppo", "seed": 1, "total_timesteps": 128,
        "env": {"n_envs": 2, "kwargs": {"target_speed": 1.3, "max_episode_steps": 40}},
        "prior": {"gait": str(WALK), "weight": 1.0, "clock": True, "start_share": 0.5},
        "policy": {"net_arch": [16]},
        "hyperparameters": {"n_steps": 64, "batch_size": 32, "n_epochs": 1},
        "logging": {"checkpoint_freq": 10_000, "eval_freq": 0, "tensorboard": False},
    })
    train(config, tmp_path / "run")
    agent = load_agent(tmp_path / "run" / "final_model.zip")
    assert agent.prior is not None and agent.prior.clock
    with pytest.raises(TypeError, match="predict"):
        agent(np.zeros(22, np.float32))
    env = gymnasium.make("sspinn/SagittalWalker-v0", target_speed=1.3, max_episode_steps=40)
    first = run_episode(agent, env, seed=3)
    run_episode(agent, env, seed=4)  # the same agent, another episode in between
    again = run_episode(agent, env, seed=3)
    fresh = run_episode(load_agent(tmp_path / "run" / "final_model.zip"), env, seed=3)
    assert first.steps == again.steps == fresh.steps
    np.testing.assert_array_equal(first.trajectory.q, again.trajectory.q)
    np.testing.assert_array_equal(first.trajectory.q, fresh.trajectory.q)
    # the clock is the state: it advances one sample per step and restarts at episode_start
    obs, _ = env.reset(seed=3)
    _, s0 = agent.predict(obs)
    _, s1 = agent.predict(obs, s0, episode_start=False)
    _, s2 = agent.predict(obs, s1, episode_start=True)
    assert s1[0] == (s0[0] + 1) % agent.prior.period_steps and s2[0] == s0[0]


def test_feedforward_adds_the_reference_torques_at_the_clock_sample() -> None:
    env = gymnasium.make("sspinn/SagittalWalker-v0", target_speed=1.3)
    cfg = config_from_dict({"algo": "ppo", "prior": {"gait": str(WALK), "clock": True, "feedforward": True}}).prior
    prior = GaitPrior.from_config(cfg, env)
    assert prior is not None and prior.feedforward is not None and prior.feedforward.shape == (prior.period_steps, 6)
    t = Trajectory.load(WALK)
    e = env.unwrapped
    k = 7  # interval 7 … 8: mean torque minus the passive moment of the mean state, over τ_max
    expected = (0.5 * (t.tau[k] + t.tau[k + 1]) - e.passive_torque(0.5 * (t.q[k, 3:] + t.q[k + 1, 3:]),
                                                                    0.5 * (t.u[k, 3:] + t.u[k + 1, 3:]))) / e.tau_max
    np.testing.assert_allclose(prior.feedforward[k], expected)
    assert np.abs(prior.feedforward).max() < 1  # within the actuators' strength
    np.testing.assert_allclose(prior.act(np.full((2, 6), 0.9), np.array([k, k])), np.clip(0.9 + expected, -1, 1)[None].repeat(2, 0),
                               rtol=1e-6)
    # the wrapper steps its environments with these actions
    plain, wrapped = WalkerVecEnv(2, target_speed=1.3), GaitPriorReward(WalkerVecEnv(2, target_speed=1.3), prior)
    plain.seed(3)
    wrapped.seed(3)
    phase = prior.start_phase(plain.reset())
    wrapped.reset()
    for a in np.random.default_rng(1).uniform(-0.3, 0.3, (20, 2, 6)).astype(np.float32):
        obs0, _, d0, _ = plain.step(prior.act(a, phase))
        obs1, _, _, _ = wrapped.step(a)
        np.testing.assert_array_equal(obs1[:, :22], obs0)
        phase = (phase + 1) % prior.period_steps
        if d0.any():
            phase[d0] = prior.start_phase(obs0[d0])
    with pytest.raises(UserError, match="needs prior.clock"):
        GaitPrior.from_config(config_from_dict({"algo": "ppo", "prior": {"gait": str(WALK), "feedforward": True}}).prior, env)


def test_mirrored_half_strides_treat_the_legs_alike() -> None:
    env = gymnasium.make("sspinn/SagittalWalker-v0", target_speed=1.3)
    cfg = config_from_dict({"algo": "ppo", "prior": {"gait": str(WALK), "clock": True, "feedforward": True,
                                                       "mirror_policy": True}}).prior
    prior = GaitPrior.from_config(cfg, env)
    assert prior is not None and prior.mirror_policy
    h = prior.period_steps // 2
    rng = np.random.default_rng(2)
    obs = rng.normal(size=(4, 22)).astype(np.float32)
    mirrored = obs.copy()
    mirrored[:, 2:5], mirrored[:, 5:8] = obs[:, 5:8], obs[:, 2:5]  # joint angles
    mirrored[:, 11:14], mirrored[:, 14:17] = obs[:, 14:17], obs[:, 11:14]  # joint speeds
    mirrored[:, 17:19], mirrored[:, 19:21] = obs[:, 19:21], obs[:, 17:19]  # contact forces
    phase = np.array([0, 10, 40, h - 1])
    # the second half stride shows the policy the mirror image, with the clock of the first half
    np.testing.assert_allclose(prior.policy_input(mirrored, phase + h), prior.policy_input(obs, phase), atol=1e-6)
    # any policy then acts on the mirrored body with the mirrored action
    weights = rng.normal(size=(24, 6)) * 0.1

    def policy(x: np.ndarray) -> np.ndarray:
        return np.tanh(x @ weights)

    first = prior.act(policy(prior.policy_input(obs, phase)), phase)
    second = prior.act(policy(prior.policy_input(mirrored, phase + h)), phase + h)
    np.testing.assert_allclose(second, first[:, [3, 4, 5, 0, 1, 2]], atol=1e-6)
    assert not np.allclose(first, first[:, [3, 4, 5, 0, 1, 2]])  # not trivially symmetric
    # a stride that is not its own mirror half a stride later is refused
    t = Trajectory.load(WALK)
    odd = Trajectory(time=t.time[:-1], q=t.q[:-1], u=t.u[:-1], qdd=t.qdd[:-1], tau=t.tau[:-1], grf=t.grf[:-1], w=t.w[:-1])
    bad = GaitPrior(trajectory=odd, scales=prior.scales, weight=1.0, source="odd.npz", clock=True)
    with pytest.raises(UserError, match="mirror"):
        bad.with_mirror_policy()
