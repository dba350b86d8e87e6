"""Settings, bounds, scales and effort terms shared by the periodic gait OCP and the stride NLP.

The periodic problem (:class:`~predictive.ocp.collocation.OCPSettings`) and the single-stride
problem of the synthetic-data chain (:class:`~predictive.ocp.stride_nlp.StrideSettings`) model the
same body the same way: torques normalised by τmax and bounded by |τ| ≤ tau_bound·τmax, the
ankle's angle-dependent strength in the effort, the q̈ regularisation, joint ranges, pelvis height
and trunk tilt ranges, and IPOPT with MUMPS. :class:`ProblemSettings` holds those fields once,
and the functions here build what both NLPs derive from them (variable scales, bounds per node,
strength-scaled torques, the acceleration regularisation, IPOPT's options), so the two problems
cannot drift apart.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any, ClassVar, TypeVar

import casadi as ca
import numpy as np

from predictive.ocp import perturbation
from sspinn.model.body import BodyParameters, JointLimits
from sspinn.model.conventions import JOINTS, N_Q, N_TAU
from sspinn.model.trajectory import residual_scale

#: Scale of the accelerations q̈ in the NLPs' decision variables (physical = scale · scaled).
ACC_SCALE = 10.0

_S = TypeVar("_S", bound="ProblemSettings")


@dataclass(frozen=True, kw_only=True)
class ProblemSettings:
    """Model, bounds, effort and IPOPT settings common to the gait NLPs (keyword-only fields).

    Attributes:
        tau_max: normalising torque per joint type (hip, knee, ankle) in units of BW·H
            (body weight × body height, N·m); also sets the bound |τ| ≤ tau_bound·τmax.
        tau_bound: torque bound as a multiple of ``tau_max``.
        w_acc: weight of the q̈ regularisation (dimensionless, see :func:`acceleration_regularisation`).
        ankle_strength_slope: k in the ankle's relative strength exp(±k·θ_ankle), 1/rad
            (0: angle-independent strength; see :func:`strength_scaled`).
        pelvis_height_bounds: pelvis_ty (hip joint centre height) range as fractions of H.
        tilt_bounds: pelvis_tilt (trunk global angle) range, rad.
        tol: IPOPT tolerance (scaled NLP error).
        constr_tol: IPOPT constr_viol_tol (scaled units: BW, BW·H, scaled velocities).
        max_iter: IPOPT iteration limit.
    """

    tau_max: tuple[float, float, float] = (0.1, 0.1, 0.1)
    tau_bound: float = 3.0
    w_acc: float = 0.1
    ankle_strength_slope: float = 1.0
    pelvis_height_bounds: tuple[float, float] = (0.3, 0.7)
    tilt_bounds: tuple[float, float] = (-0.6, 0.6)
    tol: float = 1e-6
    constr_tol: float = 1e-8
    max_iter: int = 3000

    #: The fields that define the model and its effort (the rest are IPOPT's tolerances).
    MODEL_FIELDS: ClassVar[tuple[str, ...]] = (
        "tau_max",
        "tau_bound",
        "w_acc",
        "ankle_strength_slope",
        "pelvis_height_bounds",
        "tilt_bounds",
    )

    def __post_init__(self) -> None:
        if self.w_acc < 0:
            raise ValueError(f"w_acc must be >= 0, got {self.w_acc}")

    def model_settings(self) -> dict[str, Any]:
        """The :data:`MODEL_FIELDS` as keyword arguments (e.g. for another problem of the same model)."""
        return {name: getattr(self, name) for name in self.MODEL_FIELDS}

    def to_dict(self) -> dict[str, Any]:
        """JSON-native dict (tuples as lists), e.g. as stored in :attr:`GaitSolution.settings`."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls: type[_S], data: Mapping[str, Any]) -> _S:
        """Inverse of :meth:`to_dict` (e.g. ``OCPSettings.from_dict(solution.settings)``)."""
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})

    def node_bounds(self, joint_limits: JointLimits, height: float) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) bounds of one node's [q, u, q̈, τ/τmax] (physical q, speeds and
        accelerations unbounded): joint ranges, pelvis height and tilt ranges, |τ/τmax| ≤ tau_bound.
        ``height`` is the body height, m."""
        lo_j, hi_j = joint_limits.arrays()
        q_lo = np.concatenate([[-np.inf, self.pelvis_height_bounds[0] * height, self.tilt_bounds[0]], lo_j])
        q_hi = np.concatenate([[np.inf, self.pelvis_height_bounds[1] * height, self.tilt_bounds[1]], hi_j])
        lo = np.concatenate([q_lo, np.full(2 * N_Q, -np.inf), np.full(N_TAU, -self.tau_bound)])
        hi = np.concatenate([q_hi, np.full(2 * N_Q, np.inf), np.full(N_TAU, self.tau_bound)])
        return lo, hi

    def ipopt_options(self, overrides: Mapping[str, Any] | None = None, verbose: bool = False) -> dict[str, Any]:
        """IPOPT's options: these tolerances, MUMPS, the adaptive barrier, quiet unless ``verbose``;
        then ``overrides``; then the robustness-check options of :mod:`predictive.ocp.perturbation`."""
        opts: dict[str, Any] = {
            "tol": self.tol,
            "constr_viol_tol": self.constr_tol,
            "max_iter": self.max_iter,
            "linear_solver": "mumps",
            "mu_strategy": "adaptive",
            "print_level": 5 if verbose else 0,
            "sb": "no" if verbose else "yes",  # IPOPT's banner
        }
        opts.update(overrides or {})
        opts.update(perturbation.extra_ipopt_options())
        return opts


def default_joint_limits() -> JointLimits:
    """Human sagittal ranges of motion (rad): hip −30°…+90° (flexion +), knee −120°…0° (knee
    flexion is negative; hyperextension excluded), ankle −40°…+30° (dorsiflexion +)."""
    d = math.radians
    return JointLimits.per_type((d(-30), d(-120), d(-40)), (d(90), 0.0, d(30)))


def joint_type_values(values: tuple[float, float, float]) -> np.ndarray:
    """Per-joint values (JOINTS order) from per-type (hip, knee, ankle) values."""
    table = dict(zip(("hip", "knee", "ankle"), values))
    return np.array([table[j.split("_")[0]] for j in JOINTS])


def nlp_scales(settings: ProblemSettings, body: BodyParameters, speed: float) -> dict[str, np.ndarray]:
    """Scales of the NLPs for ``body`` at ``speed`` (m/s): ``res_scale`` of the Kane residual rows
    (BW for pelvis_tx/ty, N; BW·H for the rotations, N·m), ``tau_max`` per joint (N·m) and
    ``u_scale`` of the speeds (max(v, 1) m/s for pelvis_tx, 1 m/s, 2 rad/s for the trunk,
    5 rad/s for the joints)."""
    bw, H = body.body_weight, body.height
    return {
        "res_scale": residual_scale(body),
        "tau_max": joint_type_values(settings.tau_max) * bw * H,
        "u_scale": np.array([max(speed, 1.0), 1.0, 2.0] + [5.0] * N_TAU),
    }


def ankle_strength(tau_scaled: Any, theta: Any, slope: float, exp: Any, tanh: Any) -> Any:
    """exp(k·θ·tanh(τn/0.02)): the factor (1 / relative ankle strength) that multiplies the
    normalised ankle torque τn in the effort (see :func:`strength_scaled`); ``exp``/``tanh`` of
    the backend (CasADi, torch or NumPy)."""
    return exp(slope * theta * tanh(tau_scaled / 0.02))


def strength_scaled(tn: Any, q: Any, slope: float) -> Any:
    """Normalised torques τ/τmax (CasADi column, JOINTS order) divided by the relative ankle
    strength exp(±k·θ_ankle), k = ``slope``: plantarflexor torque (τ < 0) is weaker with the
    ankle plantarflexed (θ < 0), dorsiflexor torque the other way round (muscle force–length
    relation); the sign is blended smoothly by tanh. ``slope`` 0 returns ``tn`` unchanged."""
    if not slope:
        return tn
    out = [tn[j] for j in range(N_TAU)]
    for j in (2, 5):  # ankle_r, ankle_l in JOINTS order
        out[j] = tn[j] * ankle_strength(tn[j], q[3 + j], slope, ca.exp, ca.tanh)
    return ca.vertcat(*out)


def acceleration_regularisation(a: Any, T: Any) -> Any:
    """Σ_i (q̈_i·T²/(4π²))² at one node (CasADi): the acceleration on the normalised cycle (for
    q = A·sin(2πt/T) its amplitude is A, in rad or m), so the term favours neither slow nor fast
    strides."""
    return ca.sumsqr(a * (T**2 / (4 * math.pi**2)))
