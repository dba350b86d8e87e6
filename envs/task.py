"""The walking task, written once for both environments: observation, reward, termination,
actuator strength, initial state and argument checking.

The reward and termination formulas are written once, as the *scalar* functions
:func:`tracking_term`, :func:`step_reward` and :func:`fell`: plain arithmetic (and :func:`exp`) that
numba compiles for the compiled step of the NumPy environments (:mod:`envs.kernels`, used by
:class:`~envs.sagittal_walker.SagittalWalkerEnv` and :class:`~envs.vector.SagittalWalkerVectorEnv`)
and that torch evaluates elementwise on tensors for :class:`~envs.batched.BatchedSagittalWalker`
(through the array-generic :func:`reward` and :func:`unhealthy`, which take NumPy arrays or torch
tensors of any batch shape). No environment has its own copy.
The reward weights and termination thresholds they read are fields of
:class:`envs.config.WalkerConfig`, the one configuration of both environments, which validates its
arguments with the checking functions below.

The passive joint moments (soft joint limits and damping, :func:`passive_torque`,
:func:`passive_parameters` and their defaults) are physiology of the body model: they live in
:mod:`sspinn.model.passive` and are re-exported here.

Units are SI (m, s, rad, N, N·m) except where stated: contact forces in the observation are in
body weights (BW = m·g) and the actuator strength is in N·m per kg of body mass.
"""

from __future__ import annotations

import math
import numbers
import sys
from collections.abc import Mapping, Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any, Final

import numba
import numpy as np
from numba.extending import overload, register_jitable

from sspinn.model.body import BodyParameters, ParameterError
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import COORDINATES, GRF, JOINTS, N_GRF, N_Q, N_TAU

# re-exported (see the module docstring); is_real is the shared real-number check
from sspinn.model.passive import (
    DEFAULT_JOINT_DAMPING,
    DEFAULT_JOINT_RANGE,
    DEFAULT_LIMIT_STIFFNESS,
    is_real,
    passive_parameters,
    passive_torque,
)

if TYPE_CHECKING:  # envs.config imports this module
    from envs.config import WalkerConfig

# --------------------------------------------------------------------------------------------
# Observation layout
# --------------------------------------------------------------------------------------------
#: Names of the observation entries, in order (see :data:`OBSERVATION_UNITS`).
OBSERVATION_NAMES: Final[tuple[str, ...]] = (
    *COORDINATES[1:],  # 0–7: pelvis_ty, pelvis_tilt, six joint angles
    *(f"d_{name}" for name in COORDINATES),  # 8–16: all nine generalized speeds
    *GRF,  # 17–20: ground reaction forces
    "target_speed",  # 21
)
#: Units of the observation entries.
OBSERVATION_UNITS: Final[tuple[str, ...]] = (
    "m", "rad", *("rad",) * N_TAU, "m/s", "m/s", *("rad/s",) * (N_Q - 2), *("BW",) * N_GRF, "m/s",
)
OBS_SIZE: Final[int] = len(OBSERVATION_NAMES)
#: Channel class of each observation entry: the groups that share one observation-noise standard
#: deviation (:class:`envs.disturbances.Disturbances`); ``"command"`` (the target speed) is never noisy.
OBSERVATION_CLASSES: Final[tuple[str, ...]] = (
    "height", *("angle",) * (N_TAU + 1), *("linear_velocity",) * 2, *("angular_velocity",) * (N_Q - 2),
    *("grf",) * N_GRF, "command",
)
#: Index of each observation entry by name.
OBS_INDEX: Final[dict[str, int]] = {name: i for i, name in enumerate(OBSERVATION_NAMES)}

# --------------------------------------------------------------------------------------------
# Actuator strength
# --------------------------------------------------------------------------------------------
#: Default maximal joint torque per kg of body mass (N·m/kg) for each joint type; an action of ±1
#: commands ± this value times the body mass. See the module docstring of
#: :mod:`envs.sagittal_walker` for the sources and the approximations involved.
DEFAULT_MAX_TORQUE: Final[dict[str, float]] = {"hip": 3.0, "knee": 3.0, "ankle": 3.0}


def _xp(x: Any) -> ModuleType:
    """The array namespace of ``x``: torch for tensors, else NumPy (torch is not imported here)."""
    torch = sys.modules.get("torch")
    if torch is not None and isinstance(x, torch.Tensor):
        return torch
    return np


# --------------------------------------------------------------------------------------------
# Observation, reward, termination (array-generic)
# --------------------------------------------------------------------------------------------
def observation(q: Any, u: Any, grf: Any, target_speed: Any, body_weight: float) -> Any:
    """Observation (..., 22) from coordinates q (..., 9), speeds u (..., 9), contact forces grf
    (..., 4) in N and the target speed (...,) in m/s; layout :data:`OBSERVATION_NAMES`. Keeps the
    input's dtype (the environments cast to float32)."""
    xp = _xp(q)
    return xp.concatenate([q[..., 1:], u, grf / body_weight, target_speed[..., None]], axis=-1)


def exp(x: Any) -> Any:
    """e**x of a float, NumPy array or torch tensor; compiled code uses ``math.exp`` (overload below)."""
    torch = sys.modules.get("torch")
    if torch is not None and isinstance(x, torch.Tensor):
        return torch.exp(x)
    return np.exp(x)


def atanh(x: Any) -> Any:
    """artanh of a float, NumPy array or torch tensor; compiled code uses ``math.atanh`` (overload below)."""
    torch = sys.modules.get("torch")
    if torch is not None and isinstance(x, torch.Tensor):
        return torch.atanh(x)
    return np.arctanh(x)


@overload(atanh)
def _atanh_compiled(x):  # type: ignore[no-untyped-def]  # pragma: no cover - numba typing hook
    if isinstance(x, numba.types.Float):
        return lambda x: math.atanh(x)
    return None


@overload(exp)
def _exp_compiled(x):  # type: ignore[no-untyped-def]  # pragma: no cover - numba typing hook (no annotations: numba compares signatures)
    if isinstance(x, numba.types.Float):
        return lambda x: math.exp(x)
    return None


def fell(height: Any, tilt: Any, min_height: Any, max_tilt: float) -> Any:
    """True where the episode must terminate: hip height (m) below ``min_height`` (m), |pelvis tilt|
    (rad) above ``max_tilt`` (rad), or either of them NaN (``x != x``). Scalars (compiled) or
    arrays/tensors (elementwise)."""
    return (height < min_height) | (abs(tilt) > max_tilt) | (height != height) | (tilt != tilt)


def tracking_term(speed: Any, target_speed: Any, width: float) -> Any:
    """Unweighted speed-tracking reward exp(−((v − v*) / width)²) ∈ (0, 1]; speeds and width in m/s."""
    return exp(-(((speed - target_speed) / width) ** 2))


def step_reward(tracking: Any, effort: Any, terminated: Any, tracking_weight: float, alive_bonus: float,
                effort_weight: float) -> tuple[Any, Any]:
    """(reward, alive) of one step from the unweighted tracking term, the effort Σ a² and the
    termination flag; ``alive`` is 1.0, or 0.0 when the step terminates the episode."""
    alive = 1.0 - terminated * 1.0
    return tracking_weight * tracking + alive_bonus * alive - effort_weight * effort, alive


@register_jitable
def _positive_part(x: Any) -> Any:
    """max(x, 0) with arithmetic and ``abs`` only (scalars compiled, arrays and tensors elementwise)."""
    return 0.5 * (x + abs(x))


@register_jitable  # callable from compiled code (shaping_penalty) and from Python with arrays or tensors
def foot_slip(fx: Any, fy: Any, friction: float, slip_velocity: float, min_load: Any) -> Any:
    """Sliding speed (m/s) of a foot's contact point implied by the forward-simulation friction law
    F_x = −μ·tanh(v/v_s)·F_y: |v| = v_s·artanh(|F_x| / (μ·F_y)) (the ratio capped at 0.999), for a
    foot carrying more than ``min_load`` (N) of vertical force F_y (N), else 0."""
    ratio = abs(fx) / (friction * abs(fy) + 1e-9)
    ratio = ratio - _positive_part(ratio - 0.999)
    return (fy > min_load) * slip_velocity * atanh(ratio)


def shaping_penalty(grf_x_r: Any, grf_y_r: Any, grf_x_l: Any, grf_y_l: Any, body_weight: Any, friction: float,
                    slip_velocity: float, slip_weight: float, impact_weight: float, impact_threshold: float) -> Any:
    """The optional gait-shaping penalty of one step (subtracted from the reward), from the contact
    forces (N) at the end of the step: ``slip_weight`` × Σ_feet :func:`foot_slip` (feet above 10 % BW,
    m/s) + ``impact_weight`` × Σ_feet max(F_y/BW − ``impact_threshold``, 0)² (BW²)."""
    min_load = 0.1 * body_weight
    slip = foot_slip(grf_x_r, grf_y_r, friction, slip_velocity, min_load) + foot_slip(
        grf_x_l, grf_y_l, friction, slip_velocity, min_load)
    over_r = _positive_part(grf_y_r / body_weight - impact_threshold)
    over_l = _positive_part(grf_y_l / body_weight - impact_threshold)
    return slip_weight * slip + impact_weight * (over_r * over_r + over_l * over_l)


@register_jitable
def next_phase(phase: Any, loaded: Any, dt: float) -> Any:
    """A foot's current phase duration after a control step of ``dt`` s: positive while it is in
    contact (``loaded``: vertical force above the contact threshold), negative in the air; the count
    restarts at ±dt when the foot lands or lifts off. Arithmetic only (compiled or elementwise)."""
    on = loaded * 1.0
    return on * (_positive_part(phase) + dt) - (1.0 - on) * (_positive_part(-phase) + dt)


def phase_penalty(phase_r: Any, phase_l: Any, max_phase: float, weight: float) -> Any:
    """``weight`` per foot whose current contact or air phase has lasted longer than ``max_phase``
    s (a foot that never lands — hopping — or never lifts off — dragging)."""
    return weight * ((abs(phase_r) > max_phase) * 1.0 + (abs(phase_l) > max_phase) * 1.0)


def unhealthy(q: Any, standing_height: Any, cfg: WalkerConfig) -> Any:
    """:func:`fell` of states q (..., 9): hip below ``cfg.min_height_fraction`` of the standing hip
    height (m) or |pelvis_tilt| > ``cfg.max_tilt`` (rad); NaN coordinates count as unhealthy too (the
    environments also check that the whole state is finite, which the physics step reports)."""
    return fell(q[..., 1], q[..., 2], cfg.min_height_fraction * standing_height, cfg.max_tilt)


def reward(speed: Any, target_speed: Any, action: Any, terminated: Any, cfg: WalkerConfig,
           grf: Any = None, phase: Any = None) -> tuple[Any, Any, Any, Any]:
    """(reward, tracking, alive, effort) per step (:func:`tracking_term`, :func:`step_reward`, minus
    :func:`shaping_penalty` of the contact forces ``grf`` (..., 4) in N and :func:`phase_penalty` of
    the feet's phase durations ``phase`` (..., 2) in s when their weights are set); see
    :class:`envs.config.WalkerConfig` for the formula.

    ``speed`` and ``target_speed`` in m/s (...,), ``action`` (..., 6) in [−1, 1], ``terminated``
    boolean (...,). ``tracking`` ∈ (0, 1] and ``effort`` = Σ a² are the unweighted terms; ``alive`` is
    1 or 0.
    """
    tracking = tracking_term(speed, target_speed, cfg.tracking_width)
    effort = (action * action).sum(-1)
    total, alive = step_reward(tracking, effort, terminated, cfg.tracking_weight, cfg.alive_bonus, cfg.effort_weight)
    if cfg.slip_weight or cfg.impact_weight:
        if grf is None:
            raise ValueError("reward: the shaping penalty (slip_weight, impact_weight) needs the contact forces grf")
        contact = cfg.contact_parameters
        total = total - shaping_penalty(grf[..., 0], grf[..., 1], grf[..., 2], grf[..., 3],
                                        cfg.body_parameters.body_weight, contact.friction, contact.slip_velocity,
                                        cfg.slip_weight, cfg.impact_weight, cfg.impact_threshold)
    if cfg.phase_weight:
        if phase is None:
            raise ValueError("reward: the phase penalty (phase_weight) needs the feet's phase durations")
        total = total - phase_penalty(phase[..., 0], phase[..., 1], cfg.max_phase_duration, cfg.phase_weight)
    return total, tracking, alive, effort


# --------------------------------------------------------------------------------------------
# Body, contact, strength, initial state
# --------------------------------------------------------------------------------------------
def make_body(body: BodyParameters | Mapping[str, Any] | None, height: float, mass: float) -> BodyParameters:
    """Body parameters from a :class:`BodyParameters`, a mapping (``BodyParameters.from_dict``: height,
    mass and optional segment overrides) or, when ``body`` is None, from ``height`` (m) and ``mass`` (kg)."""
    if body is None:
        for name, value in (("height", height), ("mass", mass)):
            if not is_real(value):
                raise ValueError(f"{name} must be a number, got {type(value).__name__} {value!r}")
        return BodyParameters.from_anthropometry(float(height), float(mass))
    if isinstance(body, BodyParameters):
        return body
    if isinstance(body, Mapping):
        return BodyParameters.from_dict(dict(body), source="body")
    raise ValueError(f"body must be a BodyParameters, a mapping or None, got {type(body).__name__}")


def make_contact(slip_velocity: float, contact: ContactParameters | None) -> ContactParameters:
    """The forward-simulation contact parameters: ``contact`` (defaults of
    :class:`ContactParameters` when None) with its slip velocity replaced by ``slip_velocity`` (m/s)."""
    if not is_real(slip_velocity) or not slip_velocity > 0 or not math.isfinite(slip_velocity):
        raise ValueError(f"slip_velocity must be a positive number (m/s), got {slip_velocity!r}")
    if contact is None:
        contact = ContactParameters()
    elif not isinstance(contact, ContactParameters):
        raise ValueError(f"contact must be a ContactParameters or None, got {type(contact).__name__}")
    return ContactParameters(**{**contact.__dict__, "slip_velocity": float(slip_velocity)})


def max_torques(spec: Mapping[str, float] | Sequence[float] | None, body_mass: float) -> np.ndarray:
    """Per-joint torque limits in N·m (6,) from N·m/kg values: None (defaults), a mapping by joint
    type ("hip", "knee", "ankle", missing keys take the defaults) or six values in joint order."""
    if spec is None:
        spec = DEFAULT_MAX_TORQUE
    if isinstance(spec, Mapping):
        unknown = set(spec) - set(DEFAULT_MAX_TORQUE)
        if unknown:
            raise ValueError(f"max_torque: unknown joint type(s) {sorted(unknown)}; use {sorted(DEFAULT_MAX_TORQUE)}")
        per_type = {**DEFAULT_MAX_TORQUE, **spec}
        values = [per_type[j.split("_")[0]] for j in JOINTS]
    elif isinstance(spec, Sequence) and not isinstance(spec, str):
        values = list(spec)
        if len(values) != N_TAU:
            raise ValueError(f"max_torque needs {N_TAU} values (N·m/kg, order {JOINTS}), got {len(values)}")
    else:
        raise ValueError(f"max_torque must be a mapping, a sequence of {N_TAU} numbers or None, got {type(spec).__name__}")
    for v in values:
        if not is_real(v) or not 0 < v < 20:
            raise ValueError(f"max_torque values must be numbers in (0, 20) N·m/kg, got {v!r}")
    return np.asarray(values, dtype=np.float64) * body_mass


def target_speed_range(target_speed: float | Sequence[float]) -> tuple[float, float]:
    """(low, high) in m/s from a fixed speed or a (low, high) range, with clear errors."""
    if is_real(target_speed):
        low = high = float(target_speed)  # type: ignore[arg-type]
    elif isinstance(target_speed, Sequence) and not isinstance(target_speed, str) and len(target_speed) == 2:
        if not all(is_real(v) for v in target_speed):
            raise ValueError(f"target_speed range must hold two numbers (m/s), got {target_speed!r}")
        low, high = float(target_speed[0]), float(target_speed[1])
    else:
        raise ValueError(f"target_speed must be a number or a (low, high) pair in m/s, got {target_speed!r}")
    if not (math.isfinite(low) and math.isfinite(high)):
        raise ValueError(f"target_speed must be finite, got {target_speed!r}")
    if low < 0:
        raise ValueError(f"target_speed must be >= 0 m/s (forward walking/running), got {target_speed!r}")
    if low > high:
        raise ValueError(f"target_speed range must have low <= high, got {target_speed!r}")
    if high > 12.0:
        raise ValueError(f"target_speed {high} m/s is beyond human sprinting speed (units: m/s)")
    return low, high


def check_target_speed(value: Any) -> float:
    """A single target speed (m/s) from ``reset(options={"target_speed": ...})``."""
    low, high = target_speed_range(value)
    if low != high:
        raise ValueError(f"options['target_speed'] must be one number (m/s), got {value!r}")
    return low


def standing_height(body: BodyParameters, contact: ContactParameters) -> float:
    """Hip height (m) of the upright pose (all angles 0, feet flat) in which each foot carries half
    the body weight in static equilibrium of the contact spring: the contact point (midway between
    heel and toe for a flat foot) then lies ``d`` below the ground, ``BW·k·softplus(β·d)/β = BW/2``.
    Uses the right leg's geometry (both legs are equal unless overridden)."""
    beta, k = contact.transition, contact.stiffness
    depth = math.log(math.expm1(0.5 * beta / k)) / beta  # softplus⁻¹(β/(2k)) / β, m
    sole = -0.5 * (body.foot_r.heel[1] + body.foot_r.toe[1])  # ankle height above the contact point, m
    return body.femur_r.length + body.tibia_r.length + sole - depth


def check_int(name: str, value: Any, low: int) -> int:
    """``value`` as an int ≥ ``low`` (rejects floats and bools)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def check_physics(dt: float, substeps: int, method: str, methods: Sequence[str]) -> tuple[float, int, str]:
    """Validate the control interval ``dt`` (s), the substeps per interval and the integrator name."""
    if not is_real(dt) or not 0 < dt <= 0.1:
        raise ValueError(f"control dt must be a number in (0, 0.1] s, got {dt!r}")
    substeps = check_int("substeps", substeps, 1)
    if method not in methods:
        raise ValueError(f"unknown integrator {method!r}; choose one of {', '.join(methods)}")
    return float(dt), substeps, method


__all__ = [
    "DEFAULT_JOINT_DAMPING",
    "DEFAULT_JOINT_RANGE",
    "DEFAULT_LIMIT_STIFFNESS",
    "DEFAULT_MAX_TORQUE",
    "OBSERVATION_CLASSES",
    "OBSERVATION_NAMES",
    "OBSERVATION_UNITS",
    "OBS_INDEX",
    "OBS_SIZE",
    "ParameterError",
    "check_int",
    "check_physics",
    "check_target_speed",
    "atanh",
    "exp",
    "fell",
    "foot_slip",
    "next_phase",
    "phase_penalty",
    "make_body",
    "passive_parameters",
    "passive_torque",
    "make_contact",
    "max_torques",
    "observation",
    "reward",
    "shaping_penalty",
    "standing_height",
    "step_reward",
    "target_speed_range",
    "tracking_term",
    "unhealthy",
]
