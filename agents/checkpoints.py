"""Where a run keeps its files, and loading a saved agent as a deterministic policy.

Layout of a run directory ``<out>`` written by :mod:`agents.train`::

    <out>/config.yaml                          the validated configuration
    <out>/checkpoints/model_<steps>_steps.zip   periodic checkpoints (SB3 CheckpointCallback)
    <out>/checkpoints/model_vecnormalize_<steps>_steps.pkl   their VecNormalize statistics
    <out>/checkpoints/model_replay_buffer_<steps>_steps.pkl  SAC/TD3 replay buffer (if kept)
    <out>/best_model.zip, best_vecnormalize.pkl  best periodic evaluation (mean return)
    <out>/final_model.zip, final_vecnormalize.pkl  end of training
    <out>/evaluations.csv                      one row per periodic evaluation
    <out>/monitor/<i>.monitor.csv              training episodes of environment i (SB3 Monitor / PerEnvVecMonitor)
    <out>/tb/                                  TensorBoard event files

Loading for evaluation (:func:`load_agent`) runs no code from the files: SB3 stores some
attributes of a model (its spaces, policy class and keyword arguments, schedules, buffers) with
cloudpickle, which would execute whatever a crafted ``.zip`` holds; :func:`safe_custom_objects`
replaces every such attribute by the value rebuilt from the run's ``config.yaml`` (the network
weights themselves are read by SB3 with ``torch.load(weights_only=True)``), and a pickled
attribute it does not know is refused. The VecNormalize statistics (a pickle) are read by
:class:`_StatisticsUnpickler`, which admits only the classes a VecNormalize pickle consists of.
"""

from __future__ import annotations

import collections
import json
import pickle
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.config import ALGORITHMS, AgentConfig, ConfigError, load_config
from sspinn.errors import UserError

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
    model = cls.load(path, device=device, custom_objects=safe_custom_objects(path, config))
    agent = LoadedAgent(model=model, config=config)
    stats = vecnormalize_path(path)
    if stats.is_file():
        vec_normalize = load_statistics(stats)
        if vec_normalize.norm_obs:
            agent.obs_mean = np.asarray(vec_normalize.obs_rms.mean, dtype=np.float64)
            agent.obs_var = np.asarray(vec_normalize.obs_rms.var, dtype=np.float64)
            agent.clip_obs = float(vec_normalize.clip_obs)
            agent.epsilon = float(vec_normalize.epsilon)
    elif config.normalize.obs:
        raise FileNotFoundError(f"{path} was trained with observation normalisation but {stats} is missing")
    return agent


class UnsafeCheckpointError(UserError):
    """A saved agent that cannot be loaded without running code from it (or is not one)."""


def safe_custom_objects(checkpoint: str | Path, config: AgentConfig) -> dict[str, Any]:
    """SB3 ``custom_objects`` replacing every cloudpickled attribute of ``checkpoint`` with a value
    rebuilt from ``config``, so that loading unpickles nothing. Raises UnsafeCheckpointError for a
    file that is not an SB3 checkpoint or holds a pickled attribute not known here."""
    import stable_baselines3
    from stable_baselines3.common import buffers
    from stable_baselines3.common.type_aliases import TrainFreq, TrainFrequencyUnit

    from agents.train import make_env, policy_kwargs

    path = Path(checkpoint)
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError, UnicodeDecodeError, OSError) as exc:
        raise UnsafeCheckpointError(f"{path}: not an SB3 checkpoint (.zip with a 'data' entry): {exc}") from None
    if not isinstance(data, dict):
        raise UnsafeCheckpointError(f"{path}: not an SB3 checkpoint (its 'data' is not a JSON object)")
    pickled = [k for k, v in data.items() if isinstance(v, dict) and ":serialized:" in v]
    cls = getattr(stable_baselines3, ALGORITHMS[config.algo])
    env = make_env(config)
    try:
        spaces = {"observation_space": env.observation_space, "action_space": env.action_space}
    finally:
        env.close()

    def constant(_: float) -> float:
        return 0.0  # schedules only matter for training; a loaded agent is evaluated

    known: dict[str, Any] = {
        **spaces,
        "policy_class": cls.policy_aliases["MlpPolicy"],
        "policy_kwargs": policy_kwargs(config),
        "lr_schedule": constant, "clip_range": constant, "clip_range_vf": None, "exploration_schedule": constant,
        "rollout_buffer_class": buffers.RolloutBuffer, "replay_buffer_class": buffers.ReplayBuffer,
        "train_freq": TrainFreq(1, TrainFrequencyUnit.STEP),  # SAC/TD3 training cadence (not used to evaluate)
        "action_noise": None, "_last_obs": None, "_last_episode_starts": None, "_last_original_obs": None,
        "ep_info_buffer": collections.deque(maxlen=100), "ep_success_buffer": collections.deque(maxlen=100),
    }
    unknown = [k for k in pickled if k not in known]
    if unknown:
        raise UnsafeCheckpointError(
            f"{path}: holds pickled Python objects {unknown} that would run code when loaded; refusing "
            "(only load agents trained with `python -m agents train`)"
        )
    return {k: known[k] for k in pickled}


#: The globals a VecNormalize pickle consists of (module, name); nothing else is unpickled.
_STATISTICS_GLOBALS = frozenset({
    ("stable_baselines3.common.vec_env.vec_normalize", "VecNormalize"),
    ("stable_baselines3.common.running_mean_std", "RunningMeanStd"),
    ("gymnasium.spaces.box", "Box"),
    ("collections", "OrderedDict"),
    ("numpy", "dtype"), ("numpy", "ndarray"),
    *((m, n) for m in ("numpy.core.multiarray", "numpy._core.multiarray") for n in ("_reconstruct", "scalar")),
    ("numpy.random._pickle", "__generator_ctor"), ("numpy.random._pickle", "__bit_generator_ctor"),
    ("numpy.random._pickle", "__randomstate_ctor"),
    *(("numpy.random._" + g.lower(), g) for g in ("PCG64", "MT19937", "Philox", "SFC64")),
    ("numpy.random._pcg64", "PCG64DXSM"),
    ("numpy.random.bit_generator", "SeedSequence"), ("numpy.random.bit_generator", "__pyx_unpickle_SeedSequence"),
})


class _StatisticsUnpickler(pickle.Unpickler):
    """Unpickles only :data:`_STATISTICS_GLOBALS` (a VecNormalize and its parts)."""

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in _STATISTICS_GLOBALS:
            raise pickle.UnpicklingError(f"refusing to load {module}.{name}")
        return super().find_class(module, name)


def load_statistics(path: str | Path) -> Any:
    """The VecNormalize saved at ``path``, unpickling nothing but its own classes."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            return _StatisticsUnpickler(fh).load()
    except pickle.UnpicklingError as exc:
        raise UnsafeCheckpointError(
            f"{path}: not VecNormalize statistics ({exc}); refusing to run code from it "
            "(only load agents trained with `python -m agents train`)"
        ) from None
    except (EOFError, ValueError, TypeError, AttributeError, IndexError, KeyError) as exc:
        raise UnsafeCheckpointError(f"{path}: damaged VecNormalize statistics ({type(exc).__name__}: {exc})") from None
