"""Body parameters of the sagittal 7-segment model: segments, IMU placement, joint limits.

Conventions (frames, signs, units) are those of :mod:`sspinn.model.conventions`. Segment parameters
are scaled linearly from body height and mass with Winter's anthropometric table
(D.A. Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed., Table 4.1), using the
segment lengths, centre-of-mass positions and foot geometry of the gait2d model family
(BioMAC-Sim-Toolbox ``gait2dc_par.xls``: 75 kg, 1.80 m), so that ``from_anthropometry(1.80, 75)``
reproduces that reference parameterisation.

The flat parameter vector ``BodyParameters.vector()`` is what the generated backends take; its
order is :data:`PARAMETERS`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np
import yaml

from sspinn.model.conventions import GRAVITY, JOINTS, SEGMENTS, SIDES
from sspinn.run_folder import atomic_write_text
from sspinn.yaml_config import check_keys, config_from_mapping, read_yaml

# --------------------------------------------------------------------------------------------
# Flat parameter vector layout (the symbols of the derivation carry the same names)
# --------------------------------------------------------------------------------------------
_SEGMENT_FIELDS: Final = ("mass", "inertia", "com_x", "com_y")


def _parameter_names() -> tuple[str, ...]:
    names = ["gravity"] + [f"pelvis_{f}" for f in _SEGMENT_FIELDS]
    for side in SIDES:
        names += [f"femur_{side}_{f}" for f in (*_SEGMENT_FIELDS, "length")]
        names += [f"tibia_{side}_{f}" for f in (*_SEGMENT_FIELDS, "length")]
        names += [f"foot_{side}_{f}" for f in (*_SEGMENT_FIELDS, "heel_x", "heel_y", "toe_x", "toe_y")]
    return tuple(names)


#: Names of the entries of the body-parameter vector, in order (SI units; inertia about the
#: segment's centre of mass in kg·m²; com/heel/toe in the segment frame in m).
PARAMETERS: Final[tuple[str, ...]] = _parameter_names()
N_PARAMETERS: Final[int] = len(PARAMETERS)

# --------------------------------------------------------------------------------------------
# Winter scaling (fractions of body mass / body height); see module docstring for the sources
# --------------------------------------------------------------------------------------------
_REF_HEIGHT: Final = 1.80
#: segment: (mass / body mass, length / height, CoM distance from proximal joint / length,
#: radius of gyration about CoM / length). For the HAT segment the CoM lies *above* the hip.
WINTER: Final[dict[str, tuple[float, float, float, float]]] = {
    "pelvis": (0.678, 0.504 / _REF_HEIGHT, 0.626, 0.496),
    "femur": (0.100, 0.245, 0.433, 0.323),
    "tibia": (0.0465, 0.246, 0.433, 0.302),
    "foot": (0.0145, 0.152, 0.50, 0.475),
}
#: Foot geometry in the foot frame (origin at the ankle), as fractions of body height.
FOOT_GEOMETRY: Final[dict[str, tuple[float, float]]] = {
    "com": (0.0768 / _REF_HEIGHT, -0.0351 / _REF_HEIGHT),
    "heel": (-0.06 / _REF_HEIGHT, -0.0702 / _REF_HEIGHT),
    "toe": (0.1636 / _REF_HEIGHT, -0.0702 / _REF_HEIGHT),
}


class ParameterError(ValueError):
    """Raised for physically meaningless parameters (negative mass, zero height, NaN...)."""


def _check_finite(name: str, value: float, positive: bool = False) -> None:
    if not isinstance(value, (int, float, np.floating, np.integer)):
        raise ParameterError(f"{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ParameterError(f"{name} must be finite, got {value!r}")
    if positive and value <= 0:
        raise ParameterError(f"{name} must be > 0, got {value!r}")


@dataclass(frozen=True)
class Segment:
    """A rigid segment in its own frame (origin at the proximal joint, y along the segment).

    Attributes:
        mass: kg.
        inertia: moment of inertia about the centre of mass, about z, kg·m².
        com: centre of mass (x, y) in the segment frame, m (negative y: below the proximal joint).
        length: distance from the proximal to the distal joint along −y, m (for the HAT segment,
            hip to shoulder; for the foot, ankle to metatarsal head; both used for drawing only).
    """

    mass: float
    inertia: float
    com: tuple[float, float]
    length: float

    def __post_init__(self) -> None:
        _check_finite("mass", self.mass, positive=True)
        _check_finite("inertia", self.inertia, positive=True)
        _check_finite("length", self.length, positive=True)
        for v in self.com:
            _check_finite("com", v)


@dataclass(frozen=True)
class Foot(Segment):
    """A foot segment; heel and toe are the ends of its contact line, in the foot frame (m)."""

    heel: tuple[float, float] = (0.0, 0.0)
    toe: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        super().__post_init__()
        for v in (*self.heel, *self.toe):
            _check_finite("heel/toe", v)
        if self.toe[0] <= self.heel[0]:
            raise ParameterError(f"toe x ({self.toe[0]}) must lie in front of heel x ({self.heel[0]})")


def _winter_segment(name: str, height: float, mass: float) -> Segment:
    mass_frac, len_frac, com_frac, rog_frac = WINTER[name]
    length = len_frac * height
    m = mass_frac * mass
    inertia = m * (rog_frac * length) ** 2
    if name == "foot":
        com = tuple(c * height for c in FOOT_GEOMETRY["com"])
        heel = tuple(c * height for c in FOOT_GEOMETRY["heel"])
        toe = tuple(c * height for c in FOOT_GEOMETRY["toe"])
        return Foot(mass=m, inertia=inertia, com=com, length=length, heel=heel, toe=toe)  # type: ignore[arg-type]
    sign = 1.0 if name == "pelvis" else -1.0
    return Segment(mass=m, inertia=inertia, com=(0.0, sign * com_frac * length), length=length)


@dataclass(frozen=True)
class BodyParameters:
    """All rigid-body parameters of one person (see :data:`PARAMETERS` for the flat layout).

    ``pelvis`` is the HAT segment (head, arms, trunk and pelvis), whose origin is the hip joint.
    Use :meth:`from_anthropometry` to scale from height and mass.
    """

    height: float
    mass: float
    pelvis: Segment
    femur_r: Segment
    tibia_r: Segment
    foot_r: Foot
    femur_l: Segment
    tibia_l: Segment
    foot_l: Foot
    gravity: float = GRAVITY

    def __post_init__(self) -> None:
        _check_finite("height", self.height, positive=True)
        _check_finite("mass", self.mass, positive=True)
        _check_finite("gravity", self.gravity, positive=True)
        for side in SIDES:
            if not isinstance(getattr(self, f"foot_{side}"), Foot):
                raise ParameterError(f"foot_{side} must be a Foot (with heel and toe)")

    @classmethod
    def from_anthropometry(cls, height: float = 1.75, mass: float = 70.0, gravity: float = GRAVITY) -> BodyParameters:
        """Scale all segments linearly from body height (m) and mass (kg) with Winter's table."""
        _check_finite("height", height, positive=True)
        _check_finite("mass", mass, positive=True)
        if not 0.5 <= height <= 2.5:
            raise ParameterError(f"height {height} m is outside the plausible human range 0.5–2.5 m (units: metres)")
        if not 10.0 <= mass <= 300.0:
            raise ParameterError(f"mass {mass} kg is outside the plausible human range 10–300 kg (units: kilograms)")
        segs = {name: _winter_segment(name, height, mass) for name in WINTER}
        return cls(
            height=height,
            mass=mass,
            gravity=gravity,
            pelvis=segs["pelvis"],
            **{f"{name}_{side}": segs[name] for side in SIDES for name in ("femur", "tibia", "foot")},
        )

    @property
    def body_weight(self) -> float:
        """Body weight m·g in N (m is the sum of the segment masses)."""
        return self.segment_mass_total * self.gravity

    @property
    def standing_hip_height(self) -> float:
        """Hip height (m) standing upright with flat feet: femur + tibia + ankle height."""
        return self.femur_r.length + self.tibia_r.length - self.foot_r.heel[1]

    @property
    def segment_mass_total(self) -> float:
        return sum(getattr(self, s).mass for s in SEGMENTS)

    def vector(self) -> np.ndarray:
        """The flat parameter vector (float64) in :data:`PARAMETERS` order."""
        values: dict[str, float] = {"gravity": self.gravity}
        for seg_name in SEGMENTS:
            seg = getattr(self, seg_name)
            values[f"{seg_name}_mass"] = seg.mass
            values[f"{seg_name}_inertia"] = seg.inertia
            values[f"{seg_name}_com_x"], values[f"{seg_name}_com_y"] = seg.com
            values[f"{seg_name}_length"] = seg.length
            if isinstance(seg, Foot):
                values[f"{seg_name}_heel_x"], values[f"{seg_name}_heel_y"] = seg.heel
                values[f"{seg_name}_toe_x"], values[f"{seg_name}_toe_y"] = seg.toe
        return np.array([values[n] for n in PARAMETERS], dtype=np.float64)

    def replace(self, **changes: Any) -> BodyParameters:
        """A copy with some fields replaced (e.g. a segment), validated again."""
        return dataclasses.replace(self, **changes)

    # ---------------------------------------------------------------- YAML / dict round trip
    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<dict>") -> BodyParameters:
        """Build from a mapping: either ``{height, mass}`` (Winter scaling) plus optional segment
        overrides (partial: ``femur_r: {mass: 9}``), or a complete dict as written by
        :meth:`to_dict`. Keys, types and values are checked by the configuration loader
        (:func:`sspinn.yaml_config.config_from_mapping`); errors are :class:`ParameterError`
        naming ``source`` and the (dotted) parameter."""
        if not isinstance(data, Mapping):
            raise ParameterError(f"{source}: body parameters must be a mapping, got {type(data).__name__}")
        check_keys(cls, data, source, what="body parameter", error=ParameterError)
        for key in ("height", "mass"):
            if key not in data:
                raise ParameterError(f"{source}: missing body parameter {key!r}")
        try:
            base = cls.from_anthropometry(data["height"], data["mass"], data.get("gravity", GRAVITY))
        except ParameterError as exc:
            raise ParameterError(f"{source}: {exc}") from None
        return config_from_mapping(cls, data, source, what="body parameter", base=base, error=ParameterError)

    @classmethod
    def from_yaml(cls, path: str | Path) -> BodyParameters:
        """Read a YAML file of :meth:`from_dict`'s mapping (under a top-level ``body`` key or not)."""
        return cls.from_dict(read_yaml(path, "body"), source=str(path))

    def to_yaml(self, path: str | Path) -> None:
        atomic_write_text(path, yaml.safe_dump({"body": _plain(self.to_dict())}, sort_keys=False))


def _plain(obj: Any) -> Any:
    """Tuples → lists, numpy scalars → floats, for YAML output."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


# --------------------------------------------------------------------------------------------
# IMU placement
# --------------------------------------------------------------------------------------------
#: Typical sensor positions in the segment frames (m), for a 1.75 m person; taken from the IMU
#: positions of the Dorschky et al. (2019) recordings (``$SSPINN_SHARED_DATA/dorschky_P03_walking``).
DEFAULT_IMU_POSITIONS: Final[dict[str, tuple[float, float]]] = {
    "pelvis": (-0.085, 0.095),
    "femur_r": (0.0, -0.285),
    "tibia_r": (0.0, -0.225),
    "foot_r": (0.12, 0.0),
    "femur_l": (0.0, -0.26),
    "tibia_l": (0.0, -0.215),
    "foot_l": (0.12, 0.0),
}
N_IMU_PARAMETERS: Final[int] = 3 * len(SEGMENTS)


@dataclass(frozen=True)
class IMUPlacement:
    """Placement of the seven sagittal IMUs: position (x, y, m) and rotation angle (rad, about z)
    of each sensor frame relative to its segment frame. The flat vector (see :meth:`vector`) is
    ``[x, y, angle]`` per segment in :data:`sspinn.model.conventions.SEGMENTS` order."""

    positions: dict[str, tuple[float, float]] = field(default_factory=lambda: dict(DEFAULT_IMU_POSITIONS))
    angles: dict[str, float] = field(default_factory=lambda: {s: 0.0 for s in SEGMENTS})

    def __post_init__(self) -> None:
        for name, table in (("positions", self.positions), ("angles", self.angles)):
            missing = set(SEGMENTS) - set(table)
            extra = set(table) - set(SEGMENTS)
            if missing or extra:
                raise ParameterError(f"IMU {name}: missing {sorted(missing)}, unknown {sorted(extra)}")
        for seg in SEGMENTS:
            for v in (*self.positions[seg], self.angles[seg]):
                _check_finite(f"IMU {seg}", v)

    @classmethod
    def default(cls, height: float = 1.75) -> IMUPlacement:
        """Typical placement, positions scaled by ``height / 1.75``."""
        s = height / 1.75
        return cls(positions={k: (x * s, y * s) for k, (x, y) in DEFAULT_IMU_POSITIONS.items()})

    def vector(self) -> np.ndarray:
        return np.array([v for seg in SEGMENTS for v in (*self.positions[seg], self.angles[seg])], dtype=np.float64)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """``{segment: {"position_m": [x, y], "angle_rad": a}}`` for every segment (the form of a
        recording's sidecar and of the synthetic data's true placement)."""
        return {s: {"position_m": [float(v) for v in self.positions[s]], "angle_rad": float(self.angles[s])} for s in SEGMENTS}

    @classmethod
    def from_vector(cls, vec: np.ndarray) -> IMUPlacement:
        vec = np.asarray(vec, dtype=float).reshape(len(SEGMENTS), 3)
        return cls(
            positions={s: (float(v[0]), float(v[1])) for s, v in zip(SEGMENTS, vec)},
            angles={s: float(v[2]) for s, v in zip(SEGMENTS, vec)},
        )


# --------------------------------------------------------------------------------------------
# Joint limits
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class JointLimits:
    """Range of motion per joint, rad (SSPINNpose's L_B bounds by default: hip and ankle
    [−π/3, π/3], knee [−π/3, 0.1] — knee flexion is negative)."""

    lower: dict[str, float] = field(
        default_factory=lambda: {j: (-math.pi / 3) for j in JOINTS}
    )
    upper: dict[str, float] = field(
        default_factory=lambda: {j: (0.1 if j.startswith("knee") else math.pi / 3) for j in JOINTS}
    )

    def __post_init__(self) -> None:
        for j in JOINTS:
            if j not in self.lower or j not in self.upper:
                raise ParameterError(f"joint limits: missing joint {j!r}")
            if not self.lower[j] < self.upper[j]:
                raise ParameterError(f"joint limits of {j}: lower {self.lower[j]} must be < upper {self.upper[j]}")

    @classmethod
    def per_type(cls, lower: tuple[float, float, float], upper: tuple[float, float, float]) -> JointLimits:
        """The same (hip, knee, ankle) limits, rad, on both sides."""
        lo, hi = dict(zip(("hip", "knee", "ankle"), lower)), dict(zip(("hip", "knee", "ankle"), upper))
        return cls(lower={j: lo[j.split("_")[0]] for j in JOINTS}, upper={j: hi[j.split("_")[0]] for j in JOINTS})

    @classmethod
    def anatomical(cls) -> JointLimits:
        """Human ranges of motion, wide enough for running: hip −40°…+120° (flexion +), knee
        −140°…+0.1 rad (flexion −; the paper's small hyperextension allowance), ankle −50°…+40°
        (dorsiflexion +). From the AAOS normal values (hip flexion 120°, knee flexion 135–140°,
        ankle plantarflexion 50°), with the hip's extension widened from 30° to 40° because
        running reaches it (the Hamner running trial of ``$SSPINN_SHARED_DATA``: −31°), and the
        ankle's dorsiflexion from the weight-bearing lunge test (≈ 40° of shank inclination;
        Bennell et al., Aust J Physiother 44:175, 1998), since a loaded ankle exceeds the 20° of
        passive dorsiflexion. The paper's bounds (the default) stop the knee at 60° of flexion,
        which running swing exceeds by far (the Hamner trial: 111°; the synthetic running
        recordings: up to 116°)."""
        d = math.radians
        return cls.per_type((d(-40), d(-140), d(-50)), (d(120), 0.1, d(40)))

    @classmethod
    def named(cls, name: str) -> JointLimits:
        """``"paper"`` (the default bounds) or ``"anatomical"`` (:meth:`anatomical`)."""
        choices = {"paper": cls, "anatomical": cls.anatomical}
        if name not in choices:
            raise ParameterError(f"joint limits: unknown set {name!r}; choose one of {sorted(choices)}")
        return choices[name]()

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) as arrays in joint order."""
        return np.array([self.lower[j] for j in JOINTS]), np.array([self.upper[j] for j in JOINTS])
