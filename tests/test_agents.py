"""Tests of the SB3 agents package: configuration, training with checkpoints and resume,
evaluation outputs and seeding (tiny budgets; the whole module runs in well under a minute)."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

from agents.__main__ import main  # noqa: E402
from agents.checkpoints import latest_checkpoint, load_agent, vecnormalize_path  # noqa: E402
from agents.config import AgentConfig, ConfigError, config_from_dict, load_config, save_config  # noqa: E402

CONFIGS = Path(__file__).resolve().parents[1] / "configs" / "agents"

#: A PPO run small enough for a unit test: 1 env, 64-step rollouts, 50-step episodes, tiny net.
TINY: dict[str, Any] = {
    "algo": "ppo",
    "seed": 3,
    "total_timesteps": 128,
    "env": {"n_envs": 1, "kwargs": {"target_speed": 1.3, "max_episode_steps": 50}},
    "policy": {"net_arch": [16], "log_std_init": -1.0},
    "hyperparameters": {"n_steps": 64, "batch_size": 32, "n_epochs": 1},
    "logging": {"checkpoint_freq": 64, "eval_freq": 128, "eval_episodes": 1, "tensorboard": False},
}


def tiny(**changes: Any) -> AgentConfig:
    data = copy.deepcopy(TINY)
    data.update(changes)
    return config_from_dict(data)


# ------------------------------------------------------------------------------------------------
# configuration
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["ppo", "sac", "td3"])
def test_shipped_configs_load(name: str) -> None:
    config = load_config(CONFIGS / f"{name}.yaml")
    assert config.algo == name
    assert config.env.kwargs["target_speed"] == 1.3
    assert config.env.target_speed == 1.3
    assert isinstance(config.hyperparameters["learning_rate"], float)


def test_the_256_environment_variant_is_the_clock_walker_with_its_own_batch() -> None:
    walker, wide = load_config(CONFIGS / "ppo_clock_walk.yaml"), load_config(CONFIGS / "ppo_clock_walk_256envs.yaml")
    assert wide.env.n_envs == 256 and tuple(wide.policy.net_arch) == (64, 64)
    assert wide.hyperparameters["n_steps"] * wide.env.n_envs % wide.hyperparameters["batch_size"] == 0
    assert wide.prior == walker.prior and wide.env.kwargs == walker.env.kwargs and wide.normalize == walker.normalize
    assert wide.hyperparameters["learning_rate"] == walker.hyperparameters["learning_rate"]


def test_optimizer_kwargs_reach_adam_and_ppo_keeps_sb3s_eps(tmp_path: Path) -> None:
    from agents.train import train

    fused = train(tiny(policy={**TINY["policy"], "optimizer_kwargs": {"fused": True}}), tmp_path / "fused")
    group = fused.policy.optimizer.param_groups[0]
    assert group["fused"] is True and group["eps"] == 1e-5  # SB3's PPO eps, which it sets only without kwargs
    plain = train(tiny(), tmp_path / "plain").policy.optimizer.param_groups[0]
    assert plain["eps"] == 1e-5 and not plain["fused"]
    with pytest.raises(ConfigError, match=r"policy.optimizer_kwargs must be keyword arguments of torch.optim.Adam"):
        tiny(policy={**TINY["policy"], "optimizer_kwargs": {"lr": 0.1}})


def test_config_round_trip_and_scientific_notation(tmp_path: Path) -> None:
    config = tiny(hyperparameters={"n_steps": 64, "batch_size": 32, "learning_rate": 3.0e-4})
    save_config(config, tmp_path / "c.yaml")
    assert load_config(tmp_path / "c.yaml") == config
    (tmp_path / "s.yaml").write_text("algo: ppo\nhyperparameters:\n  learning_rate: 3e-4\n")
    assert load_config(tmp_path / "s.yaml").hyperparameters["learning_rate"] == pytest.approx(3e-4)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"algo": "a2c"}, "algo must be one of"),
        ({"seed": -1}, "seed must be"),
        ({"total_timesteps": 0}, "total_timesteps"),
        ({"unknown": 1}, "unknown key"),
        ({"env": {"n_envs": 0}}, "env.n_envs"),
        ({"env": {"vec_env": "ray"}}, "env.vec_env"),
        ({"env": {"kwargs": {"target_speeed": 1.3}}}, "env.kwargs"),
        ({"env": {"kwargs": {"target_speed": [1.0, 2.0]}}}, "eval_target_speed"),
        ({"env": {"foo": 1}}, "env.foo"),
        ({"policy": {"net_arch": []}}, "policy.net_arch"),
        ({"policy": {"activation": "sigmoid"}}, "policy.activation"),
        ({"hyperparameters": {"n_step": 64}}, "keyword arguments of stable_baselines3.PPO"),
        ({"hyperparameters": {"seed": 1}}, "free of keys set by agents.train"),
        ({"hyperparameters": {"n_steps": 8, "batch_size": 128}}, "batch_size"),
        ({"hyperparameters": {"learning_rate": "fast"}}, "learning_rate"),
        ({"hyperparameters": {"gamma": 1.5}}, "gamma"),
        ({"logging": {"eval_episodes": 0}}, "logging.eval_episodes"),
        ({"normalize": {"obs": "yes"}}, "normalize.obs"),
        ({"normalize": 3}, "'normalize' must be a mapping"),
    ],
)
def test_config_validation_errors(change: dict[str, Any], message: str) -> None:
    data: dict[str, Any] = {"algo": "ppo"}
    data.update(change)
    with pytest.raises(ConfigError, match=message):
        config_from_dict(data)


def test_config_errors_name_the_file(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("seed: 1\n")
    with pytest.raises(ConfigError, match="bad.yaml: 'algo' is required"):
        load_config(path)
    path.write_text("algo: ppo\n  bad: [indent\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(path)
    with pytest.raises(ConfigError, match="missing.yaml: no such configuration file"):
        load_config(tmp_path / "missing.yaml")
    td3 = yaml.safe_load((CONFIGS / "td3.yaml").read_text())
    td3["policy"]["log_std_init"] = -1.0
    with pytest.raises(ConfigError, match="not TD3"):
        config_from_dict(td3)


def test_cli_reports_config_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["train", "--algo", "sac", "--config", str(CONFIGS / "ppo.yaml"), "--out", str(tmp_path)]) == 2
    assert "--algo sac but" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------------
# training, checkpoints, resume, evaluation
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def trained_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 128-step PPO run resumed to 256 steps (shared by the tests below)."""
    from agents.train import train

    out = tmp_path_factory.mktemp("ppo_run")
    model = train(tiny(), out)
    assert model.num_timesteps == 128
    with pytest.raises(FileExistsError, match="--resume"):
        train(tiny(), out)
    model = train(tiny(total_timesteps=256), out, resume=True)
    assert model.num_timesteps == 256
    return out


def test_training_checkpoints_and_resume(trained_run: Path) -> None:
    steps = sorted(int(p.stem.split("_")[1]) for p in (trained_run / "checkpoints").glob("model_*_steps.zip"))
    assert steps == [64, 128, 192, 256]
    latest = latest_checkpoint(trained_run)
    assert latest is not None and latest.name == "model_256_steps.zip"
    assert vecnormalize_path(latest).is_file()
    for name in ("config.yaml", "final_model.zip", "final_vecnormalize.pkl", "best_model.zip", "best_vecnormalize.pkl"):
        assert (trained_run / name).is_file(), name
    rows = (trained_run / "evaluations.csv").read_text().splitlines()
    assert rows[0].startswith("timesteps,") and [r.split(",")[0] for r in rows[1:]] == ["128", "256"]
    assert "mean_step_time_asymmetry" in rows[0] and "mean_foot_slide_per_step_cm" in rows[0]
    # the Monitor log was appended to on resume, not overwritten
    monitor = (trained_run / "monitor" / "0.monitor.csv").read_text().splitlines()
    assert sum(int(line.split(",")[1]) for line in monitor[2:]) > 128
    agent = load_agent(trained_run / "final_model.zip")
    assert agent.obs_mean is not None and agent.obs_mean.shape == (22,)
    assert agent(np.zeros(22, dtype=np.float32)).shape == (6,)


def test_resume_without_checkpoint_fails(tmp_path: Path) -> None:
    from agents.train import train

    with pytest.raises(FileNotFoundError, match="no checkpoint"):
        train(tiny(), tmp_path, resume=True)


def test_a_finished_run_is_replaced_only_with_overwrite(tmp_path: Path) -> None:
    """A run shorter than one checkpoint leaves only its final model: training into its folder again
    is refused (naming what it holds) until --overwrite, which deletes the old run's files first."""
    from agents.train import train

    short = tiny(logging={"checkpoint_freq": 10_000, "eval_freq": 0, "tensorboard": False})
    train(short, tmp_path)
    assert latest_checkpoint(tmp_path) is None and (tmp_path / "final_model.zip").is_file()
    before = (tmp_path / "final_model.zip").stat().st_mtime_ns
    with pytest.raises(FileExistsError, match=r"already holds a run \(final_model.zip.*--overwrite") as info:
        train(short, tmp_path)
    assert "--resume" not in str(info.value)  # nothing to resume from
    assert (tmp_path / "final_model.zip").stat().st_mtime_ns == before
    (tmp_path / "evaluations.csv").write_text("timesteps\n1\n")  # a file of the old run that the new one would not write
    with pytest.raises(ValueError, match="give one of them"):
        train(short, tmp_path, resume=True, overwrite=True)
    model = train(short, tmp_path, overwrite=True)
    assert model.num_timesteps == 128 and not (tmp_path / "evaluations.csv").exists()
    assert (tmp_path / "final_model.zip").stat().st_mtime_ns != before


def test_ctrl_c_saves_a_checkpoint_that_resume_continues(tmp_path: Path, monkeypatch) -> None:
    """A Ctrl-C during training saves a checkpoint at the end of that vector step and stops with
    KeyboardInterrupt (no final model); --resume continues from it to the planned steps."""
    import signal

    from agents.train import train
    from agents.vec_env import WalkerVecEnv

    handler_before = signal.getsignal(signal.SIGINT)
    config = tiny(logging={"checkpoint_freq": 10_000, "eval_freq": 0, "tensorboard": False})
    real_step_wait = WalkerVecEnv.step_wait
    calls = {"n": 0}

    def step_then_sigint(self):  # Ctrl-C arrives during the 70th environment step
        calls["n"] += 1
        if calls["n"] == 70:
            signal.raise_signal(signal.SIGINT)
        return real_step_wait(self)

    with monkeypatch.context() as m:
        m.setattr(WalkerVecEnv, "step_wait", step_then_sigint)
        with pytest.raises(KeyboardInterrupt):
            train(config, tmp_path)
    assert signal.getsignal(signal.SIGINT) is handler_before
    latest = latest_checkpoint(tmp_path)
    assert latest is not None and latest.name == "model_70_steps.zip" and vecnormalize_path(latest).is_file()
    assert not (tmp_path / "final_model.zip").exists()
    model = train(config, tmp_path, resume=True)
    assert model.num_timesteps >= 128 and (tmp_path / "final_model.zip").is_file()  # PPO rolls out whole n_steps


def test_evaluate_writes_report_plot_and_animation(trained_run: Path, tmp_path: Path) -> None:
    out = tmp_path / "eval"
    code = main(["evaluate", "--checkpoint", str(trained_run / "final_model.zip"), "--episodes", "2",
                 "--max-steps", "20", "--fps", "50", "--out", str(out)])
    assert code == 0
    report = json.loads((out / "metrics.json").read_text())
    assert report["algo"] == "ppo" and report["target_speed"] == 1.3
    assert [e["seed"] for e in report["episodes"]] == [0, 1]
    for episode in report["episodes"]:
        assert 1 <= episode["steps"] <= 20
        assert set(episode) >= {"distance_m", "mean_speed_m_s", "speed_error_m_s", "cost_of_transport", "fell",
                                "foot_slide_m", "cadence_steps_per_min", "step_time_asymmetry", "step_length_asymmetry",
                                "stance_asymmetry", "foot_slide_per_step_cm", "peak_impact_bw", "rmsd_knee_deg"}
    assert report["summary"]["episodes"] == 2 and "mean_peak_impact_bw" in report["summary"]
    assert (out / "traces.png").stat().st_size > 10_000
    from PIL import Image

    with Image.open(out / "episode.gif") as gif:
        assert gif.n_frames == report["episodes"][0]["steps"] // 2 + 1
    gif_path = tmp_path / "walk.gif"
    assert main(["record", "--checkpoint", str(trained_run / "final_model.zip"), "--max-steps", "8",
                 "--out", str(gif_path)]) == 0
    assert gif_path.stat().st_size > 1000
    assert main(["record", "--checkpoint", str(trained_run / "final_model.zip"), "--out", str(tmp_path / "a.avi")]) == 2


def test_evaluation_is_reproducible(trained_run: Path, tmp_path: Path) -> None:
    from agents.evaluate import evaluate

    kwargs = {"episodes": 2, "seed": 7, "max_steps": 30, "video": False}
    first = evaluate(trained_run / "final_model.zip", tmp_path / "a", **kwargs)
    second = evaluate(trained_run / "final_model.zip", tmp_path / "b", **kwargs)
    assert first["episodes"] == second["episodes"]
    other = evaluate(trained_run / "final_model.zip", tmp_path / "c", **{**kwargs, "seed": 8})
    assert other["episodes"][0]["distance_m"] != first["episodes"][0]["distance_m"]


def test_training_is_reproducible(tmp_path: Path) -> None:
    import torch

    from agents.train import train

    config = tiny(total_timesteps=64, logging={"checkpoint_freq": 64, "eval_freq": 0, "tensorboard": False})
    params = [train(config, tmp_path / name).policy.state_dict() for name in ("a", "b")]
    assert all(torch.equal(params[0][k], params[1][k]) for k in params[0])


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_off_policy_configs_train(algo: str, tmp_path: Path) -> None:
    from agents.train import train

    data = yaml.safe_load((CONFIGS / f"{algo}.yaml").read_text())
    data.update(total_timesteps=64)
    data["env"]["kwargs"]["max_episode_steps"] = 30
    data["policy"]["net_arch"] = [16]
    data["hyperparameters"].update(learning_starts=32, batch_size=16, buffer_size=1000)
    data["logging"].update(checkpoint_freq=32, eval_freq=0, tensorboard=False, keep_replay_buffer=True)
    config = config_from_dict(data)
    model = train(config, tmp_path)
    assert model.num_timesteps == 64
    assert (tmp_path / "checkpoints" / "model_replay_buffer_64_steps.pkl").is_file()
    model = train(config.with_overrides(total_timesteps=96), tmp_path, resume=True)
    # CheckpointCallback runs before SB3 stores the step's transition: the buffer saved at 64 steps holds 63
    assert model.num_timesteps == 96 and model.replay_buffer.size() == 96 - 1


def test_learning_curve_plot(trained_run: Path, tmp_path: Path) -> None:
    from agents.plot_learning_curve import main as plot_main
    from agents.plot_learning_curve import read_monitor, rolling_mean

    episodes = read_monitor(trained_run)
    assert np.all(np.diff(episodes["timesteps"]) >= 0) and episodes["timesteps"][-1] <= 256
    assert rolling_mean(np.array([1.0, 3.0, 5.0]), 2) == pytest.approx([1.0, 2.0, 4.0])
    assert plot_main([str(trained_run), "--out", str(tmp_path / "curve.png")]) == 0
    assert (tmp_path / "curve.png").stat().st_size > 10_000
