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
Importing this package imports neither torch nor stable-baselines3.
"""

from agents.config import AgentConfig, ConfigError, config_from_dict, load_config

__all__ = ["AgentConfig", "ConfigError", "config_from_dict", "load_config"]
