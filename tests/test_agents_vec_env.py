"""The SB3 adapter of the native vector environment: SB3's VecEnv conventions, the same episodes as
a DummyVecEnv of single environments, and PPO training through it."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3.common.env_util import make_vec_env  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv  # noqa: E402

from agents.config import config_from_dict  # noqa: E402
from agents.train import make_env  # noqa: E402
from agents.vec_env import PerEnvVecMonitor, WalkerVecEnv  # noqa: E402

#: Short episodes and easy falls, so that 60 random steps hold terminations and truncations.
_ENV = {"target_speed": (0.8, 1.6), "max_episode_steps": 20, "min_height_fraction": 0.95}


def _config(vec_env: str, **changes: Any) -> Any:
    data: dict[str, Any] = {
        "algo": "ppo", "seed": 3, "total_timesteps": 256,
        "env": {"n_envs": 2, "vec_env": vec_env, "kwargs": {**_ENV, "target_speed": 1.3}, "eval_target_speed": 1.3},
        "policy": {"net_arch": [16], "log_std_init": -1.0},
        "hyperparameters": {"n_steps": 64, "batch_size": 32, "n_epochs": 2},
        "logging": {"checkpoint_freq": 128, "eval_freq": 0, "tensorboard": False},
    }
    data.update(copy.deepcopy(changes))
    return config_from_dict(data)


def test_same_steps_as_a_dummy_vec_env_with_terminal_observations() -> None:
    n, seed = 3, 21
    config = _config("dummy", env={"n_envs": n, "vec_env": "dummy", "kwargs": _ENV, "eval_target_speed": 1.3})
    dummy = make_vec_env(lambda: make_env(config), n_envs=n, seed=seed, vec_env_cls=DummyVecEnv)
    native = WalkerVecEnv(n, **_ENV)
    native.seed(seed)
    obs_d, obs_n = dummy.reset(), native.reset()
    np.testing.assert_array_equal(obs_n, obs_d)
    actions = np.random.default_rng(1).uniform(-1, 1, (60, n, 6)).astype(np.float32)
    kinds = set()
    for a in actions:
        obs_d, rew_d, done_d, info_d = dummy.step(a)
        obs_n, rew_n, done_n, info_n = native.step(a)
        np.testing.assert_array_equal(obs_n, obs_d)
        np.testing.assert_array_equal(rew_n, rew_d)
        assert rew_n.dtype == np.float32 and done_n.dtype == bool
        np.testing.assert_array_equal(done_n, done_d)
        for i in np.flatnonzero(done_n):
            np.testing.assert_array_equal(info_n[i]["terminal_observation"], info_d[i]["terminal_observation"])
            assert info_n[i]["TimeLimit.truncated"] == info_d[i]["TimeLimit.truncated"]
            assert info_n[i]["distance"] == pytest.approx(info_d[i]["distance"])
            kinds.add(info_n[i]["TimeLimit.truncated"])
    assert kinds == {True, False}, "both truncations and terminations must have occurred"
    assert native.get_attr("num_envs") == [n] * n and native.env_is_wrapped(DummyVecEnv) == [False] * n


def test_terminal_observation_is_the_last_observation_of_the_episode() -> None:
    native = WalkerVecEnv(1, max_episode_steps=3, reset_noise_scale=0.0)
    native.seed(0)
    native.reset()
    zeros = np.zeros((1, 6), dtype=np.float32)
    observations = [native.step(zeros)[0][0] for _ in range(2)]
    obs, _, done, info = native.step(zeros)
    assert done[0] and info[0]["TimeLimit.truncated"]
    terminal = info[0]["terminal_observation"]
    assert not np.array_equal(terminal, observations[-1])  # the body kept moving
    np.testing.assert_allclose(obs[0][:8], [native.env.standing_height] + [0.0] * 7, atol=1e-9)  # the next episode
    assert np.abs(terminal[:8] - obs[0][:8]).max() > 1e-5


def test_ppo_learns_a_few_hundred_steps_through_the_adapter() -> None:
    import torch
    from stable_baselines3 import PPO

    venv = WalkerVecEnv(4, **_ENV)
    venv.seed(0)
    from stable_baselines3.common.vec_env import VecMonitor

    model = PPO("MlpPolicy", VecMonitor(venv), n_steps=64, batch_size=64, n_epochs=2, seed=0, device="cpu",
                policy_kwargs={"net_arch": [16]})
    before = {k: v.clone() for k, v in model.policy.state_dict().items()}
    model.learn(total_timesteps=512)  # two rollouts of 4 × 64 steps
    assert model.num_timesteps == 512
    assert len(model.ep_info_buffer) > 5  # finished episodes reached SB3 through VecMonitor
    assert any(not torch.equal(before[k], v) for k, v in model.policy.state_dict().items())


def test_train_through_the_native_vector_env_equals_dummy_vec_env(tmp_path: Path) -> None:
    """``python -m agents train``'s default (native) and DummyVecEnv give the same policy and the same
    per-environment Monitor logs (returns and lengths)."""
    import csv

    import torch

    from agents.train import train

    models = {kind: train(_config(kind), tmp_path / kind) for kind in ("native", "dummy")}
    native, dummy = models["native"], models["dummy"]
    assert native.num_timesteps == 256
    assert isinstance(native.get_env().venv, PerEnvVecMonitor)
    params_n, params_d = native.policy.state_dict(), dummy.policy.state_dict()
    assert all(torch.equal(params_n[k], params_d[k]) for k in params_n), "native and dummy runs must agree"

    def episodes(kind: str, i: int) -> np.ndarray:
        with (tmp_path / kind / "monitor" / f"{i}.monitor.csv").open() as fh:
            rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
        return np.array([(float(r["r"]), int(r["l"]), float(r["distance"])) for r in rows])

    for i in range(2):
        assert len(episodes("native", i)) > 3
        # Monitor rounds returns to 6 decimals, VecMonitor sums in float32
        np.testing.assert_allclose(episodes("native", i), episodes("dummy", i), rtol=1e-6)


def test_shaped_ppo_config_loads() -> None:
    from agents.config import load_config

    config = load_config(Path(__file__).resolve().parents[1] / "configs" / "agents" / "ppo_shaped.yaml")
    assert config.env.vec_env == "native" and config.env.threads == 1
    assert config.env.kwargs["slip_weight"] > 0 and config.env.kwargs["impact_weight"] > 0
