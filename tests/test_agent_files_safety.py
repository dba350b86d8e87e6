"""Nothing an agent run folder holds can run code when it is loaded: ``train --resume``,
``evaluate`` and ``record`` read the SB3 ``.zip`` (its JSON ``data`` with cloudpickled entries
and its torch ``.pth`` entries), the VecNormalize statistics and the replay buffer (pickles)
through :mod:`agents.checkpoints`. Every crafted file carries a payload that would create a
marker file; the marker must never appear, and each file is either refused with one line or
loaded safely. Resuming rebuilds the pickled attributes from the configuration exactly."""

from __future__ import annotations

import base64
import copy
import json
import os
import pickle
import shutil
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

from agents.__main__ import main  # noqa: E402
from agents.checkpoints import (  # noqa: E402
    UnsafeCheckpointError,
    load_algorithm,
    load_replay_buffer,
    load_statistics,
    restore_replay_buffer,
)
from agents.config import config_from_dict, load_config  # noqa: E402
from agents.train import train  # noqa: E402

CONFIGS = Path(__file__).resolve().parents[1] / "configs" / "agents"

#: 64 PPO steps in one 64-step rollout: one checkpoint, one evaluation, a best and a final model.
PPO: dict[str, Any] = {
    "algo": "ppo", "seed": 3, "total_timesteps": 64,
    "env": {"n_envs": 1, "kwargs": {"target_speed": 1.3, "max_episode_steps": 30}},
    "policy": {"net_arch": [8]},
    "hyperparameters": {"n_steps": 64, "batch_size": 32, "n_epochs": 1, "clip_range": 0.15},
    "logging": {"checkpoint_freq": 64, "eval_freq": 64, "eval_episodes": 1, "tensorboard": False},
}


class RunsCode:
    """A pickle payload: unpickling it runs ``touch <marker>``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ppo")
    train(config_from_dict(copy.deepcopy(PPO)), out)
    return out


@pytest.fixture(scope="module")
def td3_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    data = yaml.safe_load((CONFIGS / "td3.yaml").read_text())
    data.update(total_timesteps=32)
    data["env"].update(n_envs=1)
    data["env"]["kwargs"]["max_episode_steps"] = 20
    data["policy"]["net_arch"] = [8]
    data["hyperparameters"].update(learning_starts=16, batch_size=8, buffer_size=200, action_noise=0.07)
    data["logging"].update(checkpoint_freq=32, eval_freq=0, tensorboard=False, keep_replay_buffer=True)
    out = tmp_path_factory.mktemp("td3")
    train(config_from_dict(data), out)
    return out


@pytest.fixture
def marker(tmp_path: Path) -> Path:
    path = tmp_path / "payload_ran"
    yield path
    assert not path.exists(), "a crafted file ran code"


def _copy(run: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(run, tmp_path / "run"))


def _rewrite_data(zip_path: Path, change) -> None:
    """Replace the JSON ``data`` entry of an SB3 zip by ``change(data)``."""
    with zipfile.ZipFile(zip_path) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    data = json.loads(entries["data"])
    change(data)
    entries["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(zip_path, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)


def _serialized(payload: object) -> dict[str, str]:
    return {":type:": "<class 'object'>", ":serialized:": base64.b64encode(pickle.dumps(payload)).decode()}


def _resume(run: Path, capsys: pytest.CaptureFixture[str], steps: int = 128) -> tuple[int, str]:
    code = main(["train", "--config", str(run / "config.yaml"), "--out", str(run), "--resume",
                 "--total-timesteps", str(steps)])
    return code, capsys.readouterr().err


def _one_line(err: str) -> None:
    assert err.count("\n") == 1 and "Traceback" not in err, err


# ------------------------------------------------------------------------------------------------
# train --resume
# ------------------------------------------------------------------------------------------------
def test_resume_refuses_crafted_vecnormalize_statistics(ppo_run, tmp_path, marker, capsys) -> None:
    run = _copy(ppo_run, tmp_path)
    (run / "checkpoints" / "model_vecnormalize_64_steps.pkl").write_bytes(pickle.dumps(RunsCode(marker)))
    code, err = _resume(run, capsys)
    assert code == 2, err
    _one_line(err)
    assert "model_vecnormalize_64_steps.pkl: not VecNormalize statistics (refusing to load posix.system)" in err


def test_resume_refuses_statistics_of_another_kind(ppo_run, tmp_path, marker, capsys) -> None:
    assert load_statistics(ppo_run / "checkpoints" / "model_vecnormalize_64_steps.pkl").obs_rms.mean.shape == (22,)
    run = _copy(ppo_run, tmp_path)
    (run / "checkpoints" / "model_vecnormalize_64_steps.pkl").write_bytes(pickle.dumps(np.zeros(3)))
    code, err = _resume(run, capsys)
    assert code == 2 and "not VecNormalize statistics (it holds a ndarray)" in err, err
    (run / "checkpoints" / "model_vecnormalize_64_steps.pkl").write_bytes(b"\x80\x04junk")
    code, err = _resume(run, capsys)
    assert code == 2 and "damaged VecNormalize statistics" in err, err
    _one_line(err)


def test_resume_loads_a_crafted_observation_space_without_running_it(ppo_run, tmp_path, marker, capsys) -> None:
    run = _copy(ppo_run, tmp_path)
    _rewrite_data(run / "checkpoints" / "model_64_steps.zip",
                  lambda data: data.update(observation_space=_serialized(RunsCode(marker))))
    code, err = _resume(run, capsys)
    assert code == 0, err  # the space is rebuilt from the configuration, the payload never read
    assert (run / "checkpoints" / "model_128_steps.zip").is_file()


@pytest.mark.parametrize("entry", ["policy_kwargs", "clip_range", "lr_schedule", "_last_obs"])
def test_resume_never_unpickles_a_known_entry(ppo_run, tmp_path, marker, entry) -> None:
    run = _copy(ppo_run, tmp_path)
    checkpoint = run / "checkpoints" / "model_64_steps.zip"
    _rewrite_data(checkpoint, lambda data: data.update({entry: _serialized(RunsCode(marker))}))
    config = load_config(run / "config.yaml")
    assert load_algorithm(checkpoint, config).num_timesteps == 64


def test_resume_refuses_an_unknown_pickled_entry(ppo_run, tmp_path, marker, capsys) -> None:
    run = _copy(ppo_run, tmp_path)
    _rewrite_data(run / "checkpoints" / "model_64_steps.zip", lambda data: data.update(payload=_serialized(RunsCode(marker))))
    code, err = _resume(run, capsys)
    assert code == 2 and "model_64_steps.zip: holds pickled Python objects ['payload'] that would run code" in err, err
    _one_line(err)


def test_resume_refuses_weights_that_are_not_tensors(ppo_run, tmp_path, marker, capsys) -> None:
    import torch

    run = _copy(ppo_run, tmp_path)
    checkpoint = run / "checkpoints" / "model_64_steps.zip"
    with zipfile.ZipFile(checkpoint) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    crafted = tmp_path / "policy.pth"
    torch.save({"payload": RunsCode(marker)}, crafted)
    entries["policy.pth"] = crafted.read_bytes()
    with zipfile.ZipFile(checkpoint, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)
    code, err = _resume(run, capsys)
    assert code == 2 and "model_64_steps.zip: holds data other than network weights" in err, err
    _one_line(err)


def test_resume_refuses_a_checkpoint_of_another_network(ppo_run, tmp_path, capsys) -> None:
    run = _copy(ppo_run, tmp_path)
    config = yaml.safe_load((run / "config.yaml").read_text())
    config["policy"]["net_arch"] = [12]
    (run / "other.yaml").write_text(yaml.safe_dump(config))
    code = main(["train", "--config", str(run / "other.yaml"), "--out", str(run), "--resume"])
    err = capsys.readouterr().err
    assert code == 2 and "model_64_steps.zip: not a ppo checkpoint of this configuration" in err, err
    _one_line(err)


def test_resume_rebuilds_the_schedules_of_the_configuration(ppo_run, td3_run) -> None:
    from stable_baselines3.common.type_aliases import TrainFreq, TrainFrequencyUnit

    ppo = load_algorithm(ppo_run / "checkpoints" / "model_64_steps.zip", load_config(ppo_run / "config.yaml"))
    assert ppo.clip_range(1.0) == 0.15 and ppo.lr_schedule(1.0) == pytest.approx(3e-4)
    td3 = load_algorithm(td3_run / "checkpoints" / "model_32_steps.zip", load_config(td3_run / "config.yaml"))
    assert td3.train_freq == TrainFreq(1, TrainFrequencyUnit.STEP)
    np.testing.assert_allclose(td3.action_noise._sigma, 0.07)


def test_resume_refuses_a_crafted_replay_buffer(td3_run, tmp_path, marker, capsys) -> None:
    run = _copy(td3_run, tmp_path)
    (run / "checkpoints" / "model_replay_buffer_32_steps.pkl").write_bytes(pickle.dumps(RunsCode(marker)))
    code, err = _resume(run, capsys, steps=48)
    assert code == 2 and "model_replay_buffer_32_steps.pkl: not an SB3 replay buffer (refusing to load posix.system)" in err, err
    _one_line(err)


def test_replay_buffers_load_safely_and_must_fit(td3_run, tmp_path) -> None:
    from gymnasium.spaces import Box
    from stable_baselines3.common.buffers import ReplayBuffer

    path = td3_run / "checkpoints" / "model_replay_buffer_32_steps.pkl"
    buffer = load_replay_buffer(path)
    assert buffer.size() == 31 and buffer.observations.shape[1:] == (1, 22)
    model = load_algorithm(td3_run / "checkpoints" / "model_32_steps.zip", load_config(td3_run / "config.yaml"))
    restore_replay_buffer(model, path)
    assert model.replay_buffer.size() == 31
    other = ReplayBuffer(10, Box(-1, 1, (3,)), Box(-1, 1, (6,)), device="cpu")
    (tmp_path / "small.pkl").write_bytes(pickle.dumps(other))
    with pytest.raises(UnsafeCheckpointError, match=r"small.pkl: replay buffer of .* does not fit this run"):
        restore_replay_buffer(model, tmp_path / "small.pkl")


# ------------------------------------------------------------------------------------------------
# evaluate / record
# ------------------------------------------------------------------------------------------------
def test_evaluate_and_record_refuse_crafted_statistics(ppo_run, tmp_path, marker, capsys) -> None:
    run = _copy(ppo_run, tmp_path)
    (run / "final_vecnormalize.pkl").write_bytes(pickle.dumps(RunsCode(marker)))
    code = main(["evaluate", "--checkpoint", str(run / "final_model.zip"), "--episodes", "1", "--no-video",
                 "--out", str(tmp_path / "eval")])
    err = capsys.readouterr().err
    assert code == 2 and "final_vecnormalize.pkl: not VecNormalize statistics" in err, err
    code = main(["record", "--checkpoint", str(run / "final_model.zip"), "--out", str(tmp_path / "a.gif")])
    err = capsys.readouterr().err
    assert code == 2 and "final_vecnormalize.pkl: not VecNormalize statistics" in err, err
    _one_line(err)
    assert not (tmp_path / "eval").exists() and not (tmp_path / "a.gif").exists()


def test_evaluate_loads_a_crafted_zip_safely(ppo_run, tmp_path, marker, capsys) -> None:
    run = _copy(ppo_run, tmp_path)
    _rewrite_data(run / "best_model.zip", lambda data: data.update(
        observation_space=_serialized(RunsCode(marker)), policy_class=_serialized(RunsCode(marker))))
    code = main(["evaluate", "--checkpoint", str(run / "best_model.zip"), "--episodes", "1", "--max-steps", "5",
                 "--no-video", "--out", str(tmp_path / "eval")])
    assert code == 0, capsys.readouterr().err
    assert json.loads((tmp_path / "eval" / "metrics.json").read_text())["summary"]["episodes"] == 1
