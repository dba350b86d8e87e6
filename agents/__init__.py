"""Stable-Baselines3 agents for ``sspinn/SagittalWalker-v0``.

Command line (``python -m agents --help``)::

    python -m agents train --algo ppo --config configs/agents/ppo.yaml --out runs/ppo [--resume | --overwrite]
    python -m agents evaluate --checkpoint runs/ppo/best_model.zip --episodes 5 --out runs/ppo/eval
    python -m agents record --checkpoint runs/ppo/best_model.zip --out walk.gif

Modules: :mod:`agents.config` (YAML → typed, validated configuration), :mod:`agents.builders`
(what a configuration builds: environment, SB3 class, network, hyperparameters),
:mod:`agents.train` (training script), :mod:`agents.rollout` (deterministic episodes and walking
metrics), :mod:`agents.evaluate` (evaluation report, plots and animation),
:mod:`agents.checkpoints` (run-directory layout, saving and loading agents without running code
from their files), :mod:`agents.plot_learning_curve`.
Importing this package imports neither torch nor stable-baselines3 (the names below are imported
on first use). In Python: ``agents.train_agent(agents.load_config(PATH), OUT)``,
``agents.evaluate_agent(CHECKPOINT, OUT)``, ``agents.load_agent(CHECKPOINT).predict(obs)``
(``train_agent`` and ``evaluate_agent`` are :func:`agents.train.train` and
:func:`agents.evaluate.evaluate`: a package name cannot be the name of one of its modules).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from agents.config import AgentConfig, ConfigError, config_from_dict, load_config
from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    "train_agent": "agents.train:train",
    "evaluate_agent": "agents.evaluate:evaluate",
    "record_agent": "agents.evaluate:record",
    **dict.fromkeys(("LoadedAgent", "load_agent",), "agents.checkpoints"),
    **dict.fromkeys(("EpisodeResult", "run_episode",), "agents.rollout"),
    **dict.fromkeys(("make_env",), "agents.builders"),
}
__all__ = [
    "AgentConfig",
    "ConfigError",
    "EpisodeResult",
    "LoadedAgent",
    "config_from_dict",
    "evaluate_agent",
    "load_agent",
    "load_config",
    "make_env",
    "record_agent",
    "run_episode",
    "train_agent",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from agents.builders import make_env
    from agents.checkpoints import LoadedAgent, load_agent
    from agents.evaluate import evaluate as evaluate_agent
    from agents.evaluate import record as record_agent
    from agents.rollout import EpisodeResult, run_episode
    from agents.train import train as train_agent

__getattr__, __dir__ = attach(__name__, _EXPORTS)
