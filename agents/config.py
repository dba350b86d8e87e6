"""Typed configuration of an agent run, loaded from YAML (``configs/agents/*.yaml``).

A configuration file has six sections; every key is optional except ``algo``::

    algo: ppo                      # ppo | sac | td3
    seed: 0                        # seeds SB3 (torch, numpy, random) and the environments
    total_timesteps: 20_000_000    # environment steps summed over all parallel environments
    env:                           # EnvConfig
      id: sspinn/SagittalWalker-v0
      n_envs: 8
      vec_env: native              # native (one compiled step for all) | dummy | subproc
      kwargs: {target_speed: 1.3}  # SagittalWalkerEnv constructor arguments
    prior: {gait: configs/agents/gaits/walk_1.3.npz}   # GaitPriorConfig (training reward, optional)
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

:func:`load_config` validates everything it can without building an environment. Unknown keys,
types, choices and ranges are checked by the project's one configuration loader
(:mod:`sspinn.yaml_config`, from the dataclasses below); this module adds what is agent-specific:
the hyperparameter names against the signature of the SB3 class, the environment arguments as a
:class:`envs.config.WalkerConfig` (plus the keywords of :class:`envs.sagittal_walker.SagittalWalkerEnv`)
and the combinations (PPO batch size, policy options per algorithm).
Errors are :class:`ConfigError` (a :class:`sspinn.errors.UserError`) naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from sspinn import yaml_config
from sspinn.run_folder import atomic_write_text
from sspinn.yaml_config import ConfigError, option

#: Control rate of the walking environment, Hz (animations show at most this many frames per second).
ENV_RATE_HZ = 100
#: Algorithms supported by :mod:`agents.train` (lower-case name → SB3 class name).
ALGORITHMS: dict[str, str] = {"ppo": "PPO", "sac": "SAC", "td3": "TD3"}
#: Algorithms that learn through the differentiable simulator (:mod:`agents.diff`; lower-case name →
#: display name); their ``hyperparameters`` are :class:`agents.diff.settings.DiffSettings`.
DIFF_ALGORITHMS: dict[str, str] = {"apg": "APG", "shac": "SHAC", "ahac": "AHAC"}
#: Vectorised-environment kinds (see :class:`EnvConfig`).
VEC_ENVS: tuple[str, ...] = ("native", "dummy", "subproc")
#: Activation functions accepted in ``policy.activation`` (name → ``torch.nn`` class name).
ACTIVATIONS: dict[str, str] = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU"}
#: Keys of ``hyperparameters`` that :mod:`agents.train` sets itself.
RESERVED_HYPERPARAMETERS: frozenset[str] = frozenset(
    {"policy", "env", "seed", "device", "tensorboard_log", "policy_kwargs", "verbose", "_init_setup_model"}
)


@dataclass(frozen=True)
class EnvConfig:
    """The training environments.

    Attributes:
        id: Gymnasium id; ``"sspinn/SagittalWalker-v0"`` is made as ``"envs:sspinn/SagittalWalker-v0"``
            so that worker processes import :mod:`envs` (which registers it).
        n_envs: number of parallel environments (≥ 1); with PPO, ``n_steps × n_envs`` steps per update.
        vec_env: ``"native"`` (default, ``sspinn/SagittalWalker-v0`` only): the native vector
            environment, all walkers stepped by one compiled call (:class:`agents.vec_env.WalkerVecEnv`);
            ``"dummy"``: SB3's ``DummyVecEnv``, single environments stepped one after another in the
            training process; ``"subproc"``: each in its own process (pays only with spare cores and
            slow envs). With the same seeds ``native`` and ``dummy`` give the same episodes.
        threads: numba threads of the native vector environment (``numba.set_num_threads``); None:
            numba's default (``NUMBA_NUM_THREADS``, else all cores).
        kwargs: constructor arguments of the environment (reward weights, target speed in m/s, ...).
        eval_target_speed: target speed (m/s) of the periodic evaluations and of ``evaluate``'s
            default; None → the ``target_speed`` in ``kwargs`` (must then be a single number).
    """

    id: str = "sspinn/SagittalWalker-v0"
    n_envs: int = option(8, ge=1, le=4096)
    vec_env: str = option("native", choices=VEC_ENVS)
    threads: int | None = option(None, ge=1)
    kwargs: dict[str, Any] = field(default_factory=dict)
    eval_target_speed: float | None = option(None, ge=0, le=12, unit="m/s")

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
    clip_obs: float = option(10.0, gt=0)
    clip_reward: float = option(10.0, gt=0)


@dataclass(frozen=True)
class PolicyConfig:
    """Network of the SB3 ``MlpPolicy`` (passed as ``policy_kwargs``).

    Attributes:
        net_arch: hidden layer sizes, shared by actor and critic(s) (separate networks, same sizes).
        activation: hidden activation, one of :data:`ACTIVATIONS`.
        log_std_init: initial log standard deviation of the Gaussian policy (PPO, SAC); None → SB3 default.
        ortho_init: orthogonal initialisation (PPO only; SB3 default True).
        optimizer_kwargs: keyword arguments of the policy's optimiser, ``torch.optim.Adam``
            (SB3's ``optimizer_kwargs``), e.g. ``{fused: true}``: Adam's fused kernel, one pass
            over all parameters instead of one per tensor (the same update up to rounding; PPO keeps
            SB3's eps of 1e-5 unless it is given).
    """

    net_arch: tuple[int, ...] = (256, 256)
    activation: str = option("tanh", choices=ACTIVATIONS)
    log_std_init: float | None = None
    ortho_init: bool | None = None
    optimizer_kwargs: dict[str, Any] = field(default_factory=dict)


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

    checkpoint_freq: int = option(200_000, gt=0)
    keep_replay_buffer: bool = False
    eval_freq: int = option(100_000, ge=0)
    eval_episodes: int = option(5, gt=0)
    eval_seed: int = option(10_000, ge=0)
    tensorboard: bool = True
    torch_threads: int = option(1, gt=0)
    verbose: int = option(0, ge=0)


@dataclass(frozen=True)
class GaitPriorConfig:
    """The optional training reward for staying near a reference stride (:mod:`agents.gait_prior`).

    Attributes:
        gait: a :class:`sspinn.model.trajectory.Trajectory` file (``.npz``) of one full stride
            (relative paths: the working directory, then the repository); None: no prior.
        weight: reward per step at zero distance to the nearest reference sample.
        angle_scale: σ of pelvis tilt and joint angles, rad.
        speed_scale: σ of their speeds, rad/s.
        symmetry_weight: weight of the foot-balance bonus (× 1 − the difference of the feet's
            loaded shares; 0: none).
        symmetry_time: time constant of the loaded shares' moving averages, s.
        mirror_weight: weight of the half-stride mirror bonus (× exp(−RMS left/right joint-angle
            difference half a reference stride apart, in units of ``angle_scale``); 0: none).
        start_share: share of the training episodes that start at a random sample of the
            reference stride instead of standing (0–1; evaluations always start standing).
        clock: the policy observes a clock that runs through the reference stride once per
            stride, and the prior compares with the clock's sample instead of the nearest one
            (:mod:`agents.gait_prior`, "clock mode"); the saved agent keeps the clock as its
            ``predict`` state.
        feedforward: (clock only) add the reference stride's actuator torques at the clock's
            sample to the policy's actions, so that the policy learns the feedback around the
            stride (:mod:`agents.gait_prior`, "feedforward").
        mirror_policy: (clock only) in the second half of each stride the policy sees the
            mirrored observation and its action is mirrored back: one policy for both legs
            (:mod:`agents.gait_prior`, "mirrored half strides").
    """

    gait: str | None = None
    weight: float = option(1.0, gt=0)
    angle_scale: float = option(0.2, gt=0, unit="rad")
    speed_scale: float = option(3.0, gt=0, unit="rad/s")
    symmetry_weight: float = option(0.0, ge=0)
    symmetry_time: float = option(1.0, gt=0, unit="s")
    mirror_weight: float = option(0.0, ge=0)
    start_share: float = option(0.0, ge=0, le=1)
    clock: bool = False
    feedforward: bool = False
    mirror_policy: bool = False


@dataclass(frozen=True)
class AgentConfig:
    """A complete agent run: algorithm, seed, budget, environment, normalisation, network,
    SB3 hyperparameters and logging (see the module docstring for the YAML layout).

    Attributes:
        algo: the SB3 algorithm, one of :data:`ALGORITHMS`, or one of :data:`DIFF_ALGORITHMS`
            (learned through the differentiable simulator: ``env.n_envs`` batched walkers, the
            ``hyperparameters`` of :class:`agents.diff.settings.DiffSettings`, no gait prior).
        seed: seeds SB3 (torch, numpy, random) and the environments (0 to 2³² − 1).
        total_timesteps: environment steps summed over all parallel environments (at most 10¹¹).
    """

    algo: str = option(choices=(*ALGORITHMS, *DIFF_ALGORITHMS))
    seed: int = option(0, ge=0, le=2**32 - 1)
    total_timesteps: int = option(1_000_000, gt=0, le=10**11)
    env: EnvConfig = field(default_factory=EnvConfig)
    prior: GaitPriorConfig = field(default_factory=GaitPriorConfig)
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
def load_config(path: str | Path, overrides: Mapping[str, Any] | None = None, settings: Iterable[str] = ()) -> AgentConfig:
    """Read and validate a YAML configuration file; ``overrides`` (dotted keys, None = keep) and
    ``settings`` (``"a.b=value"``) change it first (see :func:`sspinn.yaml_config.load_config`)."""
    config = yaml_config.load_config(AgentConfig, path, overrides=overrides, settings=settings, what="key")
    validate(config, str(path))
    return config


def config_from_dict(data: Any, source: str = "config") -> AgentConfig:
    """Build and validate an :class:`AgentConfig` from plain data (the parsed YAML)."""
    config = yaml_config.config_from_mapping(AgentConfig, data, source, what="key")
    validate(config, source)
    return config


def _adam() -> type:
    """``torch.optim.Adam`` (torch imported only when a configuration is validated)."""
    import torch

    return torch.optim.Adam


def _check(condition: bool, source: str, key: str, expected: str, value: Any) -> None:
    if not condition:
        raise ConfigError(f"{source}: {key} must be {expected}, got {value!r}")


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def validate(config: AgentConfig, source: str = "config") -> None:
    """The agent-specific checks (types, choices and ranges of single fields are the loader's):
    the environment arguments, the hyperparameters and the combinations of fields."""
    c, e, p = config, config.env, config.policy
    _check(bool(e.id), source, "env.id", "a Gymnasium id", e.id)
    _check(e.vec_env != "native" or e.id == "sspinn/SagittalWalker-v0", source, "env.vec_env",
           "dummy or subproc for an environment other than sspinn/SagittalWalker-v0", e.vec_env)
    if e.id == "sspinn/SagittalWalker-v0":
        from envs.config import WalkerConfig
        from envs.sagittal_walker import SagittalWalkerEnv

        # the WalkerConfig fields plus the env's own keywords (image size; not the config object)
        params = inspect.signature(SagittalWalkerEnv.__init__).parameters.values()
        own = {p.name for p in params if p.kind is p.KEYWORD_ONLY} - {"config", "render_mode"}
        WalkerConfig.from_mapping(e.kwargs, source, prefix="env.kwargs", other_keys=own)
        try:
            e.target_speed  # noqa: B018 (property raises on a range without eval_target_speed)
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None

    _check(len(p.net_arch) > 0 and all(h > 0 for h in p.net_arch), source, "policy.net_arch",
           "a non-empty list of positive layer sizes", p.net_arch)

    if c.algo in DIFF_ALGORITHMS:
        _validate_diff(config, source)
        return
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
    for key in ("n_steps", "batch_size", "n_epochs", "buffer_size", "learning_starts", "gradient_steps"):
        value = c.hyperparameters.get(key)
        _check(not _is_int(value) or value <= MAX_COUNT, source, f"hyperparameters.{key}", f"at most {MAX_COUNT:.0e}", value)
    _check_buffer_memory(c, source)
    if "gamma" in c.hyperparameters:
        _check(0 < c.gamma <= 1, source, "hyperparameters.gamma", "in (0, 1]", c.gamma)
    if c.algo == "ppo":
        n_steps = c.hyperparameters.get("n_steps", 2048)
        batch = c.hyperparameters.get("batch_size", 64)
        _check(batch <= n_steps * e.n_envs, source, "hyperparameters.batch_size",
               f"<= n_steps × n_envs = {n_steps * e.n_envs}", batch)
    adam = set(inspect.signature(_adam().__init__).parameters) - {"self", "params", "lr"}
    unknown = sorted(set(p.optimizer_kwargs) - adam)
    _check(not unknown, source, "policy.optimizer_kwargs", f"keyword arguments of torch.optim.Adam ({', '.join(sorted(adam))}; "
           "the learning rate is hyperparameters.learning_rate)", unknown)
    if p.ortho_init is not None and c.algo != "ppo":
        raise ConfigError(f"{source}: policy.ortho_init applies to PPO only")
    if p.log_std_init is not None and c.algo == "td3":
        raise ConfigError(f"{source}: policy.log_std_init applies to stochastic policies (PPO, SAC), not TD3")
    noise = c.hyperparameters.get("action_noise")
    _check(noise is None or (_is_number(noise) and noise >= 0), source, "hyperparameters.action_noise",
           "null or a standard deviation >= 0 (normalised action units)", noise)


#: Upper bound of the count-like hyperparameters (steps per rollout, batch, epochs, buffer).
MAX_COUNT = 10**9
#: Memory a stored transition takes in an SB3 rollout or replay buffer, bytes: a lower bound
#: (float32 observation — and next observation for replay — of at least 32 values, the action,
#: reward, value, flags), used to refuse a buffer that cannot fit before SB3 allocates it.
BYTES_PER_TRANSITION = 256


def _check_buffer_memory(c: AgentConfig, source: str) -> None:
    """Refuse ``n_steps × n_envs`` (PPO, A2C: the rollout buffer) or ``buffer_size`` (replay) whose
    buffer needs more than half the machine's memory (:func:`sspinn.resource_limits.check_allocation`)."""
    from sspinn.resource_limits import ResourceLimitError, check_allocation

    h = c.hyperparameters
    if c.algo in ("ppo", "a2c"):
        n_steps = h.get("n_steps", 2048 if c.algo == "ppo" else 5)
        if not _is_int(n_steps):
            return
        transitions, what = n_steps * c.env.n_envs, f"hyperparameters.n_steps {n_steps} × env.n_envs {c.env.n_envs}"
    else:
        size = h.get("buffer_size", 1_000_000)
        if not _is_int(size):
            return
        transitions, what = size, f"hyperparameters.buffer_size {size}"
    try:
        check_allocation(transitions * BYTES_PER_TRANSITION, f"{what} (transitions in the buffer)")
    except ResourceLimitError as exc:
        raise ConfigError(f"{source}: {exc}") from None


def _validate_diff(config: AgentConfig, source: str) -> None:
    """The checks of an APG/SHAC/AHAC configuration: its settings (ranges with upper bounds) and
    the options that only SB3 runs have."""
    from agents.diff.settings import settings_of

    settings_of(config, source)
    _check(config.env.id == "sspinn/SagittalWalker-v0", source, "env.id",
           f"sspinn/SagittalWalker-v0 for algo {config.algo} (the batched torch environment)", config.env.id)
    _check(config.prior.gait is None, source, "prior.gait", f"null for algo {config.algo} (no gait prior yet)",
           config.prior.gait)
    _check(not config.normalize.reward, source, "normalize.reward",
           f"false for algo {config.algo} (the return is differentiated unscaled)", config.normalize.reward)
    _check(config.normalize.obs, source, "normalize.obs", f"true for algo {config.algo} (running mean/std)",
           config.normalize.obs)


def algorithm_parameters(algo: str) -> set[str]:
    """Keyword arguments the SB3 class of ``algo`` accepts, minus those set by :mod:`agents.train`."""
    import stable_baselines3

    cls = getattr(stable_baselines3, ALGORITHMS[algo])
    return set(inspect.signature(cls.__init__).parameters) - {"self"} - RESERVED_HYPERPARAMETERS


def save_config(config: AgentConfig, path: str | Path) -> None:
    """Write ``config`` as YAML (read back by :func:`load_config`), atomically."""
    atomic_write_text(path, yaml.safe_dump(config.to_dict(), sort_keys=False))
