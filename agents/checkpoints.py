"""Where a run keeps its files, and loading a saved agent as a deterministic policy.

Layout of a run directory ``<out>`` written by :mod:`agents.train`::

    <out>/config.yaml                          the validated configuration
    <out>/checkpoints/model_<steps>_steps.zip   periodic checkpoints (agents.train.PeriodicCheckpoint)
    <out>/checkpoints/model_vecnormalize_<steps>_steps.pkl   their VecNormalize statistics
    <out>/checkpoints/model_replay_buffer_<steps>_steps.pkl  SAC/TD3 replay buffer (if kept)
    <out>/best_model.zip, best_vecnormalize.pkl  best periodic evaluation (mean return)
    <out>/final_model.zip, final_vecnormalize.pkl  end of training
    <out>/evaluations.csv                      one row per periodic evaluation
    <out>/monitor/<i>.monitor.csv              training episodes of environment i (SB3 Monitor / PerEnvVecMonitor)
    <out>/tb/                                  TensorBoard event files

Loading runs no code from the files, for evaluation (:func:`load_agent`) as for ``train
--resume`` (:func:`load_algorithm`, :func:`load_statistics`, :func:`restore_replay_buffer`): SB3
stores some attributes of a model (its spaces, policy class and keyword arguments, schedules,
buffers, exploration noise) with cloudpickle, which would execute whatever a crafted ``.zip``
holds; :func:`safe_custom_objects` replaces every such attribute by the value rebuilt from the
run's configuration (:mod:`agents.builders`; the network weights themselves are read by SB3 with
``torch.load(weights_only=True)``), and a pickled attribute it does not know is refused. The
VecNormalize statistics and the replay buffer (pickles) are read by an unpickler that admits only
the classes such a pickle consists of (:data:`STATISTICS_GLOBALS`, :data:`REPLAY_BUFFER_GLOBALS`).

Writing (:func:`save_checkpoint`) is atomic per file (:func:`sspinn.run_folder.atomic_path`), the
model's ``.zip`` last: a checkpoint whose ``.zip`` exists has its statistics and buffer complete.
"""

from __future__ import annotations

import csv
import io
import json
import pickle
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from agents.builders import action_noise, algorithm_class, hyperparameter, make_env, policy_kwargs
from agents.config import DIFF_ALGORITHMS, AgentConfig, ConfigError, load_config, save_config
from agents.rollout import SUMMARY_GAIT_KEYS
from sspinn.errors import UserError, one_line
from sspinn.run_folder import atomic_path, atomic_write_text, claim_run_folder

if TYPE_CHECKING:  # imports stable-baselines3, which loading waits for
    from agents.gait_prior import GaitPrior

CHECKPOINT_DIR = "checkpoints"
CHECKPOINT_PREFIX = "model"
CONFIG_FILE = "config.yaml"
_STEPS = re.compile(r"^(?P<prefix>.+)_(?P<steps>\d+)_steps\.(?:zip|pt)$")


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


def latest_checkpoint(run_dir: str | Path, suffix: str = ".zip") -> Path | None:
    """The periodic checkpoint with the most timesteps in ``<run_dir>/checkpoints`` (None if none):
    SB3's ``.zip`` files, or with ``suffix=".pt"`` those of :mod:`agents.diff`."""
    folder = Path(run_dir) / CHECKPOINT_DIR
    found = [(int(m["steps"]), p) for p in folder.glob(f"{CHECKPOINT_PREFIX}_*_steps{suffix}") if (m := _STEPS.match(p.name))]
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
    """A saved SB3 model with its observation normalisation, as a deterministic policy.

    :meth:`predict` follows SB3's convention, ``predict(observation, state=None,
    episode_start=None, deterministic=True) → (action, state)``: the state is the agent's memory
    of the episode — the gait clock of an agent trained with ``prior.clock``
    (:mod:`agents.gait_prior`), None otherwise — and starts afresh where ``episode_start`` is True
    or ``state`` is None, so one agent drives any number of episodes. Calling the agent,
    ``agent(observation)``, is the memoryless shortcut of agents without a clock.

    Attributes:
        model: the SB3 model. config: its run's configuration.
        obs_mean, obs_var, clip_obs, epsilon: the VecNormalize statistics (None: not normalised).
        prior: the gait prior whose clock the policy observes (None: no clock), with its
            feedforward, if any, added to the policy's actions.
    """

    model: object
    config: AgentConfig
    obs_mean: np.ndarray | None = None
    obs_var: np.ndarray | None = None
    clip_obs: float = 10.0
    epsilon: float = 1e-8
    prior: GaitPrior | None = None

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """Observation as the network saw it in training (VecNormalize statistics, frozen)."""
        if self.obs_mean is None or self.obs_var is None:
            return obs
        scaled = (obs - self.obs_mean) / np.sqrt(self.obs_var + self.epsilon)
        return np.clip(scaled, -self.clip_obs, self.clip_obs).astype(np.float32)

    @property
    def initial_state(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(q, u) where this agent's episodes start (``env.reset(options={"initial_state": ...})``):
        a clock agent's reference stride's first sample; None (standing) otherwise."""
        return None if self.prior is None else self.prior.start_state()

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        """Action(s) for an observation (22,) or a batch (n, 22), and the state to pass back next step."""
        obs = np.asarray(observation, dtype=np.float32)
        if self.prior is not None:
            batch = obs.reshape(-1, obs.shape[-1])
            n = len(batch)
            starts = np.ones(n, dtype=bool) if state is None else np.broadcast_to(
                np.asarray(False if episode_start is None else episode_start, dtype=bool).reshape(-1), (n,))
            phase = np.zeros(n, dtype=np.int64) if state is None else (np.asarray(state, dtype=np.int64) + 1)
            phase = phase % self.prior.period_steps
            if starts.any():
                phase[starts] = self.prior.start_phase(batch[starts])
            clocked = self.prior.policy_input(batch, phase)
            action, _ = self.model.predict(self.normalize(clocked), deterministic=deterministic)  # type: ignore[attr-defined]
            action = self.prior.act(np.asarray(action).reshape(n, -1), phase)
            return action.reshape(*obs.shape[:-1], -1), phase
        action, _ = self.model.predict(self.normalize(obs), deterministic=deterministic)  # type: ignore[attr-defined]
        return action, state

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if self.prior is not None:
            raise TypeError("this agent observes a gait clock: drive it with predict(observation, state, episode_start)")
        return self.predict(obs)[0]


def load_agent(checkpoint: str | Path, config: AgentConfig | None = None, device: str = "cpu") -> LoadedAgent:
    """Load ``checkpoint`` (an SB3 ``.zip``) and, if present, its VecNormalize statistics.

    ``config`` defaults to the run's ``config.yaml`` (:func:`find_config`); it names the algorithm
    and the environment arguments used for evaluation.
    """
    path = Path(checkpoint)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {path} does not exist")
    config = config if config is not None else find_config(path)

    if config.algo in DIFF_ALGORITHMS:  # learned through the differentiable simulator: a .pt of tensors
        from agents.diff.agent import DiffAgent

        return DiffAgent.load(path, config=config)  # type: ignore[return-value]  # same predict protocol
    from agents.gait_prior import load_prior

    prior = load_prior(config) if config.prior.clock else None
    agent = LoadedAgent(model=load_algorithm(path, config, device=device), config=config, prior=prior)
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


def append_csv_row(path: str | Path, row: dict[str, Any], columns: tuple[str, ...]) -> None:
    """Append ``row`` to the CSV log ``path`` (atomically rewritten); a new file gets ``columns`` as
    its header, an existing one keeps its own (a resumed run's)."""
    path = Path(path)
    previous = path.read_text() if path.is_file() else ""
    if previous:
        columns = tuple(next(csv.reader(io.StringIO(previous)), columns))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    if not previous:
        writer.writeheader()
    writer.writerow(row)
    atomic_write_text(path, previous + buffer.getvalue())


class UnsafeCheckpointError(UserError):
    """A saved agent that cannot be loaded without running code from it (or is not one)."""


#: How to load only agents this project wrote (the end of every refusal).
_ONLY_OURS = "only load agents trained with `python -m agents train`"


def load_algorithm(checkpoint: str | Path, config: AgentConfig, env: Any = None, device: str = "cpu", **kwargs: Any) -> Any:
    """The SB3 model saved in ``checkpoint``, loaded without unpickling anything
    (:func:`safe_custom_objects`); ``env`` (a VecEnv, to continue training) and ``kwargs`` go to
    ``<Algorithm>.load``. A file that is not such a checkpoint, or whose network does not fit
    ``config``, raises :class:`UnsafeCheckpointError` with one line."""
    path = Path(checkpoint)
    custom = safe_custom_objects(path, config)
    try:
        return algorithm_class(config).load(path, env=env, device=device, custom_objects=custom, **kwargs)
    except pickle.UnpicklingError:  # torch.load(weights_only=True) met something other than tensors
        raise UnsafeCheckpointError(
            f"{path}: holds data other than network weights that would run code when loaded; refusing ({_ONLY_OURS})"
        ) from None
    except (RuntimeError, ValueError, KeyError, AssertionError, EOFError, zipfile.BadZipFile) as exc:
        raise UnsafeCheckpointError(
            f"{path}: not a {config.algo} checkpoint of this configuration ({type(exc).__name__}: {one_line(exc)[:300]})"
        ) from None


def safe_custom_objects(checkpoint: str | Path, config: AgentConfig) -> dict[str, Any]:
    """SB3 ``custom_objects`` replacing every cloudpickled attribute of ``checkpoint`` with the value
    rebuilt from ``config`` (as :mod:`agents.train` built it, so that training can continue from
    them), so that loading unpickles nothing. Raises UnsafeCheckpointError for a file that is not
    an SB3 checkpoint or holds a pickled attribute not known here."""
    path = Path(checkpoint)
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError, UnicodeDecodeError, OSError) as exc:
        raise UnsafeCheckpointError(f"{path}: not an SB3 checkpoint (.zip with a 'data' entry): {exc}") from None
    if not isinstance(data, dict):
        raise UnsafeCheckpointError(f"{path}: not an SB3 checkpoint (its 'data' is not a JSON object)")
    pickled = [k for k, v in data.items() if isinstance(v, dict) and ":serialized:" in v]
    unknown = [k for k in pickled if k not in _REBUILT]
    if unknown:
        raise UnsafeCheckpointError(
            f"{path}: holds pickled Python objects {unknown} that would run code when loaded; refusing ({_ONLY_OURS})"
        )
    from stable_baselines3.common.utils import FloatSchedule

    from agents.gait_prior import clock_space

    env = make_env(config)
    try:
        observation_space = clock_space(env.observation_space) if config.prior.clock else env.observation_space
        spaces = {"observation_space": observation_space, "action_space": env.action_space}
    finally:
        env.close()
    network = policy_kwargs(config)
    saved = data.get("policy_kwargs")
    if isinstance(saved, dict) and "use_sde" in saved:  # SB3 adds it for algorithms with gSDE support (SAC)
        network["use_sde"] = bool(hyperparameter(config, "use_sde"))
    train_freq = hyperparameter(config, "train_freq") if "train_freq" in pickled else None
    known: dict[str, Any] = {
        **spaces,
        "policy_class": algorithm_class(config).policy_aliases["MlpPolicy"],
        "policy_kwargs": network,
        # schedules: the constants of the configuration (SB3's _setup_model wraps them again)
        "lr_schedule": FloatSchedule(hyperparameter(config, "learning_rate")) if "lr_schedule" in pickled else None,
        "clip_range": hyperparameter(config, "clip_range") if "clip_range" in pickled else None,
        "clip_range_vf": hyperparameter(config, "clip_range_vf") if "clip_range_vf" in pickled else None,
        "train_freq": tuple(train_freq) if isinstance(train_freq, list) else train_freq,
        "action_noise": action_noise(config, spaces["action_space"].shape[0]),
        # SB3 picks the buffer classes as it did when the model was made (None → its default)
        "rollout_buffer_class": None, "replay_buffer_class": None,
        # training state that SB3 rebuilds on the next learn() (the environments are reset)
        "_last_obs": None, "_last_episode_starts": None, "_last_original_obs": None,
        "ep_info_buffer": None, "ep_success_buffer": None,
    }
    return {k: known[k] for k in pickled}


#: The pickled attributes of an SB3 checkpoint that :func:`safe_custom_objects` rebuilds.
_REBUILT = frozenset({
    "observation_space", "action_space", "policy_class", "policy_kwargs", "lr_schedule", "clip_range",
    "clip_range_vf", "train_freq", "action_noise", "rollout_buffer_class", "replay_buffer_class", "_last_obs",
    "_last_episode_starts", "_last_original_obs", "ep_info_buffer", "ep_success_buffer",
})

#: numpy's parts of a pickle: arrays, dtypes, scalars and random generators (module, name).
_NUMPY_GLOBALS = frozenset({
    ("numpy", "dtype"), ("numpy", "ndarray"),
    *((m, n) for m in ("numpy.core.multiarray", "numpy._core.multiarray") for n in ("_reconstruct", "scalar")),
    *((m, "_frombuffer") for m in ("numpy.core.numeric", "numpy._core.numeric")),
    ("numpy.random._pickle", "__generator_ctor"), ("numpy.random._pickle", "__bit_generator_ctor"),
    ("numpy.random._pickle", "__randomstate_ctor"),
    *(("numpy.random._" + g.lower(), g) for g in ("PCG64", "MT19937", "Philox", "SFC64")),
    ("numpy.random._pcg64", "PCG64DXSM"),
    ("numpy.random.bit_generator", "SeedSequence"), ("numpy.random.bit_generator", "__pyx_unpickle_SeedSequence"),
    ("gymnasium.spaces.box", "Box"),
})
#: The globals a VecNormalize pickle consists of (module, name); nothing else is unpickled.
STATISTICS_GLOBALS = _NUMPY_GLOBALS | {
    ("stable_baselines3.common.vec_env.vec_normalize", "VecNormalize"),
    ("stable_baselines3.common.running_mean_std", "RunningMeanStd"),
    ("collections", "OrderedDict"),
}
#: The globals an SB3 replay buffer pickle consists of (module, name).
REPLAY_BUFFER_GLOBALS = _NUMPY_GLOBALS | {
    ("stable_baselines3.common.buffers", "ReplayBuffer"),
    ("stable_baselines3.common.buffers", "NStepReplayBuffer"),
    ("torch", "device"),
}


class _RefusedGlobal(pickle.UnpicklingError):
    """A pickle refers to a class or function outside the allow-list (it could run code)."""


class _AllowListUnpickler(pickle.Unpickler):
    """Unpickles only the globals in ``allowed``; any other refers to code and is refused."""

    def __init__(self, file: io.BufferedIOBase, allowed: frozenset[tuple[str, str]]) -> None:
        super().__init__(file)
        self.allowed = allowed

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in self.allowed:
            raise _RefusedGlobal(f"refusing to load {module}.{name}")
        return super().find_class(module, name)


def _unpickle(path: str | Path, allowed: frozenset[tuple[str, str]], what: str, cls: type) -> Any:
    """The ``cls`` instance pickled at ``path``, unpickling nothing outside ``allowed``."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            value = _AllowListUnpickler(fh, allowed).load()
    except _RefusedGlobal as exc:
        raise UnsafeCheckpointError(f"{path}: not {what} ({exc}); refusing to run code from it ({_ONLY_OURS})") from None
    except (OSError, MemoryError):
        raise
    except Exception as exc:  # noqa: BLE001 - whatever a damaged pickle raises, one line
        raise UnsafeCheckpointError(f"{path}: damaged {what} ({type(exc).__name__}: {one_line(exc)[:200]})") from None
    if not isinstance(value, cls):
        raise UnsafeCheckpointError(f"{path}: not {what} (it holds a {type(value).__name__})")
    return value


def load_statistics(path: str | Path) -> Any:
    """The VecNormalize saved at ``path``, unpickling nothing but its own classes (without its
    environments: give it the training environments with ``set_venv`` to continue training)."""
    from stable_baselines3.common.vec_env import VecNormalize

    return _unpickle(path, STATISTICS_GLOBALS, "VecNormalize statistics", VecNormalize)


def load_replay_buffer(path: str | Path) -> Any:
    """The SB3 replay buffer saved at ``path``, unpickling nothing but its own classes."""
    from stable_baselines3.common.buffers import ReplayBuffer

    return _unpickle(path, REPLAY_BUFFER_GLOBALS, "an SB3 replay buffer", ReplayBuffer)


def restore_replay_buffer(model: Any, path: str | Path) -> None:
    """Give ``model`` (SAC/TD3 about to continue training) the replay buffer saved at ``path``
    (:func:`load_replay_buffer`); UnsafeCheckpointError if its shapes do not fit the model."""
    buffer = load_replay_buffer(path)
    expected = ((model.n_envs, *model.observation_space.shape), (model.n_envs, *model.action_space.shape))
    found = (tuple(np.shape(buffer.observations))[1:], tuple(np.shape(buffer.actions))[1:])
    if found != expected:
        raise UnsafeCheckpointError(
            f"{path}: replay buffer of (envs, observation) {found[0]} and (envs, action) {found[1]} does not fit "
            f"this run's {expected[0]} and {expected[1]}; delete it to continue without it"
        )
    buffer.device = model.device
    model.replay_buffer = buffer


def save_checkpoint(model: Any, path: str | Path, vec_normalize: Any = None, replay_buffer: bool = False) -> Path:
    """Write ``model`` to ``path`` (an SB3 ``.zip``) with its VecNormalize statistics
    (:func:`vecnormalize_path`) and, for a periodic checkpoint with ``replay_buffer``, its replay
    buffer (:func:`replay_buffer_path`); every file atomically, the ``.zip`` last."""
    path = Path(path)
    if vec_normalize is not None:
        with atomic_path(vecnormalize_path(path)) as tmp:
            vec_normalize.save(str(tmp))
    if replay_buffer and getattr(model, "replay_buffer", None) is not None:
        with atomic_path(replay_buffer_path(path)) as tmp:
            model.save_replay_buffer(tmp)
    with atomic_path(path) as tmp:
        model.save(tmp)
    return path


#: Columns of a training run's evaluations.csv (SB3 and differentiable runs alike).
EVAL_COLUMNS: tuple[str, ...] = (
    "timesteps", "wall_s", "mean_return", "mean_distance_m", "min_distance_m", "mean_speed_m_s",
    "mean_abs_speed_error_m_s", "mean_cost_of_transport", "falls", "episodes", "mean_foot_slide_m",
    "mean_cadence_steps_per_min", *(f"mean_{key}" for key in SUMMARY_GAIT_KEYS),
)


def open_run_folder(config: AgentConfig, run_dir: Path, checkpoint: Path | None, resume: bool, overwrite: bool,
                    outputs: tuple[str, ...]) -> None:
    """Make ``run_dir`` this run's: with ``resume`` a ``checkpoint`` must exist; without it the
    folder must hold none of ``outputs`` unless ``overwrite`` (which deletes them); then the
    configuration is written and torch's threads set."""
    if resume and checkpoint is None:
        raise FileNotFoundError(f"--resume: no checkpoint in {run_dir / CHECKPOINT_DIR}")
    if not resume:
        claim_run_folder(run_dir, outputs, overwrite, "continue it with --resume, " if checkpoint is not None else "")
    run_dir.mkdir(parents=True, exist_ok=True)
    save_config(config, run_dir / CONFIG_FILE)
    import torch

    torch.set_num_threads(config.logging.torch_threads)
