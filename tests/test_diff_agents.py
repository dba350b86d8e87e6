"""Tests of the controllers learned through the differentiable simulator (:mod:`agents.diff`):
gradients through the physics, one SHAC update, save/load, resume, the evaluation protocol and the
configuration's bounds (tiny N and horizons; 5 physics substeps where the physics is not the point)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from agents.__main__ import main
from agents.checkpoints import latest_checkpoint, load_agent
from agents.config import ConfigError, config_from_dict
from agents.diff import DiffAgent, DiffSettings
from agents.diff.agent import RunningNorm
from sspinn.torch_files import ModelFileError

CONFIGS = Path(__file__).resolve().parents[1] / "configs" / "agents"
ENV = {"target_speed": 1.3, "max_episode_steps": 30, "substeps": 5}

#: A SHAC run small enough for a unit test: 3 walkers, windows of 3 steps, 30-step episodes.
TINY: dict[str, Any] = {
    "algo": "shac",
    "seed": 1,
    "total_timesteps": 18,
    "env": {"n_envs": 3, "kwargs": ENV},
    "normalize": {"obs": True, "reward": False},
    "hyperparameters": {"horizon": 3, "critic_iterations": 2, "critic_batches": 2, "actor_hidden": [8],
                        "critic_hidden": [8]},
    "logging": {"checkpoint_freq": 9, "eval_freq": 9, "eval_episodes": 1, "tensorboard": False, "verbose": 0},
}


def tiny_settings(**changes: Any) -> DiffSettings:
    return DiffSettings(**{**TINY["hyperparameters"], "actor_hidden": (8,), "critic_hidden": (8,), **changes})


def write_config(folder: Path, **changes: Any) -> Path:
    import yaml

    data = copy.deepcopy(TINY)
    data.update(changes)
    path = folder / "tiny.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(autouse=True)
def one_thread(torch_threads: Any) -> None:
    torch.set_num_threads(1)


# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("algo", ["apg", "shac", "ahac"])
def test_gradients_reach_the_policy_through_the_physics(algo: str) -> None:
    agent = DiffAgent(algo, tiny_settings(horizon=2, cut_grf_rate=100.0), n_envs=2, env_kwargs=ENV, seed=0)
    before = [p.detach().clone() for p in agent.actor_parameters()]
    stats = agent.update_window()
    assert 0 < stats["grad_norm"] < float("inf")
    # the last action reaches the reward only through one control step of physics: its gradient is
    # the physics' (the tracking reward depends on the speed after the step, not on a directly)
    assert 0 < stats["grad_last_action"] < float("inf")
    assert any(not torch.equal(b, p.detach()) for b, p in zip(before, agent.actor_parameters()))
    assert stats["steps"] == agent.num_timesteps == 4


def test_the_reward_depends_on_the_action_only_through_the_physics_and_the_effort() -> None:
    """With the effort weight 0, the step's reward still has a non-zero gradient in the action:
    the speed after the step is a differentiable function of the torques."""
    from envs.batched import BatchedSagittalWalker

    env = BatchedSagittalWalker(2, seed=0, substeps=5, effort_weight=0.0, target_speed=1.3)
    env.reset()
    a = torch.zeros(2, 6, requires_grad=True)
    _, reward, *_ = env.step(a)
    reward.sum().backward()
    assert a.grad is not None and torch.isfinite(a.grad).all() and a.grad.abs().sum() > 0


def test_one_shac_update_lowers_the_window_loss_on_a_fixed_batch() -> None:
    """The same start states, exploration noise, normalisation and critic before and after one
    actor step on the window's gradient: the window loss falls."""
    agent = DiffAgent("shac", tiny_settings(horizon=3, actor_lr=1e-3, max_grad_norm=1e9), n_envs=4, env_kwargs=ENV,
                      seed=2)
    env = agent.env
    agent.obs_norm.update(env.observe())
    q, u = env.q.clone(), env.u.clone()
    noise = agent.noise.get_state()

    def window() -> Any:
        env.reset(seed=5)
        env.set_state(q, u)
        agent.noise.set_state(noise)
        return agent.rollout_window(update_statistics=False)

    before = window()
    agent.actor_opt.zero_grad()
    before.loss.backward()
    agent.actor_opt.step()
    after = window()
    assert float(after.loss.detach()) < float(before.loss.detach())


def test_td_lambda_targets_close_on_termination() -> None:
    agent = DiffAgent("shac", tiny_settings(gamma=0.5, lam=1.0), n_envs=1, env_kwargs=ENV)
    rew = torch.tensor([[1.0], [1.0], [1.0]])
    next_val = torch.tensor([[9.0], [0.0], [4.0]])
    ends = torch.tensor([[False], [True], [False]])
    targets = agent.td_lambda_targets(rew, next_val, ends)
    # last step: 1 + 0.5·4 = 3; step 1 ended (terminated, V = 0): 1; step 0 with λ = 1: 1 + 0.5·1 = 1.5
    assert targets[:, 0].tolist() == [1.5, 1.0, 3.0]


def test_running_norm_matches_numpy_and_passes_gradients() -> None:
    norm = RunningNorm(3, clip=10.0)
    data = np.random.default_rng(0).normal(2.0, 3.0, size=(500, 3))
    for chunk in np.array_split(data, 7):
        norm.update(torch.as_tensor(chunk))
    assert np.allclose(norm.mean.numpy(), data.mean(0), atol=1e-6)
    assert np.allclose(norm.var.numpy(), data.var(0), rtol=1e-4)
    x = torch.zeros(2, 3, requires_grad=True)
    norm(x).sum().backward()
    assert x.grad is not None and (x.grad > 0).all()


# ------------------------------------------------------------------------------------------------
def test_save_load_round_trip_gives_identical_actions(tmp_path: Path) -> None:
    agent = DiffAgent("ahac", tiny_settings(), n_envs=2, env_kwargs=ENV, seed=4)
    agent.learn(6)
    path = agent.save(tmp_path / "agent.pt")
    again = DiffAgent.load(path)
    obs = np.random.default_rng(1).normal(size=(5, 22)).astype(np.float32)
    assert np.array_equal(agent.predict(obs)[0], again.predict(obs)[0])
    assert again.num_timesteps == agent.num_timesteps == 6 and again.algo == "ahac"
    action, state = again.predict(obs[0])
    assert action.shape == (6,) and state is None and np.all(np.abs(action) <= 1)


def test_a_foreign_or_pickled_file_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pt"
    torch.save({"format": "sspinn-diff-agent", "version": 1, "x": Path("/")}, bad)  # an arbitrary object
    with pytest.raises(ModelFileError, match="could run code"):
        DiffAgent.load(bad)
    other = tmp_path / "other.pt"
    torch.save({"format": "sspinn-model", "version": 1}, other)
    with pytest.raises(ModelFileError, match="not one of"):
        DiffAgent.load(other)


@pytest.mark.slow
def test_train_resume_and_evaluate_through_the_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = write_config(tmp_path)
    run = tmp_path / "run"
    assert main(["train", "--algo", "shac", "--config", str(config), "--out", str(run)]) == 0
    assert (run / "final_model.pt").is_file() and (run / "best_model.pt").is_file()
    assert latest_checkpoint(run, suffix=".pt").name == "model_18_steps.pt"
    rows = (run / "training.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 and rows[0].startswith("steps,updates,loss")
    assert len((run / "evaluations.csv").read_text().splitlines()) == 1 + 3  # before training, at 9 and 18 steps

    # resume continues the step count up to a larger budget
    assert main(["train", "--config", str(config), "--out", str(run), "--resume", "--total-timesteps", "27"]) == 0
    assert "resuming from" in capsys.readouterr().out
    assert DiffAgent.load(run / "final_model.pt").num_timesteps == 27
    assert len((run / "training.csv").read_text().splitlines()) == 1 + 3  # windows of 3 walkers × 3 steps

    # a second run into the folder without --resume or --overwrite is refused
    with pytest.raises(FileExistsError):
        from agents.config import load_config
        from agents.train import train

        train(load_config(config), run)

    # the evaluation CLI takes it like an SB3 checkpoint, and load_agent gives the predict protocol
    out = tmp_path / "eval"
    assert main(["evaluate", "--checkpoint", str(run / "final_model.pt"), "--out", str(out), "--episodes", "1",
                 "--max-steps", "5", "--no-video"]) == 0
    assert (out / "metrics.json").is_file() and "1 episodes at 1.30 m/s" in capsys.readouterr().out
    agent = load_agent(run / "final_model.pt")
    action, state = agent.predict(np.zeros(22, dtype=np.float32), None, episode_start=True)
    assert action.shape == (6,) and state is None


def test_the_controller_comparison_protocol_drives_it() -> None:
    """``run_episode`` (evaluate, the training evaluations, the controller comparison) drives a
    DiffAgent like an SB3 agent."""
    from agents.builders import make_env
    from agents.rollout import run_episode

    agent = DiffAgent("shac", tiny_settings(), n_envs=2, env_kwargs=ENV)
    env = make_env(config_from_dict(TINY), max_episode_steps=4)
    try:
        result = run_episode(agent, env, seed=0, target_speed=1.3)
    finally:
        env.close()
    assert result.steps == 4 and np.isfinite(result.episode_return)


# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("section", "key", "value", "message"), [
    ("hyperparameters", "horizon", 10_000, r"hyperparameters.horizon must be an integer in \[1, 256\], got 10000"),
    ("hyperparameters", "horizon", 0, r"hyperparameters.horizon must be an integer in \[1, 256\], got 0"),
    ("hyperparameters", "gamma", 1.5, r"hyperparameters.gamma"),
    ("hyperparameters", "critic_iterations", 10_000, r"critic_iterations must be an integer in \[1, 256\]"),
    ("hyperparameters", "actor_hidden", [10_000], r"actor_hidden must be 1–4 layer sizes"),
    ("hyperparameters", "n_steps", 64, r"n_steps"),
    ("env", "n_envs", 100_000, r"env.n_envs must be an integer in \[1, 4096\]"),
    (None, "total_timesteps", 10**12, r"total_timesteps must be"),
    ("normalize", "reward", True, r"normalize.reward must be false"),
])
def test_bad_values_are_one_line_errors_with_bounds(section: str | None, key: str, value: Any, message: str) -> None:
    data = copy.deepcopy(TINY)
    (data if section is None else data[section])[key] = value
    with pytest.raises(ConfigError, match=message) as info:
        config_from_dict(data)
    assert "\n" not in str(info.value)


def test_bad_constructor_values_name_their_bounds() -> None:
    with pytest.raises(ValueError, match=r"n_envs must be an integer in \[1, 4096\]"):
        DiffAgent("shac", n_envs=5000)
    with pytest.raises(ValueError, match="algo must be one of apg, shac, ahac"):
        DiffAgent("ppo")
    with pytest.raises(ValueError, match=r"total_env_steps must be an integer in \[1, 1e11\]"):
        DiffAgent("apg", n_envs=1).learn(10**12)
    with pytest.raises(ValueError, match=r"4096 walkers × 256 steps × 50 substeps keeps about \d+ GB"):
        DiffAgent("apg", DiffSettings(horizon=256), n_envs=4096)


@pytest.mark.parametrize("name", ["apg_walk", "shac_walk", "ahac_walk"])
def test_shipped_configs_load(name: str) -> None:
    from agents.config import load_config
    from agents.diff.settings import settings_of

    config = load_config(CONFIGS / f"{name}.yaml")
    assert config.algo == name.split("_")[0] and config.env.target_speed == 1.3
    assert settings_of(config).horizon >= 1 and config.prior.gait is None


@pytest.mark.slow
def test_the_side_by_side_benchmark_runs_quick(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``benchmarks/speed/diff_vs_ppo.py --quick``: every arm trains a few steps and is summarised."""
    import json
    import runpy

    bench = runpy.run_path(str(Path(__file__).resolve().parents[1] / "benchmarks" / "speed" / "diff_vs_ppo.py"),
                           run_name="diff_vs_ppo")
    results = bench["main"](["--quick", "--out", str(tmp_path / "runs"), "--json", str(tmp_path / "r.json")])
    arms = {row["arm"]: row for row in results["arms"]}
    assert set(arms) == {"ppo_256envs", "sac", "apg", "shac", "ahac"}
    assert all(row["evaluations"] >= 1 and row["wall_s"] > 0 for row in arms.values())
    assert arms["ppo_256envs"]["gait_prior"] and not arms["shac"]["gait_prior"]
    assert all(row["finite"] for row in results["gradients"])
    assert json.loads((tmp_path / "r.json").read_text())["torch_threads"] == 1
    assert "walking targets met by the best model" in capsys.readouterr().out
    assert all(isinstance(row["walking_target_misses"], list) for row in arms.values())
