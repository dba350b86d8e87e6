"""Disturbance tests of the walking task, the same for every controller: pushes, sensor noise and
delay, weaker or stronger actuators, and a body that differs from the announced model.

:class:`Disturbances` is one frozen dataclass; it is the ``disturbances`` field of
:class:`envs.config.WalkerConfig` (every episode) and the ``reset(options={"disturbances": {...}})``
option of :class:`~envs.sagittal_walker.SagittalWalkerEnv` and
:class:`~envs.vector.SagittalWalkerVectorEnv` (that episode; the given fields replace the
configuration's). Both environments apply them in the same compiled step (:mod:`envs.kernels`).
All defaults are "no disturbance".

The environment's *announced* model — ``body``, ``body_vector``, ``tau_max``, ``standing_height``,
``step_state`` of :class:`envs.config.WalkerParameters` — stays the nominal one: a disturbance is
what a controller does not know. Observations report contact forces in the nominal body weight.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np

from envs.task import OBSERVATION_CLASSES
from sspinn.model.body import BodyParameters, Foot, Segment
from sspinn.model.conventions import JOINTS, N_TAU, SEGMENTS
from sspinn.model.passive import is_real

#: Push timings by gait phase: the foot whose mid-stance starts the push.
PUSH_PHASES: Final[dict[str, int]] = {"midstance_r": 0, "midstance_l": 1}
#: Observation channel classes that may be given a noise standard deviation, with their units.
NOISE_CLASSES: Final[dict[str, str]] = {
    "height": "m", "angle": "rad", "linear_velocity": "m/s", "angular_velocity": "rad/s", "grf": "BW",
}
#: Segment types, each naming both sides (``"femur"`` → femur_r and femur_l).
SEGMENT_TYPES: Final[tuple[str, ...]] = ("pelvis", "femur", "tibia", "foot")
#: Largest observation delay, control steps (0.5 s).
MAX_DELAY_STEPS: Final[int] = 50


@dataclass(frozen=True)
class Disturbances:
    """Disturbances of one episode (defaults: none). Units in brackets.

    Push — a horizontal force on the pelvis (at the hip joint centre, the origin of the HAT
    segment), constant over whole control intervals (0.01 s), at most once per episode:

    Attributes:
        push_force: [% body weight] horizontal force, + forward, − backward; 0 disables the push.
            Body weight = the nominal body mass × 9.81 m/s².
        push_duration: [s] how long the force acts, rounded to whole control intervals (≥ 0.01 s).
        push_time: [s after reset] start of the push, rounded down to a control step; or None
            to start it at a gait phase (``push_phase``).
        push_phase: ``"midstance_r"`` or ``"midstance_l"``: start the push at the first mid-stance
            of that foot at or after ``push_after`` s. Mid-stance is detected from the contact
            forces at the start of a control step: the foot carries more than
            :data:`sspinn.data.gait_events.CONTACT_THRESHOLD_BW` (10 % BW) of vertical force while the
            other foot carries less (single support), and the foot's horizontal force has turned from
            braking (< 0 at the previous control step) to propulsive (≥ 0). A gait that never shows
            this transition is never pushed (``info["push_force"]`` stays 0).
        push_after: [s after reset] earliest start of a phase-triggered push.

    Observations (the reward and the episode end use the true state):

    Attributes:
        obs_noise: [unit of the channel] standard deviation of zero-mean Gaussian noise added to
            every observation entry of a class: ``{"height": m, "angle": rad, "linear_velocity":
            m/s, "angular_velocity": rad/s, "grf": BW}`` (missing classes: none; the target speed is
            never noisy; classes in :data:`envs.task.OBSERVATION_CLASSES`). Drawn independently per
            entry and step from a counter-based generator keyed by a number drawn from the
            environment's ``np_random`` at reset (:mod:`envs.kernels`).
        obs_delay: [control steps] the observation returned after step t is the one of step
            t − ``obs_delay`` (the first observation of the episode until then); noise is added to
            the delayed observation. 0–50.

    Actuators and body:

    Attributes:
        strength_change: [%] change of the actuator strength: torque = clipped action ×
            ``tau_max`` × (1 + change/100). One number for all joints or six (joint order
            :data:`sspinn.model.conventions.JOINTS`); each in (−100, 100].
        mass_change: [%] change of segment masses (and with them the moments of inertia) of the
            simulated body: one number for all segments, or a mapping by segment
            (:data:`sspinn.model.conventions.SEGMENTS`, e.g. ``femur_r``) or segment type (``pelvis``,
            ``femur``, ``tibia``, ``foot``: both sides); each in (−50, 50].
        length_change: [%] change of segment lengths of the simulated body, with the centre-of-mass
            positions, the heel and toe points and the radius of gyration (inertia ∝ length²)
            scaled alike; same forms and range as ``mass_change``. The simulated body starts at its
            own standing height and falls below ``min_height_fraction`` of its own standing height.
    """

    push_force: float = 0.0
    push_duration: float = 0.1
    push_time: float | None = None
    push_phase: str | None = None
    push_after: float = 1.0
    obs_noise: dict[str, float] | None = None
    obs_delay: int = 0
    strength_change: float | tuple[float, ...] = 0.0
    mass_change: float | dict[str, float] = 0.0
    length_change: float | dict[str, float] = 0.0

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        _number("push_force", self.push_force, -200.0, 200.0, "% body weight")
        _number("push_duration", self.push_duration, 0.005, 5.0, "s")
        _number("push_after", self.push_after, 0.0, 1e4, "s")
        if self.push_time is not None:
            _number("push_time", self.push_time, 0.0, 1e4, "s")
        if self.push_phase is not None and self.push_phase not in PUSH_PHASES:
            raise ValueError(f"push_phase must be None or one of {sorted(PUSH_PHASES)}, got {self.push_phase!r}")
        if self.push_force != 0 and (self.push_time is None) == (self.push_phase is None):
            raise ValueError("a push (push_force != 0) needs exactly one of push_time (s) and push_phase "
                             f"({', '.join(sorted(PUSH_PHASES))})")
        if self.obs_noise is not None:
            if not isinstance(self.obs_noise, Mapping):
                raise ValueError(f"obs_noise must be a mapping of channel class to std, got {self.obs_noise!r}")
            unknown = sorted(set(self.obs_noise) - set(NOISE_CLASSES))
            if unknown:
                raise ValueError(f"obs_noise: unknown channel class(es) {unknown}; use {sorted(NOISE_CLASSES)}")
            for name, std in self.obs_noise.items():
                _number(f"obs_noise[{name!r}]", std, 0.0, 100.0, NOISE_CLASSES[name])
            put("obs_noise", {k: float(v) for k, v in self.obs_noise.items()})
        if isinstance(self.obs_delay, bool) or not isinstance(self.obs_delay, (int, np.integer)) or not (
            0 <= self.obs_delay <= MAX_DELAY_STEPS
        ):
            raise ValueError(f"obs_delay must be an integer in [0, {MAX_DELAY_STEPS}] control steps, got {self.obs_delay!r}")
        put("obs_delay", int(self.obs_delay))
        strength = self.strength_change
        if isinstance(strength, Sequence) and not isinstance(strength, str):
            if len(strength) != N_TAU:
                raise ValueError(f"strength_change needs one number or {N_TAU} (order {JOINTS}), got {len(strength)}")
            for v in strength:
                _number("strength_change", v, -100.0, 100.0, "%", open_low=True)
            put("strength_change", tuple(float(v) for v in strength))
        else:
            _number("strength_change", strength, -100.0, 100.0, "%", open_low=True)
        for name in ("mass_change", "length_change"):
            value = getattr(self, name)
            if isinstance(value, Mapping):
                per_segment = _per_segment(name, value)
                put(name, dict(value))
                for v in per_segment.values():
                    _number(name, v, -50.0, 50.0, "%", open_low=True)
            else:
                _number(name, value, -50.0, 50.0, "%", open_low=True)

    @classmethod
    def resolve(cls, value: Disturbances | Mapping[str, Any] | None, base: Disturbances | None = None) -> Disturbances:
        """``value`` as Disturbances: a mapping replaces the given fields of ``base`` (default: none);
        None → ``base``. Unknown keys are a ``ValueError`` listing the fields."""
        base = cls() if base is None else base
        if value is None:
            return base
        if isinstance(value, Disturbances):
            return value
        if not isinstance(value, Mapping):
            raise ValueError(f"disturbances must be a Disturbances or a mapping of its fields, got {type(value).__name__}")
        names = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(value) - set(names))
        if unknown:
            raise ValueError(f"disturbances: unknown field(s) {unknown}; fields: {', '.join(names)}")
        return dataclasses.replace(base, **value)

    # ------------------------------------------------------------------------------ derived values
    @property
    def pushes(self) -> bool:
        """Whether the episode has a push."""
        return self.push_force != 0.0

    def noise_std(self) -> np.ndarray:
        """(22,) observation-noise standard deviation per observation entry (units of the entries)."""
        table = self.obs_noise or {}
        return np.array([table.get(c, 0.0) for c in OBSERVATION_CLASSES], dtype=np.float64)

    def strength_scale(self) -> np.ndarray:
        """(6,) factors on the actuator torques, 1 + change/100."""
        return 1.0 + np.broadcast_to(np.asarray(self.strength_change, dtype=np.float64), (N_TAU,)) / 100.0

    @property
    def changes_body(self) -> bool:
        """Whether the simulated body differs from the nominal one."""
        return any(v != 0.0 for v in _per_segment("mass_change", self.mass_change).values()) or any(
            v != 0.0 for v in _per_segment("length_change", self.length_change).values()
        )

    def body(self, nominal: BodyParameters) -> BodyParameters:
        """The simulated body: ``nominal`` with the segment masses and lengths changed."""
        if not self.changes_body:
            return nominal
        mass = _per_segment("mass_change", self.mass_change)
        length = _per_segment("length_change", self.length_change)
        segments = {name: _changed(getattr(nominal, name), 1 + mass[name] / 100, 1 + length[name] / 100) for name in SEGMENTS}
        return nominal.replace(**segments)


def _number(name: str, value: Any, low: float, high: float, unit: str, open_low: bool = False) -> None:
    ok = is_real(value) and math.isfinite(value) and (low < value if open_low else low <= value) and value <= high
    if not ok:
        bracket = "(" if open_low else "["
        raise ValueError(f"{name} must be a number in {bracket}{low:g}, {high:g}] {unit}, got {value!r}")


def _per_segment(name: str, value: float | Mapping[str, float]) -> dict[str, float]:
    """{segment: change in %} from one number or a mapping by segment or segment type."""
    if not isinstance(value, Mapping):
        return {s: float(value) for s in SEGMENTS}
    out = {s: 0.0 for s in SEGMENTS}
    for key, v in value.items():
        if key in SEGMENTS:
            out[key] = v
        elif key in SEGMENT_TYPES:
            for s in SEGMENTS:
                if s.split("_")[0] == key:
                    out[s] = v
        else:
            raise ValueError(f"{name}: unknown segment {key!r}; use one of {SEGMENTS} or {SEGMENT_TYPES}")
    return out


def _changed(segment: Segment, mass_scale: float, length_scale: float) -> Segment:
    """A segment with its mass × ``mass_scale`` and its lengths × ``length_scale`` (inertia × both)."""
    changes: dict[str, Any] = {
        "mass": segment.mass * mass_scale,
        "inertia": segment.inertia * mass_scale * length_scale**2,
        "com": tuple(c * length_scale for c in segment.com),
        "length": segment.length * length_scale,
    }
    if isinstance(segment, Foot):
        changes["heel"] = tuple(c * length_scale for c in segment.heel)
        changes["toe"] = tuple(c * length_scale for c in segment.toe)
    return dataclasses.replace(segment, **changes)


__all__ = ["MAX_DELAY_STEPS", "NOISE_CLASSES", "PUSH_PHASES", "SEGMENT_TYPES", "Disturbances"]
