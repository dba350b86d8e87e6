"""What an :class:`agents.config.AgentConfig` builds: the environment, the SB3 algorithm class,
its network (``policy_kwargs``) and keyword arguments, and the value of any hyperparameter
(the configuration's, else the SB3 class's default).

Shared by training (:mod:`agents.train`), by loading a saved agent without unpickling anything
(:mod:`agents.checkpoints`, which rebuilds every pickled attribute of a checkpoint from these) and
by evaluation (:mod:`agents.evaluate`). Imports torch and stable-baselines3 only when called.
"""

from __future__ import annotations

import inspect
from typing import Any

import gymnasium
import numpy as np

from agents.config import ACTIVATIONS, ALGORITHMS, AgentConfig

#: Evaluations at target speeds below this (m/s) compare the joint angles with Winter's walking.
WALKING_BELOW_M_S = 2.0


def env_kwargs(config: AgentConfig, **overrides: Any) -> dict[str, Any]:
    """The environment's constructor arguments: ``env.kwargs`` with ``overrides`` winning."""
    return {**config.env.kwargs, **overrides}


def make_env(config: AgentConfig, render_mode: str | None = None, **overrides: Any) -> gymnasium.Env:
    """One environment with the configuration's constructor arguments (``overrides`` win).

    ``max_episode_steps`` sets both Gymnasium's ``TimeLimit`` (``gymnasium.make`` takes that
    keyword for itself) and, for ``sspinn/SagittalWalker-v0``, the environment's own episode length,
    so that the two agree."""
    import envs
    from envs.config import WalkerConfig

    kwargs = env_kwargs(config, **overrides)
    steps = kwargs.pop("max_episode_steps", None)
    if steps is not None and config.env.id == envs.ENV_ID:
        kwargs["config"] = WalkerConfig(max_episode_steps=steps)
    return gymnasium.make(config.env.make_id, max_episode_steps=steps, **kwargs, render_mode=render_mode)


def algorithm_class(config: AgentConfig) -> type:
    """The SB3 class of ``config.algo`` (``stable_baselines3.PPO``, ``SAC`` or ``TD3``)."""
    import stable_baselines3

    return getattr(stable_baselines3, ALGORITHMS[config.algo])


def hyperparameter(config: AgentConfig, name: str) -> Any:
    """``hyperparameters[name]`` of ``config``, else the default of the SB3 class's argument."""
    if name in config.hyperparameters:
        return config.hyperparameters[name]
    parameter = inspect.signature(algorithm_class(config).__init__).parameters.get(name)
    if parameter is None:
        raise KeyError(f"stable_baselines3.{ALGORITHMS[config.algo]} has no argument {name!r}")
    return parameter.default


def policy_kwargs(config: AgentConfig) -> dict[str, Any]:
    """SB3 ``policy_kwargs``: separate actor and critic networks of ``net_arch``, activation, init,
    the optimiser's keyword arguments."""
    import torch

    p = config.policy
    arch = list(p.net_arch)
    kwargs: dict[str, Any] = {
        "net_arch": {"pi": arch, "vf": arch} if config.algo == "ppo" else {"pi": arch, "qf": arch},
        "activation_fn": getattr(torch.nn, ACTIVATIONS[p.activation]),
    }
    if p.log_std_init is not None:
        kwargs["log_std_init"] = p.log_std_init
    if p.ortho_init is not None:
        kwargs["ortho_init"] = p.ortho_init
    if p.optimizer_kwargs:
        # SB3's PPO policy gives Adam eps = 1e-5 only when it is handed no optimizer_kwargs: kept
        defaults = {"eps": 1e-5} if config.algo == "ppo" else {}
        kwargs["optimizer_kwargs"] = {**defaults, **p.optimizer_kwargs}
    return kwargs


def action_noise(config: AgentConfig, n_actions: int) -> Any:
    """The exploration noise of ``hyperparameters.action_noise``: a number becomes Gaussian noise
    of that standard deviation (normalised action units); None (the default) is none."""
    from stable_baselines3.common.noise import NormalActionNoise

    noise = config.hyperparameters.get("action_noise")
    if isinstance(noise, (int, float)) and not isinstance(noise, bool):
        return NormalActionNoise(np.zeros(n_actions), float(noise) * np.ones(n_actions))
    return noise


def algorithm_kwargs(config: AgentConfig, n_actions: int) -> dict[str, Any]:
    """SB3 keyword arguments from ``hyperparameters`` (``action_noise`` as :func:`action_noise`)."""
    kwargs = dict(config.hyperparameters)
    if "action_noise" in kwargs:
        kwargs["action_noise"] = action_noise(config, n_actions)
    return kwargs


__all__ = ["action_noise", "algorithm_class", "algorithm_kwargs", "hyperparameter", "make_env", "policy_kwargs"]
