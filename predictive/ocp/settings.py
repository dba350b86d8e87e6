"""Settings, bounds, scales and effort terms shared by the periodic gait OCP and the stride NLP.

The periodic problem (:class:`~predictive.ocp.collocation.OCPSettings`) and the single-stride
problem of the synthetic-data chain (:class:`~predictive.ocp.stride_nlp.StrideSettings`) model the
same body the same way: torques normalised by τmax and bounded by |τ| ≤ tau_bound·τmax, the
effort's exponent, the ankle's angle-dependent strength in the effort, the q̈ regularisation, the
human priors (:func:`grf_cap_penalty`, :func:`winter_angles`), joint ranges, pelvis height and
trunk tilt ranges, and IPOPT with MUMPS.

**Human priors.** A torque-driven model with the smooth one-point contact per foot, minimising
squared normalised torques, walks stiff-legged: 1.77 BW heel-strike peaks, 8 % double support and
54 % stance at 1.3 m/s against people's ≈ 1.1 BW, 20 % and 60 % (Winter 1991; Nilsson &
Thorstensson 1989, Acta Physiol Scand 136:217). The cubed effort (Ackermann & van den Bogert 2010,
J Biomech 43:1055: high-exponent effort criteria give more realistic double support and GRF)
lengthens stance and double support to people's (62 %, 24 %) but keeps a 1.6 BW impact; the
impact goes with two soft priors, both plain costs (the solution may still leave them when the
dynamics demand it):

* :func:`grf_cap_penalty`: the squared excess of each foot's vertical GRF over a cap at
  ``grf_cap_fraction`` of the way up the human per-stance peak range at the speed
  (:func:`grf_cap_bw`, ranges of :func:`sspinn.data.gait_norms.human_ranges`), weight ``w_grf_cap``;
* :func:`angle_prior`: walking's hip, knee and ankle angles near Winter's normal walking
  (:data:`WINTER_FOURIER`, a Fourier fit of the averaged stride of Winter 1991, The Biomechanics
  and Motor Control of Human Gait, 2nd ed., as published in the BioMAC-Sim-Toolbox), each
  deviation in units of ``angle_prior_sd_deg`` (the between-subject spread of sagittal angles is
  ≈ 3–6°; Winter 1991), weight ``w_angle_prior``; for walking (below :data:`WALK_RUN_SPEED`) only.
  The single-stride NLP keeps each stride near its subject's periodic gait instead (its guess).

Measured arm by arm at 1.3 m/s in docs/results/gait_norms.md. :class:`ProblemSettings` holds those fields once,
and the functions here build what both NLPs derive from them (variable scales, bounds per node,
strength-scaled torques, the acceleration regularisation, IPOPT's options), so the two problems
cannot drift apart.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any, ClassVar, Final, Literal, TypeVar

import casadi as ca
import numpy as np

from predictive.ocp import perturbation
from sspinn.data.gait_norms import SPEED_LIMITS, human_ranges
from sspinn.model import kinematics
from sspinn.model.body import BodyParameters, JointLimits
from sspinn.model.conventions import JOINTS, N_Q, N_TAU
from sspinn.model.trajectory import residual_scale

#: Scale of the accelerations q̈ in the NLPs' decision variables (physical = scale · scaled).
ACC_SCALE = 10.0

Effort = Literal["squared", "cubed"]
#: Exponent of each effort.
EFFORT_EXPONENTS: Final = {"squared": 2, "cubed": 3}
#: Speeds at or above this are running (the GRF cap's ranges; the synthetic data's gait families), m/s.
WALK_RUN_SPEED: Final = 2.0

#: Winter's normal walking (1.325 m/s, stride 1.14 s), right hip, knee and ankle angle (rad, sspinn
#: signs) from right heel strike: a0 and the cosine and sine coefficients of harmonics 1–6 of the
#: stride phase φ ∈ [0, 1) (least-squares fit of the 50 published samples, RMS misfit 0.07 / 0.22
#: / 0.33°); source in the module docstring.
WINTER_FOURIER: Final = {
    "hip": (0.1221, (0.2683, -0.0493, -0.0052, -0.0002, -0.0046, 0.0007), (-0.0767, -0.0222, 0.0269, -0.0039, 0.0031, 0.0023)),
    "knee": (-0.4325, (0.0673, 0.268, 0.0192, 0.0198, 0.0072, -0.0031), (0.3481, -0.1506, -0.087, -0.0126, -0.0175, -0.0058)),
    "ankle": (-0.0086, (-0.0111, 0.0295, -0.0652, 0.0337, 0.0062, 0.0054), (0.1391, -0.115, 0.0041, 0.0016, -0.0201, -0.0008)),
}
#: Winter's normal walking, right vertical GRF (BW) from right heel strike: a0 and harmonics 1–10
#: (as :data:`WINTER_FOURIER`; RMS misfit 0.007 BW).
WINTER_GRF_FOURIER: Final = (
    0.4861,
    (-0.1669, 0.0927, -0.2001, -0.0044, -0.0715, 0.0058, -0.0212, -0.008, -0.0106, -0.0085),
    (0.5257, 0.0709, 0.148, -0.0111, 0.0019, 0.0068, -0.0019, 0.0113, -0.0017, 0.0034),
)

_S = TypeVar("_S", bound="ProblemSettings")


@dataclass(frozen=True, kw_only=True)
class ProblemSettings:
    """Model, bounds, effort and IPOPT settings common to the gait NLPs (keyword-only fields).

    Attributes:
        tau_max: normalising torque per joint type (hip, knee, ankle) in units of BW·H
            (body weight × body height, N·m); also sets the bound |τ| ≤ tau_bound·τmax.
        tau_bound: torque bound as a multiple of ``tau_max``.
        effort: "squared" or "cubed": exponent of the normalised torques in the effort.
        w_grf_cap: weight of the GRF cap prior (dimensionless, per BW² of excess; 0: none).
        grf_cap_fraction: where the cap lies in the human peak range, 0 (its low end) … 1 (its
            high end) (:func:`grf_cap_bw`).
        w_angle_prior: weight of the angle prior (dimensionless, mean squared deviation in units
            of ``angle_prior_sd_deg``; 0: none).
        angle_prior_sd_deg: tolerance of the angle prior, degrees.
        w_grf_prior: weight of the vertical-GRF prior (walking; dimensionless, mean squared
            deviation from Winter's vertical GRF in units of ``grf_prior_sd_bw``; 0: none).
        grf_prior_sd_bw: tolerance of the GRF prior, BW.
        w_slip: weight of the sliding-power term Σ_feet (F_x·ẋ_c/BW)² (BW·m/s, :func:`sliding_power`;
            0: none): the power of the friction force on a sliding contact point. The smooth
            contact lets a swinging foot carry a few per cent of body weight millimetres above
            the floor and skid — a free brake, and with the GRF cap a way to let the heel down
            before it lands (a 0.1 BW heel skim through late swing, counted as taps by the norms
            check) — which the term makes cost what a skid costs.
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
    effort: Effort = "cubed"
    w_grf_cap: float = 100.0
    grf_cap_fraction: float = 0.5
    w_angle_prior: float = 0.1
    angle_prior_sd_deg: float = 5.0
    w_grf_prior: float = 3.0
    grf_prior_sd_bw: float = 0.15
    w_slip: float = 100.0
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
        "effort",
        "w_grf_cap",
        "grf_cap_fraction",
        "w_angle_prior",
        "angle_prior_sd_deg",
        "w_grf_prior",
        "grf_prior_sd_bw",
        "w_slip",
        "w_acc",
        "ankle_strength_slope",
        "pelvis_height_bounds",
        "tilt_bounds",
    )

    def __post_init__(self) -> None:
        if self.effort not in EFFORT_EXPONENTS:
            raise ValueError(f"effort must be 'squared' or 'cubed', got {self.effort!r}")
        for name in ("w_acc", "w_grf_cap", "w_angle_prior", "w_grf_prior", "w_slip"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        if not 0 <= self.grf_cap_fraction <= 1:
            raise ValueError(f"grf_cap_fraction must be in [0, 1], got {self.grf_cap_fraction}")
        if not 0 < self.grf_prior_sd_bw <= 10:
            raise ValueError(f"grf_prior_sd_bw must be in (0, 10] BW, got {self.grf_prior_sd_bw}")
        if not 0 < self.angle_prior_sd_deg <= 90:
            raise ValueError(f"angle_prior_sd_deg must be in (0, 90] degrees, got {self.angle_prior_sd_deg}")

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


def effort_power(tn: Any, effort: str) -> Any:
    """|τn|^e elementwise (CasADi), e = 2 ("squared") or 3 ("cubed")."""
    return tn**2 if EFFORT_EXPONENTS[effort] == 2 else ca.fabs(tn) ** 3


def grf_cap_bw(speed: float, fraction: float) -> float:
    """The GRF cap at ``speed`` (m/s), BW: ``fraction`` of the way up the human per-stance
    vertical GRF peak range (:func:`sspinn.data.gait_norms.human_ranges`, walking below
    :data:`WALK_RUN_SPEED`, running above; speeds clipped to the ranges' speeds): with 0.5 1.10,
    1.18 and 1.35 BW at 0.8, 1.3 and 1.8 m/s, 2.6 BW running."""
    mode = "run" if speed >= WALK_RUN_SPEED else "walk"
    low, high = SPEED_LIMITS[mode]
    peak_low, peak_high = human_ranges(float(np.clip(speed, low, high)), mode).peak_bw
    return peak_low + fraction * (peak_high - peak_low)


def grf_cap_penalty(fy_bw: Any, cap_bw: Any) -> Any:
    """Σ_feet max(F_y/BW − cap, 0)² (CasADi) of the vertical forces ``fy_bw`` (BW)."""
    return ca.sumsqr(ca.fmax(fy_bw - cap_bw, 0))


def _fourier(phase: np.ndarray | float, a0: float, cos: tuple[float, ...], sin: tuple[float, ...]) -> np.ndarray:
    ph = np.asarray(phase, dtype=float)[..., None]
    k = np.arange(1, len(cos) + 1)
    return a0 + np.cos(2 * math.pi * k * ph) @ np.array(cos) + np.sin(2 * math.pi * k * ph) @ np.array(sin)


def winter_angles(phase: np.ndarray | float) -> np.ndarray:
    """Winter's normal-walking hip, knee and ankle angles (rad) at stride phases from heel
    strike (:data:`WINTER_FOURIER`); shape (..., 3)."""
    return np.stack([_fourier(phase, *WINTER_FOURIER[name]) for name in ("hip", "knee", "ankle")], axis=-1)


def winter_grf(phase: np.ndarray | float) -> np.ndarray:
    """Winter's normal-walking vertical GRF (BW, ≥ 0) of one foot at stride phases from its heel
    strike (:data:`WINTER_GRF_FOURIER`)."""
    return np.maximum(_fourier(phase, *WINTER_GRF_FOURIER), 0.0)


def angle_prior(joints: Any, reference: Any, sd_deg: float) -> Any:
    """Mean over the six joints of ((θ − θ_ref)/sd)² (CasADi), JOINTS order, sd in degrees."""
    return ca.sumsqr((joints - reference) / math.radians(sd_deg)) / N_TAU


def sliding_power(q: Any, u: Any, a: Any, grf: Any, w: Any, body: Any) -> Any:
    """(2,) F_x·ẋ_c per foot (CasADi; N·m/s): the power of each foot's friction force on its
    contact point's sliding (contact point at the fractions ``w``; ``body`` numeric or symbolic)."""
    pk = kinematics.point_kinematics(q, u, a, w, body)
    return ca.vertcat(*(grf[2 * k] * pk[kinematics.point_index(f"contact_{side}"), 2] for k, side in enumerate("rl")))
