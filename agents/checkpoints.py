"""Where a run keeps its files, and loading a saved agent as a deterministic policy.

Layout of a run directory ``<out>`` written by :mod:`agents.train`::

    <out>/config.yaml                          the validated configuration
    <out>/checkpoints/model_<steps>_steps.zip   periodic checkpoints (SB3 CheckpointCallback)
    <out>/checkpoints/model_vecnormalize_<steps>_steps.pkl   their VecNormalize statistics
    <out>/checkpoints/model_replay_buffer_<steps>_steps.pkl  SAC/TD3 replay buffer (if kept)
    <out>/best_model.zip, best_vecnormalize.pkl  best periodic evaluation (mean return)
    <out>/final_model.zip, final_vecnormalize.pkl  end of training
    <out>/evaluations.csv                      one row per periodic evaluation
    <out>/monitor/<i>.monitor.csv              training episodes of environment i (SB3 Monitor)
    <out>/tb/                                  TensorBoard event files
"""

from __future__ import annotations

import pickle
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agents.config import ALGORITHMS, AgentConfig, ConfigError, load_config

CHECKPOINT_DIR = "checkpoints"
CHECKPOINT_PREFIX = "model"
CONFIG_FILE = "config.yaml"
_STEPS = re.compile(r"^(?P<prefix>.+)_(?P<steps>\d+)_steps\.zip$")


def vecnormalize_path(model_path: str | Path) -> Path:
    """The VecNormalize statistics saved next to ``model_path`` (whether or not the file exists)."""
    path = Path(model_path)
    match = _STEPS.match(path.name)
    if match:
        return path.with_name(f"{match['prefix']}_vecnormalize_{match['steps']}_steps.pkl")
    stem = path.name.removesuffix(".zip").removesuffix("_model")
    return path.with_name(f"{stem}_vecnormalize.pkl")


def replay_buffer_path(checkpoint: str | Path) -> Path:
    """The replay buffer that SB3's CheckpointCallback saves next to a periodic checkpoint."""
    path = Path(checkpoint)
    match = _STEPS.match(path.name)
    if not match:
        raise ValueError(f"{path.name} is not a periodic checkpoint (<prefix>_<steps>_steps.zip)")
    return path.with_name(f"{match['prefix']}_replay_buffer_{match['steps']}_steps.pkl")


def checkpoint_steps(checkpoint: str | Path) -> int:
    """Timesteps in the name of a periodic checkpoint."""
    match = _STEPS.match(Path(checkpoint).name)
    if not match:
        raise ValueError(f"{Path(checkpoint).name} is not a periodic checkpoint (<prefix>_<steps>_steps.zip)")
    return int(match["steps"])


def latest_checkpoint(run_dir: str | Path) -> Path | None:
    """The periodic checkpoint with the most timesteps in ``<run_dir>/checkpoints`` (None if none)."""
    folder = Path(run_dir) / CHECKPOINT_DIR
    found = [(int(m["steps"]), p) for p in folder.glob(f"{CHECKPOINT_PREFIX}_*_steps.zip") if (m := _STEPS.match(p.name))]
    return max(found)[1] if found else None


def find_config(checkpoint: str | Path) -> AgentConfig:
    """The ``config.yaml`` of the run that wrote ``checkpoint`` (its folder or one of two parents)."""
    path = Path(checkpoint).resolve()
    for folder in list(path.parents)[:3]:
        if (folder / CONFIG_FILE).is_file():
            return load_config(folder / CONFIG_FILE)
    raise ConfigError(f"no {CONFIG_FILE} found next to {checkpoint} or in its two parent folders")


@dataclass
class LoadedAgent:
    """A saved SB3 model with its observation normalisation, callable as a deterministic policy."""

    model: object
    config: AgentConfig
    obs_mean: np.ndarray | None = None
    obs_var: np.ndarray | None = None
    clip_obs: float = 10.0
    epsilon: float = 1e-8

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """Observation as the network saw it in training (VecNormalize statistics, frozen)."""
        if self.obs_mean is None or self.obs_var is None:
            return obs
        scaled = (obs - self.obs_mean) / np.sqrt(self.obs_var + self.epsilon)
        return np.clip(scaled, -self.clip_obs, self.clip_obs).astype(np.float32)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        action, _ = self.model.predict(self.normalize(obs), deterministic=True)  # type: ignore[attr-defined]
        return action


def load_agent(checkpoint: str | Path, config: AgentConfig | None = None, device: str = "cpu") -> LoadedAgent:
    """Load ``checkpoint`` (an SB3 ``.zip``) and, if present, its VecNormalize statistics.

    ``config`` defaults to the run's ``config.yaml`` (:func:`find_config`); it names the algorithm
    and the environment arguments used for evaluation.
    """
    import stable_baselines3

    path = Path(checkpoint)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {path} does not exist")
    config = config if config is not None else find_config(path)
    cls = getattr(stable_baselines3, ALGORITHMS[config.algo])
    model = cls.load(path, device=device)
    agent = LoadedAgent(model=model, config=config)
    stats = vecnormalize_path(path)
    if stats.is_file():
        with stats.open("rb") as fh:
            vec_normalize = pickle.load(fh)  # noqa: S301 (our own training output)
        if vec_normalize.norm_obs:
            agent.obs_mean = np.asarray(vec_normalize.obs_rms.mean, dtype=np.float64)
            agent.obs_var = np.asarray(vec_normalize.obs_rms.var, dtype=np.float64)
            agent.clip_obs = float(vec_normalize.clip_obs)
            agent.epsilon = float(vec_normalize.epsilon)
    elif config.normalize.obs:
        raise FileNotFoundError(f"{path} was trained with observation normalisation but {stats} is missing")
    return agent
