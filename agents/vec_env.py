"""Stable-Baselines3 on the native vector environment: a ``VecEnv`` adapter and per-environment
episode logs.

:class:`WalkerVecEnv` wraps :class:`envs.vector.SagittalWalkerVectorEnv` (all N walkers stepped by
one compiled call) in SB3's ``VecEnv`` interface; :func:`agents.train.make_training_envs` uses it
unless ``env.vec_env`` asks for SB3's ``DummyVecEnv``/``SubprocVecEnv`` of single environments.
The SB3 conventions (``stable_baselines3.common.vec_env.base_vec_env``), which differ from
Gymnasium's vector API:

* ``reset()`` returns the observations only; the seeds set by ``seed(s)`` (s, s + 1, ... per
  environment, as ``make_vec_env`` does) and options of ``set_options`` apply to that reset once;
* ``step_wait()`` returns (obs, rewards float32, dones, infos) with ``dones = terminated |
  truncated``; a finished environment is reset within the step (the vector environment runs in
  Gymnasium's ``SAME_STEP`` auto-reset mode), its returned observation is the new episode's first,
  and its info holds ``terminal_observation`` (the last observation of the finished episode) and
  ``TimeLimit.truncated`` (truncated and not terminated), plus the environment's end-of-episode
  quantities (``distance`` m, ``cost_of_transport``) for the episode logs.

With the same seeds, the observations, rewards and dones are those of SB3's ``DummyVecEnv`` of
single environments (``tests/test_agents.py``), so a PPO run gives the same policy either way, only
faster.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.monitor import ResultsWriter
from stable_baselines3.common.vec_env import VecEnv, VecMonitor
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from envs.vector import SagittalWalkerVectorEnv

#: Step quantities of the finished episode copied into SB3's info of a done environment.
FINAL_INFO_KEYS: tuple[str, ...] = ("distance", "cost_of_transport", "x_position", "target_speed")


class WalkerVecEnv(VecEnv):
    """SB3 ``VecEnv`` over one :class:`~envs.vector.SagittalWalkerVectorEnv` (module docstring).

    Args:
        num_envs: number of walkers.
        **env_kwargs: arguments of the vector environment (``WalkerConfig`` fields, ``config``,
            ``parallel``); its auto-reset mode is set to ``SAME_STEP``.
    """

    def __init__(self, num_envs: int, **env_kwargs: Any) -> None:
        if "autoreset_mode" in env_kwargs:
            raise ValueError("WalkerVecEnv sets the vector environment's autoreset_mode (SAME_STEP) itself")
        self.env = SagittalWalkerVectorEnv(num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs)
        self.render_mode = None
        super().__init__(num_envs, self.env.single_observation_space, self.env.single_action_space)
        self._actions = np.zeros((num_envs, *self.action_space.shape), dtype=np.float64)

    def reset(self) -> VecEnvObs:
        """Reset every environment with the pending seeds and options (used once)."""
        seeds = list(self._seeds)
        options = self._options
        if all(o == options[0] for o in options):
            obs, _ = self.env.reset(seed=seeds, options=dict(options[0]) or None)
        else:  # different options per environment: one masked reset each (with its own seed)
            for i, opt in enumerate(options):
                mask = np.zeros(self.num_envs, dtype=bool)
                mask[i] = True
                obs, _ = self.env.reset(seed=seeds, options={**opt, "reset_mask": mask})
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions[:] = actions

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, terminated, truncated, info = self.env.step(self._actions)
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if dones.any():
            rows = dones.nonzero()[0]
            final, final_obs = info["final_info"], info["final_obs"]
            time_limit = (truncated & ~terminated)[rows].tolist()
            values = [final[key][rows].tolist() for key in FINAL_INFO_KEYS]
            for n, i in enumerate(rows.tolist()):
                infos[i] = {
                    "terminal_observation": final_obs[i],
                    "TimeLimit.truncated": time_limit[n],
                    **{key: column[n] for key, column in zip(FINAL_INFO_KEYS, values)},
                }
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.env.close()

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The vector environment's attribute, once per index (all walkers share it)."""
        value = getattr(self.env, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        raise AttributeError(f"WalkerVecEnv: attributes of the shared vector environment cannot be set ({attr_name})")

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any) -> list[Any]:
        raise AttributeError(f"WalkerVecEnv: no per-environment methods ({method_name}); use the vector environment")

    def env_is_wrapped(self, wrapper_class: type[gymnasium.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]


class PerEnvVecMonitor(VecMonitor):
    """SB3's ``VecMonitor`` (episode statistics in ``info["episode"]``) writing one Monitor CSV per
    environment, ``<folder>/<i>.monitor.csv`` (return, length, wall time and ``info_keywords``), as
    ``make_vec_env(monitor_dir=...)`` does for single environments — the layout
    :func:`agents.plot_learning_curve.read_monitor` reads. ``append=True`` continues existing files
    (``--resume``)."""

    def __init__(self, venv: VecEnv, folder: str | Path, info_keywords: tuple[str, ...] = (), append: bool = False) -> None:
        super().__init__(venv, None, info_keywords)
        header = {"t_start": self.t_start, "env_id": "sspinn/SagittalWalker-v0 (vector)"}
        self.writers = [
            ResultsWriter(str(Path(folder) / str(i)), header=header, extra_keys=info_keywords, override_existing=not append)
            for i in range(self.num_envs)
        ]

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, dones, infos = super().step_wait()
        for i in np.flatnonzero(dones):
            self.writers[i].write_row(infos[i]["episode"])
        return obs, rewards, dones, infos

    def close(self) -> None:
        for writer in self.writers:
            writer.close()
        super().close()


__all__ = ["FINAL_INFO_KEYS", "PerEnvVecMonitor", "WalkerVecEnv"]
