"""The configuration of the walking task, shared by the single and the batched environment.

:class:`WalkerConfig` collects every task and physics argument of
:class:`~envs.sagittal_walker.SagittalWalkerEnv` and :class:`~envs.batched.BatchedSagittalWalker`
in one frozen dataclass that validates itself on construction; both environments take it as
``config=`` and accept its fields as keyword overrides (``gymnasium.make(ENV_ID, target_speed=1.3)``
keeps working). :class:`WalkerParameters` is the read-only view of a configuration that both
environments share: the quantities a controller needs to predict the environment's step (torque
limits, passive joint moments, body and contact parameters, time steps, integrator).

Units are SI (m, s, rad, N, N·m) except where stated.
"""

from __future__ import annotations

import dataclasses
import math
import operator
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np

from envs import task
from envs.disturbances import Disturbances
from sspinn.model.body import BodyParameters
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import N_Q
from sspinn.model.passive import is_real
from sspinn.model.simulation import METHODS
from sspinn.yaml_config import config_from_mapping

#: Control interval, s (fixed: 100 Hz). The physics defaults below are justified in the docstring
#: of :class:`~envs.sagittal_walker.SagittalWalkerEnv` ("Physics step").
CONTROL_DT: Final[float] = 0.01
#: Default physics substeps per control interval.
SUBSTEPS: Final[int] = 50
#: Default integrator (one of :data:`sspinn.model.simulation.METHODS`).
METHOD: Final[str] = "semi_implicit_euler"
#: Default slip velocity of the forward-simulation friction law, m/s.
SLIP_VELOCITY: Final[float] = 0.2

#: Default body height (m) and mass (kg); ``body`` may only be given when these are unchanged.
_DEFAULT_HEIGHT, _DEFAULT_MASS = 1.75, 70.0
#: Reward and termination fields: finite numbers.
_NUMBER_FIELDS = ("tracking_weight", "tracking_width", "alive_bonus", "effort_weight", "min_height_fraction", "max_tilt",
                  "slip_weight", "impact_weight", "impact_threshold", "phase_weight", "max_phase_duration")


def _read_only(attribute: str, doc: str) -> Any:
    """A read-only property returning ``self.<attribute>`` (a dotted path is followed)."""
    return property(operator.attrgetter(attribute), doc=doc)


@dataclass(frozen=True)
class WalkerConfig:
    """Task and physics arguments of the sagittal walker environments (single and batched).

    Validated in ``__post_init__``: an invalid value raises ``ValueError``
    (``sspinn.model.body.ParameterError`` is a subclass) naming the field and its units. Mappings and
    lists given as field values are copied (a dict stays a dict, a list becomes a tuple); treat them
    as read-only. Change a configuration with :func:`dataclasses.replace` (validated again).

    Reward per control step (0.01 s)::

        r = tracking_weight · exp(−((v − v*) / tracking_width)²)
            + alive_bonus · [not terminated]
            − effort_weight · Σ_j a_j²
            − slip_weight · Σ_feet v_slip − impact_weight · Σ_feet max(F_y/BW − impact_threshold, 0)²
            − phase_weight · Σ_feet [current contact or air phase longer than max_phase_duration]

    with v the pelvis (hip joint centre) forward speed averaged over the step (m/s), v* the target
    speed (m/s), a ∈ [−1, 1]⁶ the action, and the last two (gait shaping, off by default) from the
    contact forces at the end of the step: v_slip the sliding speed of a foot carrying more than
    10 % BW implied by the friction law (m/s, :func:`envs.task.foot_slip`), F_y a foot's vertical
    force (:func:`envs.task.shaping_penalty`); a foot is in contact while its vertical force exceeds
    10 % BW (:data:`sspinn.data.gait_events.CONTACT_THRESHOLD_BW`), :func:`envs.task.next_phase`.

    Attributes:
        height: body height, m (Winter scaling; 0.5–2.5). Default 1.75.
        mass: body mass, kg (10–300). Default 70.
        body: a :class:`~sspinn.model.body.BodyParameters`, or a mapping for
            ``BodyParameters.from_dict`` (height, mass, optional segment overrides); then
            ``height`` and ``mass`` must keep their defaults. None: scaled from height and mass.
        target_speed: m/s, fixed, or a (low, high) range sampled uniformly per episode. Default 1.25.
        max_torque: actuator strength, N·m/kg: a mapping by joint type ("hip", "knee", "ankle";
            missing types take the defaults) or six values in joint order; None → 3.0 each.
        tracking_weight: weight of the speed-tracking term (reward units). Default 1.
        tracking_width: σ of the speed-tracking Gaussian, m/s (> 0). Default 0.25.
        alive_bonus: reward for every step that does not terminate the episode. Default 0.2.
        effort_weight: weight of Σ a² (dimensionless actions, Σ a² ∈ [0, 6]). Default 0.01.
        slip_weight: weight of the feet's sliding speed, per m/s (≥ 0). Default 0 (off).
        impact_weight: weight of the squared vertical-force excess over ``impact_threshold``, per
            BW² (≥ 0). Default 0 (off).
        impact_threshold: vertical force per foot above which the impact penalty acts, BW (> 0).
            Default 1.5 (walking's impact peaks are ≈ 1.1–1.3 BW).
        phase_weight: penalty per step and foot whose current contact or air phase has lasted more
            than ``max_phase_duration`` (≥ 0): against hopping on one leg or dragging a foot.
            Default 0 (off).
        max_phase_duration: s (> 0). Default 1.0 (walking at 1.3 m/s: stance ≈ 0.7 s, swing ≈ 0.45 s).
        min_height_fraction: the episode terminates when the hip height (pelvis_ty) falls below
            this fraction of the standing hip height (m). In (0, 1); default 0.6.
        max_tilt: |pelvis_tilt| limit, rad (trunk lean); beyond it the episode terminates. Default 1.
        joint_range: soft-limit ranges of the passive joint moments, rad, {"hip": (lo, hi), ...};
            missing types (and None) take :data:`sspinn.model.passive.DEFAULT_JOINT_RANGE`.
        joint_limit_stiffness: soft-limit stiffness, N·m/rad² (≥ 0). Default 10⁴.
        joint_damping: viscous joint damping, N·m·s/rad (≥ 0). Default 1.
        reset_noise_scale: half-width of the uniform initial-state noise, m, rad, m/s or rad/s
            (in [0, 0.1]). Default 0.005.
        max_episode_steps: truncation after this many control steps (≥ 1). Default 1000 (10 s).
        substeps: physics substeps per control step (≥ 1). Default 50 (0.2 ms).
        method: integrator, "semi_implicit_euler" (default) or "rk4".
        slip_velocity: friction regularisation v_s of the forward-simulation contact, m/s (> 0).
            Default 0.2.
        contact: :class:`~sspinn.model.contact.ContactParameters` (stiffness, damping, μ, ...; its slip
            velocity is replaced by ``slip_velocity``); None → defaults.
        reset_states: start states for a share of the episodes, (K, 18) rows (q, u) (m, rad, m/s,
            rad/s; pelvis_tx is reset to 0), e.g. the samples of a walking stride (reference state
            initialisation for training, Peng et al. 2018, *DeepMimic*); None: every episode
            starts standing. A ``reset`` with ``options["initial_state"]`` ignores them.
        reset_state_share: share of the episodes that start at a uniformly drawn row of
            ``reset_states``, in [0, 1]. Default 0.
        disturbances: the disturbance tests of every episode, a
            :class:`~envs.disturbances.Disturbances` or a mapping of its fields (pushes, observation
            noise and delay, actuator strength, body mismatch; units there). Default: none.
    """

    height: float = _DEFAULT_HEIGHT
    mass: float = _DEFAULT_MASS
    body: BodyParameters | Mapping[str, Any] | None = None
    target_speed: float | Sequence[float] = 1.25
    max_torque: Mapping[str, float] | Sequence[float] | None = None
    tracking_weight: float = 1.0
    tracking_width: float = 0.25
    alive_bonus: float = 0.2
    effort_weight: float = 0.01
    slip_weight: float = 0.0
    impact_weight: float = 0.0
    impact_threshold: float = 1.5
    phase_weight: float = 0.0
    max_phase_duration: float = 1.0
    min_height_fraction: float = 0.6
    max_tilt: float = 1.0
    joint_range: Mapping[str, Sequence[float]] | None = None
    joint_limit_stiffness: float = task.DEFAULT_LIMIT_STIFFNESS
    joint_damping: float = task.DEFAULT_JOINT_DAMPING
    reset_noise_scale: float = 0.005
    reset_states: Any = None
    reset_state_share: float = 0.0
    max_episode_steps: int = 1000
    substeps: int = SUBSTEPS
    method: str = METHOD
    slip_velocity: float = SLIP_VELOCITY
    contact: ContactParameters | None = None
    disturbances: Disturbances = field(default_factory=Disturbances)

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        for name in ("body", "target_speed", "max_torque", "joint_range"):  # copies, see the docstring
            value = getattr(self, name)
            if isinstance(value, Mapping):
                put(name, dict(value))
            elif isinstance(value, list):
                put(name, tuple(value))
        if self.body is not None and (self.height != _DEFAULT_HEIGHT or self.mass != _DEFAULT_MASS):
            raise ValueError("give either body or height/mass, not both (body already fixes height and mass)")
        body = task.make_body(self.body, self.height, self.mass)
        contact = task.make_contact(self.slip_velocity, self.contact)
        for name in _NUMBER_FIELDS:
            value = getattr(self, name)
            if not is_real(value) or not math.isfinite(value):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
        if self.tracking_width <= 0:
            raise ValueError(f"tracking_width must be > 0 m/s, got {self.tracking_width}")
        if not 0.0 < self.min_height_fraction < 1.0:
            raise ValueError(f"min_height_fraction must lie in (0, 1), got {self.min_height_fraction}")
        if self.max_tilt <= 0:
            raise ValueError(f"max_tilt must be > 0 rad, got {self.max_tilt}")
        for name in ("slip_weight", "impact_weight", "phase_weight"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.impact_threshold <= 0:
            raise ValueError(f"impact_threshold must be > 0 BW, got {self.impact_threshold}")
        if self.max_phase_duration <= 0:
            raise ValueError(f"max_phase_duration must be > 0 s, got {self.max_phase_duration}")
        if not is_real(self.reset_noise_scale) or not 0 <= self.reset_noise_scale <= 0.1:
            raise ValueError(f"reset_noise_scale must be a number in [0, 0.1] (m, rad), got {self.reset_noise_scale!r}")
        put("reset_noise_scale", float(self.reset_noise_scale))
        if not is_real(self.reset_state_share) or not 0 <= self.reset_state_share <= 1:
            raise ValueError(f"reset_state_share must be a number in [0, 1], got {self.reset_state_share!r}")
        put("reset_state_share", float(self.reset_state_share))
        if self.reset_states is not None:
            try:
                states = np.array(self.reset_states, dtype=np.float64)
            except (TypeError, ValueError):
                raise ValueError("reset_states must be a (K, 18) array of (q, u) rows") from None
            if states.ndim != 2 or states.shape[1] != 2 * N_Q or len(states) == 0 or not np.isfinite(states).all():
                raise ValueError(f"reset_states must be a finite (K, {2 * N_Q}) array of (q, u) rows, got shape {states.shape}")
            states.flags.writeable = False
            put("reset_states", states)
        elif self.reset_state_share > 0:
            raise ValueError("reset_state_share > 0 needs reset_states")
        _, substeps, method = task.check_physics(CONTROL_DT, self.substeps, self.method, METHODS)
        put("substeps", substeps)
        tau_max = task.max_torques(self.max_torque, body.segment_mass_total)
        passive = task.passive_parameters(self.joint_range, self.joint_limit_stiffness, self.joint_damping)
        target_range = task.target_speed_range(self.target_speed)
        put("max_episode_steps", task.check_int("max_episode_steps", self.max_episode_steps, 1))
        put("disturbances", Disturbances.resolve(self.disturbances))
        for array in (tau_max, passive):
            array.flags.writeable = False
        # derived quantities: not fields (not compared, not in repr/asdict), read through properties
        put("_body", body)
        put("_contact", contact)
        put("_tau_max", tau_max)
        put("_passive", passive)
        put("_target_range", target_range)
        put("_standing_height", task.standing_height(body, contact))

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Names of the fields, i.e. of the keyword arguments the environments accept for them."""
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def from_mapping(
        cls, data: Mapping[str, Any], source: str = "<mapping>", prefix: str = "", other_keys: Collection[str] = ()
    ) -> WalkerConfig:
        """A configuration from plain data (e.g. the ``env.kwargs`` of an agent's YAML file) through
        the project's configuration loader (:func:`sspinn.yaml_config.config_from_mapping`): unknown
        keys, types (``3e-4``, lists for tuples), then this class's validation; errors are
        ``ConfigError`` naming ``source`` and the option (dotted below ``prefix``). ``other_keys``
        are accepted and ignored (an environment's own keywords)."""
        return config_from_mapping(cls, data, source, what="key", prefix=prefix, other_keys=other_keys)

    @classmethod
    def resolve(cls, config: WalkerConfig | None = None, **overrides: Any) -> WalkerConfig:
        """``config`` (default: :class:`WalkerConfig` ()) with the fields in ``overrides`` replaced.

        Raises:
            TypeError: ``config`` is not a WalkerConfig, or an override is not a field name.
            ValueError: an invalid value (see the class docstring).
        """
        if config is not None and not isinstance(config, cls):
            raise TypeError(f"config must be a {cls.__name__} or None, got {type(config).__name__}")
        unknown = sorted(set(overrides) - set(cls.field_names()))
        if unknown:
            raise TypeError(f"unknown environment argument(s) {unknown}; {cls.__name__} fields: {', '.join(cls.field_names())}")
        if config is None:
            return cls(**overrides)
        return dataclasses.replace(config, **overrides) if overrides else config

    # ------------------------------------------------------- derived values (not fields, read-only)
    body_parameters = _read_only("_body", "The body (from ``body``, or scaled from ``height`` and ``mass``).")
    contact_parameters = _read_only("_contact", "The forward-simulation contact (``contact`` with ``slip_velocity``).")
    tau_max = _read_only("_tau_max", "Maximal actuator torque per joint, N·m, (6,) in joint order (read-only array).")
    passive_parameters = _read_only(
        "_passive",
        "Packed passive-moment parameters (14,) of :func:`sspinn.model.passive.passive_parameters`: [lower (6, rad), "
        "upper (6, rad), stiffness (N·m/rad²), damping (N·m·s/rad)] (read-only array).",
    )
    target_range = _read_only("_target_range", "(low, high) target speed, m/s (low == high for a fixed speed).")
    standing_height = _read_only(
        "_standing_height", "Hip height of the upright starting pose, m (:func:`envs.task.standing_height`)."
    )

    @property
    def physics_dt(self) -> float:
        """Physics substep, s (= 0.01 s / ``substeps``)."""
        return CONTROL_DT / self.substeps


class WalkerParameters:
    """Read-only public parameters of a walker environment, from its :class:`WalkerConfig`
    (``self._config``, set by the environment's constructor). Arrays are fresh float64 copies."""

    _config: WalkerConfig

    config = _read_only("_config", "The validated task and physics configuration (a frozen :class:`WalkerConfig`).")
    body = _read_only("_config.body_parameters", "Body (segment) parameters, :class:`sspinn.model.body.BodyParameters`.")
    contact = _read_only(
        "_config.contact_parameters", "Forward-simulation contact parameters, :class:`sspinn.model.contact.ContactParameters`."
    )
    substeps = _read_only("_config.substeps", "Physics substeps per control interval.")
    physics_dt = _read_only("_config.physics_dt", "Physics substep, s (= ``dt / substeps``).")
    method = _read_only("_config.method", "Integrator name, one of :data:`sspinn.model.simulation.METHODS`.")
    standing_height = _read_only(
        "_config.standing_height", "Hip height of the upright starting pose, m (falls are measured against it)."
    )

    @property
    def dt(self) -> float:
        """Control interval, s (one ``step``)."""
        return CONTROL_DT

    @property
    def body_vector(self) -> np.ndarray:
        """Packed body parameters (41,), the ``p`` of :mod:`sspinn.model.simulation` and :mod:`sspinn.model.dynamics`."""
        return self.body.vector()

    @property
    def contact_vector(self) -> np.ndarray:
        """Packed contact parameters (7,), the ``c`` of :mod:`sspinn.model.simulation` and :mod:`sspinn.model.dynamics`."""
        return self.contact.vector()

    @property
    def tau_max(self) -> np.ndarray:
        """Maximal actuator torque per joint, N·m, (6,): an action of ±1 commands ±``tau_max``."""
        return self._config.tau_max.copy()

    @property
    def passive_parameters(self) -> np.ndarray:
        """Packed passive joint-moment parameters (14,): [lower (6, rad), upper (6, rad), stiffness
        (N·m/rad²), damping (N·m·s/rad)], the ``passive`` of :func:`sspinn.model.simulation.advance`."""
        return self._config.passive_parameters.copy()

    def passive_torque(self, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        """Passive joint moments (..., 6) in N·m at joint angles (..., 6, rad) and rates (..., 6,
        rad/s), as the environment adds them to the actuator torques (:func:`sspinn.model.passive.passive_torque`)."""
        p = self._config.passive_parameters
        return task.passive_torque(np.asarray(angles), np.asarray(rates), p[:6], p[6:12], p[12], p[13])


__all__ = ["CONTROL_DT", "METHOD", "SLIP_VELOCITY", "SUBSTEPS", "WalkerConfig", "WalkerParameters"]
