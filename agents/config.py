"""Typed configuration of an agent run, loaded from YAML (``configs/agents/*.yaml``).

A configuration file has five sections; every key is optional except ``algo``::

    algo: ppo                      # ppo | sac | td3
    seed: 0                        # seeds SB3 (torch, numpy, random) and the environments
    total_timesteps: 20_000_000    # environment steps summed over all parallel environments
    env:                           # EnvConfig
      id: sspinn/SagittalWalker-v0
      n_envs: 8
      vec_env: dummy               # dummy (one process) | subproc (one process per env)
      kwargs: {target_speed: 1.3}  # SagittalWalkerEnv constructor arguments
    normalize:                     # NormalizeConfig (VecNormalize)
      obs: true
      reward: true
    policy:                        # PolicyConfig (SB3 policy_kwargs)
      net_arch: [256, 256]
      activation: tanh
    hyperparameters:               # keyword arguments of the SB3 algorithm class (PPO, SAC, TD3)
      learning_rate: 3.0e-4
    logging:                       # LoggingConfig (callbacks, threads)
      checkpoint_freq: 200_000

:func:`load_config` validates everything it can without building an environment: unknown keys,
types and ranges, the hyperparameter names against the signature of the SB3 class and the
environment arguments against the fields of :class:`envs.config.WalkerConfig` and the keywords of
:class:`envs.sagittal_walker.SagittalWalkerEnv`.
Errors are :class:`ConfigError` (a ``ValueError``) naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

#: Algorithms supported by :mod:`agents.train` (lower-case name → SB3 class name).
ALGORITHMS: dict[str, str] = {"ppo": "PPO", "sac": "SAC", "td3": "TD3"}
#: Vectorised-environment kinds (see :class:`EnvConfig`).
VEC_ENVS: tuple[str, ...] = ("dummy", "subproc")
#: Activation functions accepted in ``policy.activation`` (name → ``torch.nn`` class name).
ACTIVATIONS: dict[str, str] = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU"}
#: Keys of ``hyperparameters`` that :mod:`agents.train` sets itself.
RESERVED_HYPERPARAMETERS: frozenset[str] = frozenset(
    {"policy", "env", "seed", "device", "tensorboard_log", "policy_kwargs", "verbose", "_init_setup_model"}
)


class ConfigError(ValueError):
    """An invalid agent configuration (the message names the source and the key)."""


@dataclass(frozen=True)
class EnvConfig:
    """The training environments.

    Attributes:
        id: Gymnasium id; ``"sspinn/SagittalWalker-v0"`` is made as ``"envs:sspinn/SagittalWalker-v0"``
            so that worker processes import :mod:`envs` (which registers it).
        n_envs: number of parallel environments (≥ 1); with PPO, ``n_steps × n_envs`` steps per update.
        vec_env: ``"dummy"`` steps the environments one after another in the training process;
            ``"subproc"`` runs each in its own process (pays only with spare cores and slow envs).
        kwargs: constructor arguments of the environment (reward weights, target speed in m/s, ...).
        eval_target_speed: target speed (m/s) of the periodic evaluations and of ``evaluate``'s
            default; None → the ``target_speed`` in ``kwargs`` (must then be a single number).
    """

    id: str = "sspinn/SagittalWalker-v0"
    n_envs: int = 8
    vec_env: str = "dummy"
    kwargs: dict[str, Any] = field(default_factory=dict)
    eval_target_speed: float | None = None

    @property
    def make_id(self) -> str:
        """The id passed to ``gymnasium.make`` (with the ``envs:`` module prefix for our env)."""
        return f"envs:{self.id}" if self.id.startswith("sspinn/") else self.id

    @property
    def target_speed(self) -> float:
        """Target speed (m/s) of evaluations."""
        if self.eval_target_speed is not None:
            return float(self.eval_target_speed)
        value = self.kwargs.get("target_speed", 1.25)
        if isinstance(value, (list, tuple)):
            raise ConfigError("env.eval_target_speed is needed when env.kwargs.target_speed is a range")
        return float(value)


@dataclass(frozen=True)
class NormalizeConfig:
    """Running normalisation of observations and rewards (SB3 ``VecNormalize``).

    Attributes:
        obs: normalise observations with running mean/std (saved with every checkpoint).
        reward: scale rewards by the running std of the discounted return (training only).
        clip_obs: clip normalised observations to ± this value.
        clip_reward: clip normalised rewards to ± this value.
    """

    obs: bool = True
    reward: bool = True
    clip_obs: float = 10.0
    clip_reward: float = 10.0


@dataclass(frozen=True)
class PolicyConfig:
    """Network of the SB3 ``MlpPolicy`` (passed as ``policy_kwargs``).

    Attributes:
        net_arch: hidden layer sizes, shared by actor and critic(s) (separate networks, same sizes).
        activation: hidden activation, one of :data:`ACTIVATIONS`.
        log_std_init: initial log standard deviation of the Gaussian policy (PPO, SAC); None → SB3 default.
        ortho_init: orthogonal initialisation (PPO only; SB3 default True).
    """

    net_arch: tuple[int, ...] = (256, 256)
    activation: str = "tanh"
    log_std_init: float | None = None
    ortho_init: bool | None = None


@dataclass(frozen=True)
class LoggingConfig:
    """Checkpoints, evaluations and threads.

    Attributes:
        checkpoint_freq: environment steps between checkpoints (model + VecNormalize statistics).
        keep_replay_buffer: also checkpoint the replay buffer (SAC/TD3; large files, exact resume).
        eval_freq: environment steps between deterministic evaluations (0 disables them).
        eval_episodes: episodes per evaluation (seeds ``eval_seed``, ``eval_seed + 1``, ...).
        eval_seed: first seed of the evaluation episodes (fixed, so evaluations are comparable).
        tensorboard: write TensorBoard event files under ``<out>/tb``.
        torch_threads: ``torch.set_num_threads`` (1 is fastest for small MLPs on a shared CPU).
        verbose: SB3 verbosity (0 silent, 1 progress tables).
    """

    checkpoint_freq: int = 200_000
    keep_replay_buffer: bool = False
    eval_freq: int = 100_000
    eval_episodes: int = 5
    eval_seed: int = 10_000
    tensorboard: bool = True
    torch_threads: int = 1
    verbose: int = 0


@dataclass(frozen=True)
class AgentConfig:
    """A complete agent run: algorithm, seed, budget, environment, normalisation, network,
    SB3 hyperparameters and logging (see the module docstring for the YAML layout)."""

    algo: str
    seed: int = 0
    total_timesteps: int = 1_000_000
    env: EnvConfig = field(default_factory=EnvConfig)
    normalize: NormalizeConfig = field(default_factory=NormalizeConfig)
    policy: PolicyConfig = field(default_factory=PolicyConfig)
    hyperparameters: dict[str, Any] = field(default_factory=dict)
    logging: LoggingConfig = field(default_factory=LoggingConfig)

    @property
    def gamma(self) -> float:
        """Discount factor (hyperparameter ``gamma``, SB3 default 0.99), also used by VecNormalize."""
        return float(self.hyperparameters.get("gamma", 0.99))

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (YAML-serialisable, tuples as lists) that :func:`config_from_dict` reads back."""

        def plain(value: Any) -> Any:
            if isinstance(value, Mapping):
                return {k: plain(v) for k, v in value.items()}
            if isinstance(value, (list, tuple)):
                return [plain(v) for v in value]
            return value

        return plain(dataclasses.asdict(self))

    def with_overrides(self, **changes: Any) -> AgentConfig:
        """A copy with top-level fields replaced (validated again)."""
        return config_from_dict({**self.to_dict(), **changes})


# --------------------------------------------------------------------------------------------
# Loading and validation
# --------------------------------------------------------------------------------------------
class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads ``3e-4`` as a float (YAML 1.1 insists on ``3.0e-4``)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def load_config(path: str | Path) -> AgentConfig:
    """Read and validate a YAML configuration file."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"config file {path} does not exist")
    with path.open() as fh:
        try:
            data = yaml.load(fh, Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
        except yaml.YAMLError as exc:
            raise ConfigError(f"{path}: not valid YAML: {exc}") from exc
    return config_from_dict(data, source=str(path))


def config_from_dict(data: Any, source: str = "config") -> AgentConfig:
    """Build and validate an :class:`AgentConfig` from plain data (the parsed YAML)."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: the top level must be a mapping, got {type(data).__name__}")
    top = _split(data, AgentConfig, source, "")
    if "algo" not in top:
        raise ConfigError(f"{source}: 'algo' is required (one of {', '.join(ALGORITHMS)})")
    sections = {
        "env": EnvConfig,
        "normalize": NormalizeConfig,
        "policy": PolicyConfig,
        "logging": LoggingConfig,
    }
    for name, cls in sections.items():
        if name in top:
            value = top[name] if top[name] is not None else {}
            if not isinstance(value, Mapping):
                raise ConfigError(f"{source}: '{name}' must be a mapping, got {type(value).__name__}")
            top[name] = cls(**_split(value, cls, source, f"{name}."))
    if "policy" in top and isinstance(top["policy"].net_arch, list):
        top["policy"] = dataclasses.replace(top["policy"], net_arch=tuple(top["policy"].net_arch))
    if top.get("hyperparameters") is None:
        top.pop("hyperparameters", None)
    if top.get("env") is not None and top["env"].kwargs is None:
        top["env"] = dataclasses.replace(top["env"], kwargs={})
    config = AgentConfig(**top)
    validate(config, source)
    return config


def _split(data: Mapping[str, Any], cls: type, source: str, prefix: str) -> dict[str, Any]:
    """``data`` as constructor keywords of the dataclass ``cls``; unknown keys are errors."""
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise ConfigError(f"{source}: unknown key(s) {', '.join(prefix + k for k in unknown)}; "
                          f"allowed: {', '.join(sorted(prefix + n for n in names))}")
    return dict(data)


def _check(condition: bool, source: str, key: str, expected: str, value: Any) -> None:
    if not condition:
        raise ConfigError(f"{source}: {key} must be {expected}, got {value!r}")


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def validate(config: AgentConfig, source: str = "config") -> None:
    """Check types and ranges of every field; raise :class:`ConfigError` naming the key."""
    c = config
    _check(c.algo in ALGORITHMS, source, "algo", f"one of {', '.join(ALGORITHMS)}", c.algo)
    _check(_is_int(c.seed) and c.seed >= 0, source, "seed", "an integer >= 0", c.seed)
    _check(_is_int(c.total_timesteps) and c.total_timesteps > 0, source, "total_timesteps", "an integer > 0",
           c.total_timesteps)

    e = c.env
    _check(isinstance(e.id, str) and bool(e.id), source, "env.id", "a Gymnasium id", e.id)
    _check(_is_int(e.n_envs) and 1 <= e.n_envs <= 256, source, "env.n_envs", "an integer in [1, 256]", e.n_envs)
    _check(e.vec_env in VEC_ENVS, source, "env.vec_env", f"one of {', '.join(VEC_ENVS)}", e.vec_env)
    _check(isinstance(e.kwargs, Mapping), source, "env.kwargs", "a mapping of constructor arguments", e.kwargs)
    _check(e.eval_target_speed is None or (_is_number(e.eval_target_speed) and 0 <= e.eval_target_speed <= 12),
           source, "env.eval_target_speed", "null or a speed in [0, 12] m/s", e.eval_target_speed)
    if e.id == "sspinn/SagittalWalker-v0":
        from envs.config import WalkerConfig
        from envs.sagittal_walker import SagittalWalkerEnv

        # the WalkerConfig fields plus the env's own keywords (image size; not the config object)
        params = inspect.signature(SagittalWalkerEnv.__init__).parameters.values()
        own = {p.name for p in params if p.kind is p.KEYWORD_ONLY} - {"config", "render_mode"}
        allowed = set(WalkerConfig.field_names()) | own
        unknown = sorted(set(e.kwargs) - allowed)
        _check(not unknown, source, "env.kwargs", f"arguments of SagittalWalkerEnv ({', '.join(sorted(allowed))})",
               unknown)
        try:
            e.target_speed  # noqa: B018 (property raises on a range without eval_target_speed)
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None

    n = c.normalize
    for key in ("obs", "reward"):
        _check(isinstance(getattr(n, key), bool), source, f"normalize.{key}", "true or false", getattr(n, key))
    for key in ("clip_obs", "clip_reward"):
        value = getattr(n, key)
        _check(_is_number(value) and value > 0, source, f"normalize.{key}", "a number > 0", value)

    p = c.policy
    _check(isinstance(p.net_arch, tuple) and len(p.net_arch) > 0 and all(_is_int(h) and h > 0 for h in p.net_arch),
           source, "policy.net_arch", "a non-empty list of positive layer sizes", p.net_arch)
    _check(p.activation in ACTIVATIONS, source, "policy.activation", f"one of {', '.join(ACTIVATIONS)}", p.activation)
    _check(p.log_std_init is None or _is_number(p.log_std_init), source, "policy.log_std_init", "null or a number",
           p.log_std_init)
    _check(p.ortho_init is None or isinstance(p.ortho_init, bool), source, "policy.ortho_init", "null or a bool",
           p.ortho_init)

    _check(isinstance(c.hyperparameters, Mapping), source, "hyperparameters", "a mapping", c.hyperparameters)
    reserved = sorted(set(c.hyperparameters) & RESERVED_HYPERPARAMETERS)
    _check(not reserved, source, "hyperparameters", "free of keys set by agents.train "
           f"({', '.join(sorted(RESERVED_HYPERPARAMETERS))}; use seed/env/policy/logging)", reserved)
    accepted = algorithm_parameters(c.algo)
    unknown = sorted(set(c.hyperparameters) - accepted)
    _check(not unknown, source, "hyperparameters",
           f"keyword arguments of stable_baselines3.{ALGORITHMS[c.algo]} ({', '.join(sorted(accepted))})", unknown)
    for key, value in c.hyperparameters.items():
        if key in ("learning_rate", "gamma", "gae_lambda", "clip_range", "ent_coef", "vf_coef", "tau",
                   "max_grad_norm", "target_policy_noise", "target_noise_clip"):
            _check(_is_number(value) or (key == "ent_coef" and isinstance(value, str) and value.startswith("auto")),
                   source, f"hyperparameters.{key}", "a finite number", value)
        if key in ("n_steps", "batch_size", "n_epochs", "buffer_size", "learning_starts", "gradient_steps",
                   "policy_delay"):
            _check(_is_int(value) and value > 0 or (key == "gradient_steps" and value == -1) or
                   (key == "learning_starts" and value == 0), source, f"hyperparameters.{key}", "a positive integer",
                   value)
    if "gamma" in c.hyperparameters:
        _check(0 < c.gamma <= 1, source, "hyperparameters.gamma", "in (0, 1]", c.gamma)
    if c.algo == "ppo":
        n_steps = c.hyperparameters.get("n_steps", 2048)
        batch = c.hyperparameters.get("batch_size", 64)
        _check(batch <= n_steps * e.n_envs, source, "hyperparameters.batch_size",
               f"<= n_steps × n_envs = {n_steps * e.n_envs}", batch)
    if p.ortho_init is not None and c.algo != "ppo":
        raise ConfigError(f"{source}: policy.ortho_init applies to PPO only")
    if p.log_std_init is not None and c.algo == "td3":
        raise ConfigError(f"{source}: policy.log_std_init applies to stochastic policies (PPO, SAC), not TD3")
    noise = c.hyperparameters.get("action_noise")
    _check(noise is None or (_is_number(noise) and noise >= 0), source, "hyperparameters.action_noise",
           "null or a standard deviation >= 0 (normalised action units)", noise)

    lg = c.logging
    for key in ("checkpoint_freq", "eval_episodes", "torch_threads"):
        value = getattr(lg, key)
        _check(_is_int(value) and value > 0, source, f"logging.{key}", "an integer > 0", value)
    for key in ("eval_freq", "eval_seed", "verbose"):
        value = getattr(lg, key)
        _check(_is_int(value) and value >= 0, source, f"logging.{key}", "an integer >= 0", value)
    for key in ("keep_replay_buffer", "tensorboard"):
        _check(isinstance(getattr(lg, key), bool), source, f"logging.{key}", "true or false", getattr(lg, key))


def algorithm_parameters(algo: str) -> set[str]:
    """Keyword arguments the SB3 class of ``algo`` accepts, minus those set by :mod:`agents.train`."""
    import stable_baselines3

    cls = getattr(stable_baselines3, ALGORITHMS[algo])
    return set(inspect.signature(cls.__init__).parameters) - {"self"} - RESERVED_HYPERPARAMETERS


def save_config(config: AgentConfig, path: str | Path) -> None:
    """Write ``config`` as YAML (read back by :func:`load_config`)."""
    Path(path).write_text(yaml.safe_dump(config.to_dict(), sort_keys=False))
