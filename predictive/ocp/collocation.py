"""Predictive gait simulation by direct collocation (CasADi + IPOPT) on the sspinn 9-DOF model.

Formulation (all units SI; signs of :mod:`sspinn.model.conventions`: hip flexion +, knee flexion −,
ankle dorsiflexion +, a positive pelvis_tilt leans the trunk back):

* **Grid.** ``N`` nodes ``t_k = k·h`` (``k = 0 … N−1``) spanning one gait cycle of duration ``T``
  (``h = T/N``), or — with ``gait_cycle="half"`` — half a cycle (``h = T/(2N)``) with
  left/right symmetry. Node ``N`` is node 0 of the next cycle, so periodicity needs no extra
  variables: the state "before" node 0 is node ``N−1`` with pelvis_tx moved back by one
  stride ``v·T`` (full cycle) or, for the half cycle, node ``N−1`` mirrored (left and right legs
  swapped) and moved back by half a stride ``v·T/2``. The average speed is therefore exactly
  ``v`` (Σ of the pelvis_tx increments equals ``v·T``). pelvis_tx(t_0) = 0 removes the
  translation invariance.
* **Variables per node.** q (9), u = q̇ (9), q̈ (9) and the joint torques τ (6); plus the
  stride duration ``T``, fixed by default to a typical human value at the requested speed
  (:func:`typical_stride_duration`) or free within bounds (``free_duration=True``), and the
  average speed ``v``, fixed to ``speed`` by default or free within ``speed_bounds``
  (``free_speed=True``, used when tracking data whose speed is unknown). With the
  torque effort below, a free duration drifts to implausibly short, shuffling strides (the
  effort has no cost for fast leg swing or for step-to-step collisions), which is why the
  default fixes it.
* **Symmetry.** ``gait_cycle="half"`` (default) assumes the healthy, symmetric gait that the
  comparison data show and halves the problem; it also kept IPOPT away from the asymmetric
  local optima (one leg in long stance, the other hopping) that full-cycle solves found in
  early versions of the objective. ``gait_cycle="full"`` assumes no symmetry (with the default
  settings it reproduced the half-cycle solutions at 1.3 and 3.5 m/s).
* **Dynamics.** Implicit, as equality constraints at every node:
  ``M(q)·q̈ − f(q, u, τ, F(q, u), w(q)) = 0`` with :func:`sspinn.model.dynamics.kane_residual` and the
  ground reaction forces ``F`` of the smooth contact model (:func:`sspinn.model.dynamics.contact_forces`)
  with the **forward-simulation friction law** ``F_x = −μ·tanh(ẋ/v_s)·F_y``: it needs no extra
  (learned) input, opposes sliding of the contact point so the stance foot cannot skate, is
  smooth (C∞), and is the law the forward simulator uses, so solutions can be replayed there.
  Its stiffness (small ``v_s``) restricts explicit integrators but not implicit collocation.
  The residual is scaled by BW (pelvis_tx, pelvis_ty rows, N) and BW·H (rotational rows, N·m).
* **Collocation: backward Euler** ``q_k − q_{k−1} = h·u_k``, ``u_k − u_{k−1} = h·q̈_k``. It is
  first-order but L-stable, which suits the stiff spring-damper contact (100 BW/m, 300 /m
  transition): the trapezoidal rule is only A-stable and does not damp the fast contact modes
  on a coarse grid. Backward Euler is the common choice of the implicit gait2d predictive work
  (van den Bogert et al. 2011, "Implicit methods for efficient musculoskeletal simulation and
  optimal control"; Ackermann, Koelewijn), is robust from poor initial guesses, needs one
  dynamics evaluation per node, and the dynamics hold *exactly* at the nodes. Its price is a
  first-order discretisation error between the nodes (see
  :meth:`GaitSolution.resampled_residual`).
* **Objective** (dimensionless), per unit distance up to the constant factor 1/v:
  ``mean_k Σ_j |τ_kj/τmax_j|^e  +  w_acc · mean_k Σ_i (q̈_ki·T²/(4π²))²  +  human priors`` with
  ``e = 3`` ("cubed", the default; Ackermann & van den Bogert 2010, J Biomech 43:1055: high
  exponents give more realistic double support and GRF) or ``2`` ("squared"), τmax = 0.1·BW·H
  (≈120 N·m for 1.75 m, 70 kg) for every joint,
  except that the ankle's strength depends on its angle θ (muscle force–length relation):
  plantarflexor torque (τ < 0) is divided by exp(k·θ), dorsiflexor torque by exp(−k·θ), with
  k = 1 /rad (plantarflexors at half strength near 40° plantarflexion, as in human
  torque–angle curves; the sign switch is blended by tanh(τ/(0.02·τmax))). Without it the
  cheapest gait the optimiser found was toe-walking with the ankle on its plantarflexion limit
  for the whole stance, reached or not depending on small changes of body size or guess; with
  it, half- and full-cycle solves and both tested body sizes gave the same heel–toe gait.
  Because the nodes are equally spaced in time, the mean over nodes is ∫effort dt / T, and
  effort per distance = (∫effort dt)/(v·T) = mean/v: with the speed fixed the mean is the cost
  of transport of this effort measure. The second term regularises accelerations and smooths the
  motion (fewer impact spikes, no chattering): q̈·T²/(4π²) is the acceleration on the
  normalised cycle (for q = A·sin(2πt/T) its amplitude is A, in rad or m), so the term does
  not favour slow or fast strides when the duration is free. The **human priors**
  (:meth:`PredictiveGaitProblem._prior_terms`; why and their sources in
  :mod:`predictive.ocp.settings`): the power of friction on sliding contact points
  (``w_slip``), a soft cap of the vertical GRF inside the human peak range at the speed
  (``w_grf_cap``) and, when walking, Winter's joint angles (``w_angle_prior``) and vertical GRF
  (``w_grf_prior``) with the right heel strike at node 0. With the squared effort and no priors
  the model walked stiff-legged (1.77 BW heel-strike peak, 8 % double support, 54 % stance at
  1.3 m/s; docs/results/gait_norms.md has the figures arm by arm).
* **Bounds.** Joint ranges from :class:`sspinn.model.body.JointLimits` (default:
  :func:`~predictive.ocp.settings.default_joint_limits`, knee ≤ 0), pelvis height and trunk tilt
  ranges, |τ| ≤ 3·τmax, duration bounds.
* **Initial guess and multi-start.** Data-free (:meth:`PredictiveGaitProblem.generic_guess`):
  pelvis_tx = v·t at constant hip height and textbook-shaped joint-angle curves (sinusoidal hip,
  Gaussian knee-flexion bump in swing), zero torques. The problem is not convex, and which local
  optimum one IPOPT run from that guess reaches depends on the floating-point path: on 25 nodes
  at 1.2 m/s, guesses perturbed by 1e-9 or another MUMPS ordering (``scripts/check_robustness.py``)
  ended in hopping gaits (objective 0.97–2.37, flight 36 %) or stiff walking (0.36–0.45) instead
  of the 0.20 walking optimum, each of three starts at least once in nine perturbations. So a
  solve from the data-free guess is a **multi-start** (:data:`DEFAULT_STARTS`: textbook
  amplitudes with IPOPT's adaptive barrier, the same with a monotone barrier, 70 % amplitudes)
  and the successful start with the lowest objective wins; in those nine perturbations the
  winner was always a walking optimum (0.200 or 0.206).
* **Scaling.** Decision variables are scaled to O(1) (τ/τmax, q̈/10, u/5 for joint speeds,
  u/2 for the trunk, u/max(v, 1) for pelvis_tx); the kinematic constraints are written as
  velocity and acceleration differences divided by the same scales, the dynamics by BW or BW·H.

The settings, bounds, scales, strength-scaled effort and IPOPT options that this problem shares
with the stride NLP of the synthetic data (:mod:`predictive.ocp.stride_nlp`) are built in
:mod:`predictive.ocp.settings`; the data-free guess comes from :mod:`predictive.ocp.generic_gait`.

Extension (:mod:`predictive.ocp.tracking`): subclasses add objective terms by overriding
:meth:`PredictiveGaitProblem._objective`, which receives the node expressions
(:class:`NodeExpressions`) of the already built constraints.

The NLP is built from CasADi SX expressions (the whole problem is a few ten-thousand scalar
operations) and solved by IPOPT with MUMPS and an exact Hessian.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Final, Literal

import casadi as ca
import numpy as np

from predictive.ocp import perturbation
from predictive.ocp.generic_gait import generic_gait, typical_stride_duration
from predictive.ocp.limits import NODES_RANGE, check_nodes, check_speed
from predictive.ocp.settings import (
    ACC_SCALE,
    WALK_RUN_SPEED,
    Effort,
    ProblemSettings,
    acceleration_regularisation,
    angle_prior,
    default_joint_limits,
    effort_power,
    grf_cap_bw,
    grf_cap_penalty,
    nlp_scales,
    sliding_power,
    strength_scaled,
    winter_angles,
    winter_grf,
)
from predictive.ocp.solution import GaitSolution, mirror_states
from sspinn.model import dynamics as dyn
from sspinn.model.body import BodyParameters, JointLimits
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import N_Q, N_TAU

GaitCycle = Literal["full", "half"]

#: IPOPT return statuses that count as a solved problem.
SUCCESS_STATUSES = ("Solve_Succeeded",)


class OCPError(RuntimeError):
    """IPOPT did not solve the optimal control problem; ``status`` is IPOPT's return status and
    ``solution`` the (non-optimal) last iterate, for inspection."""

    def __init__(self, status: str, message: str, solution: GaitSolution | None = None) -> None:
        super().__init__(message)
        self.status = status
        self.solution = solution


@dataclass(frozen=True)
class Start:
    """One start of a multi-start from the data-free guess (:meth:`PredictiveGaitProblem.solve_multistart`).

    Attributes:
        amplitude: scale of the joint excursions of :func:`generic_gait` (1: textbook shapes).
        ipopt_options: IPOPT options of this start (the caller's options override them).
    """

    amplitude: float = 1.0
    ipopt_options: Mapping[str, Any] | None = None

    def describe(self) -> dict[str, Any]:
        return {"amplitude": self.amplitude, "ipopt_options": dict(self.ipopt_options or {})}


#: IPOPT's monotone barrier from a larger initial barrier parameter: a different path to the optimum.
MONOTONE_BARRIER: Final[Mapping[str, Any]] = {"mu_strategy": "monotone", "mu_init": 0.1}

def objectives_agree(objectives: Sequence[float], rtol: float) -> bool:
    """Whether two of ``objectives`` are equal within the relative tolerance ``rtol`` (two IPOPT
    paths to one optimum: the stopping rule of a multi-start)."""
    return any(math.isclose(a, b, rel_tol=rtol) for k, a in enumerate(objectives) for b in objectives[k + 1 :])


#: The multi-start of every solve from the data-free guess (see the module docstring).
DEFAULT_STARTS: Final[tuple[Start, ...]] = (
    Start(),
    Start(ipopt_options=MONOTONE_BARRIER),
    Start(amplitude=0.7),
)


@dataclass(frozen=True)
class OCPSettings(ProblemSettings):
    """Settings of :func:`solve_predictive` (stored with every solution): the periodic problem's
    own fields below plus the model, bounds, effort and IPOPT fields of
    :class:`~predictive.ocp.settings.ProblemSettings` (keyword-only; ``tau_max``, ``tau_bound``,
    ``effort``, the human priors' weights, ``w_acc``, ``ankle_strength_slope``,
    ``pelvis_height_bounds``, ``tilt_bounds``, ``tol``, ``constr_tol`` 1e-8, ``max_iter`` 3000).

    Attributes:
        speed: average forward speed v, m/s (pelvis_tx advances v·T per cycle); with
            ``free_speed`` only the initial guess.
        n_nodes: collocation nodes per simulated interval (the whole cycle, or half of it).
        gait_cycle: "full" (one periodic cycle, no symmetry assumed) or "half" (half a cycle,
            the second half is the first with left and right swapped).
        duration: stride (cycle) duration in s; None: :func:`typical_stride_duration` of the speed.
            It is fixed unless ``free_duration``, and then it is only the initial guess.
        free_duration: optimise the duration within ``duration_bounds``.
        duration_bounds: (min, max) stride duration in s when free.
        free_speed: optimise the average speed within ``speed_bounds``.
        speed_bounds: (min, max) average speed in m/s when free.
    """

    speed: float
    n_nodes: int = 50
    gait_cycle: GaitCycle = "half"
    duration: float | None = None
    free_duration: bool = False
    duration_bounds: tuple[float, float] = (0.4, 2.0)
    free_speed: bool = False
    speed_bounds: tuple[float, float] = (0.0, 10.0)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed >= 0):
            raise ValueError(f"speed must be a finite number >= 0 m/s, got {self.speed!r}")
        if not NODES_RANGE[0] <= self.n_nodes <= NODES_RANGE[1]:
            raise ValueError(f"n_nodes must be in {NODES_RANGE[0]}–{NODES_RANGE[1]}, got {self.n_nodes}")
        if self.gait_cycle not in ("full", "half"):
            raise ValueError(f"gait_cycle must be 'full' or 'half', got {self.gait_cycle!r}")
        lo, hi = self.duration_bounds
        if not 0 < lo <= hi:
            raise ValueError(f"duration_bounds must satisfy 0 < min <= max (s), got {self.duration_bounds}")
        if not 0 <= self.speed_bounds[0] <= self.speed_bounds[1]:
            raise ValueError(f"speed_bounds must satisfy 0 <= min <= max (m/s), got {self.speed_bounds}")
        if self.duration is not None and not self.duration > 0:
            raise ValueError(f"duration must be > 0 s, got {self.duration}")
        super().__post_init__()

    @property
    def stride_duration(self) -> float:
        """The fixed duration, or the initial guess of a free one, s."""
        T = self.duration if self.duration is not None else typical_stride_duration(self.speed)
        return float(np.clip(T, *self.duration_bounds)) if self.free_duration else float(T)


# ---------------------------------------------------------------------------------------------
# Index helpers
# ---------------------------------------------------------------------------------------------
@dataclass
class _Layout:
    """Decision-vector layout: per node [q, u, a, tau] (scaled), then the duration T (s) and the
    average speed v (m/s)."""

    n: int
    per_node: int = 2 * N_Q + N_Q + N_TAU
    slices: dict[str, slice] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.slices = {
            "q": slice(0, N_Q),
            "u": slice(N_Q, 2 * N_Q),
            "a": slice(2 * N_Q, 3 * N_Q),
            "tau": slice(3 * N_Q, 3 * N_Q + N_TAU),
        }

    @property
    def size(self) -> int:
        return self.n * self.per_node + 2

    def split(self, z: Any) -> tuple[Any, Any]:
        """(node matrix (per_node × n), T) from the flat decision vector (SX or ndarray)."""
        nodes = z[: self.n * self.per_node]
        T = z[self.n * self.per_node]
        if isinstance(nodes, np.ndarray):
            return nodes.reshape(self.n, self.per_node).T, T
        return ca.reshape(nodes, self.per_node, self.n), T

    def speed(self, z: Any) -> Any:
        """The average speed v (m/s) from the flat decision vector."""
        return z[self.n * self.per_node + 1]


@dataclass(frozen=True)
class NodeExpressions:
    """Symbolic (CasADi SX) quantities at the collocation nodes, handed to
    :meth:`PredictiveGaitProblem._objective`. Lists have one entry per node (column vectors).

    Attributes:
        q, u, a: coordinates (m, rad), speeds (m/s, rad/s), accelerations (m/s², rad/s²).
        tau: joint torques, N·m.
        tau_scaled: τ/τmax (dimensionless decision variables).
        grf: ground reaction forces [Fx_r, Fy_r, Fx_l, Fy_l], N (contact model).
        T: cycle duration, s.
        v: average speed, m/s.
        slip: each foot's sliding power F_x·ẋ_c / BW (2), m/s (:func:`~predictive.ocp.settings.sliding_power`).
    """

    q: list[Any]
    u: list[Any]
    a: list[Any]
    tau: list[Any]
    tau_scaled: list[Any]
    grf: list[Any]
    T: Any
    v: Any
    slip: list[Any] = field(default_factory=list)


# ---------------------------------------------------------------------------------------------
# The problem
# ---------------------------------------------------------------------------------------------
class PredictiveGaitProblem:
    """The collocation NLP for one body and settings; :meth:`solve` runs IPOPT.

    Build once and call :meth:`solve` with different initial guesses if needed.
    """

    def __init__(
        self,
        settings: OCPSettings,
        body: BodyParameters | None = None,
        contact: ContactParameters | None = None,
        joint_limits: JointLimits | None = None,
    ) -> None:
        self.settings = settings
        self.body = body if body is not None else BodyParameters.from_anthropometry(1.75, 70.0)
        self.contact = contact if contact is not None else ContactParameters()
        self.joint_limits = joint_limits if joint_limits is not None else default_joint_limits()
        self.bw = self.body.body_weight
        self.height = self.body.height
        scales = nlp_scales(settings, self.body, settings.speed)
        self.tau_max = scales["tau_max"]  # N·m
        self.layout = _Layout(settings.n_nodes)
        # variable scales (physical = scale · scaled)
        self.q_scale = np.ones(N_Q)
        self.u_scale = scales["u_scale"]
        self.a_scale = np.full(N_Q, ACC_SCALE)
        self.res_scale = scales["res_scale"]
        self._node_fun = self._build_node_function()
        self._nlp, self._bounds = self._build_nlp()
        self._solvers: dict[str, ca.Function] = {}

    # ----------------------------------------------------------------- building blocks
    def _build_node_function(self) -> ca.Function:
        """(q, u, a, tau) → (scaled Kane residual (9), grf (4) in N, w (2), sliding power (2) in BW·m/s)."""
        q, u, a, tau = (ca.SX.sym(name, n) for name, n in (("q", N_Q), ("u", N_Q), ("a", N_Q), ("tau", N_TAU)))
        grf, w = dyn.contact_forces(q, u, self.body, self.contact)
        r = dyn.kane_residual(q, u, a, tau, grf, w, self.body)
        slip = sliding_power(q, u, a, grf, w, self.body) / self.bw
        return ca.Function("node", [q, u, a, tau], [r / ca.DM(self.res_scale), grf, w, slip])

    @property
    def _n_intervals_per_cycle(self) -> int:
        return self.settings.n_nodes * (2 if self.settings.gait_cycle == "half" else 1)

    def _previous_state(self, q_last: Any, u_last: Any, T: Any, v: Any) -> tuple[Any, Any]:
        """The state before node 0: the last node moved back by one stride v·T (or mirrored and
        moved back by half a stride)."""
        s = self.settings
        if s.gait_cycle == "half":
            q_prev, u_prev = mirror_states(q_last), mirror_states(u_last)
            shift = v * T / 2
        else:
            q_prev, u_prev, shift = q_last, u_last, v * T
        q_prev = ca.vertcat(q_prev[0] - shift, q_prev[1:])
        return q_prev, u_prev

    def _build_nlp(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        s, lay = self.settings, self.layout
        z = ca.SX.sym("z", lay.size)
        nodes, T = lay.split(z)
        v = lay.speed(z)
        sl = lay.slices
        qs, us, as_, ts = (ca.DM(x) for x in (self.q_scale, self.u_scale, self.a_scale, self.tau_max))
        q = [nodes[sl["q"], k] * qs for k in range(lay.n)]
        u = [nodes[sl["u"], k] * us for k in range(lay.n)]
        a = [nodes[sl["a"], k] * as_ for k in range(lay.n)]
        tau = [nodes[sl["tau"], k] * ts for k in range(lay.n)]
        h = T / self._n_intervals_per_cycle

        g: list[Any] = []
        grf, slip = [], []
        for k in range(lay.n):
            if k == 0:
                q_prev, u_prev = self._previous_state(q[-1], u[-1], T, v)
            else:
                q_prev, u_prev = q[k - 1], u[k - 1]
            g.append(((q[k] - q_prev) / h - u[k]) / us)
            g.append(((u[k] - u_prev) / h - a[k]) / as_)
            res, grf_k, _, slip_k = self._node_fun(q[k], u[k], a[k], tau[k])
            g.append(res)
            grf.append(grf_k)
            slip.append(slip_k)
        tau_scaled = [nodes[sl["tau"], k] for k in range(lay.n)]
        objective = self._objective(
            NodeExpressions(q=q, u=u, a=a, tau=tau, tau_scaled=tau_scaled, grf=grf, T=T, v=v, slip=slip)
        )
        nlp = {"x": z, "f": objective, "g": ca.vertcat(*g)}

        # bounds (physical → scaled)
        node_lo, node_hi = s.node_bounds(self.joint_limits, self.height)
        node_lo[:N_Q] /= self.q_scale
        node_hi[:N_Q] /= self.q_scale
        t_lo, t_hi = s.duration_bounds if s.free_duration else (s.stride_duration, s.stride_duration)
        v_lo, v_hi = s.speed_bounds if s.free_speed else (s.speed, s.speed)
        lbx = np.concatenate([np.tile(node_lo, lay.n), [t_lo, v_lo]])
        ubx = np.concatenate([np.tile(node_hi, lay.n), [t_hi, v_hi]])
        lbx[0] = ubx[0] = 0.0  # pelvis_tx(t_0) = 0
        n_g = nlp["g"].shape[0]
        bounds = {"lbx": lbx, "ubx": ubx, "lbg": np.zeros(n_g), "ubg": np.zeros(n_g)}
        return nlp, bounds

    def _effort_terms(self, x: NodeExpressions) -> tuple[Any, Any]:
        """(effort, acceleration regularisation), both averaged over the nodes (dimensionless):
        mean_k Σ_j |τ_kj/τmax_j|^e (ankle strength-scaled) and mean_k Σ_i (q̈_ki·T²/(4π²))²."""
        s = self.settings
        effort = 0
        reg = 0
        for k in range(self.layout.n):
            tn = strength_scaled(x.tau_scaled[k], x.q[k], s.ankle_strength_slope)
            effort += ca.sum1(effort_power(tn, s.effort))
            reg += acceleration_regularisation(x.a[k], x.T)
        return effort / self.layout.n, reg / self.layout.n

    def _prior_terms(self, x: NodeExpressions) -> Any:
        """The human priors (:mod:`predictive.ocp.settings`), averaged over the nodes: w_grf_cap ×
        the GRF cap's excess (BW²), w_slip × the squared sliding power ((BW·m/s)²) and, when
        walking, w_angle_prior × the angle prior against Winter's walking with the right heel
        strike at node 0 (the left leg half a cycle later)."""
        s, n = self.settings, self.layout.n
        total = 0
        if s.w_slip:
            total += s.w_slip * sum(ca.sumsqr(x.slip[k]) for k in range(n)) / n
        if s.w_grf_cap:
            cap = grf_cap_bw(s.speed, s.grf_cap_fraction)
            total += s.w_grf_cap * sum(grf_cap_penalty(x.grf[k][[1, 3]] / self.bw, cap) for k in range(n)) / n
        walking = 0 < s.speed < WALK_RUN_SPEED
        phase = np.arange(n) / self._n_intervals_per_cycle
        if s.w_angle_prior and walking:
            ref = np.concatenate([winter_angles(phase), winter_angles((phase + 0.5) % 1.0)], axis=1)  # JOINTS order
            total += s.w_angle_prior * sum(angle_prior(x.q[k][3:], ca.DM(ref[k]), s.angle_prior_sd_deg) for k in range(n)) / n
        if s.w_grf_prior and walking:
            fy = np.stack([winter_grf(phase), winter_grf((phase + 0.5) % 1.0)], axis=1)
            dev = [(x.grf[k][[1, 3]] / self.bw - ca.DM(fy[k])) / s.grf_prior_sd_bw for k in range(n)]
            total += s.w_grf_prior * sum(ca.sumsqr(d) for d in dev) / (2 * n)
        return total

    def _objective(self, x: NodeExpressions) -> Any:
        """The NLP objective (dimensionless): effort + w_acc · regularisation + the human priors
        (module docstring). Subclasses override this to add terms (e.g. tracking errors)."""
        effort, reg = self._effort_terms(x)
        return effort + self.settings.w_acc * reg + self._prior_terms(x)

    def prepare(self, ipopt_options: Mapping[str, Any] | None = None, verbose: bool = False) -> None:
        """Build the IPOPT solver of these options now rather than on the first :meth:`solve`
        with them (e.g. while another process works on the initial guess)."""
        self._get_solver(ipopt_options, verbose)

    def _get_solver(self, ipopt_options: Mapping[str, Any] | None, verbose: bool) -> ca.Function:
        """The IPOPT solver of this NLP with these options, built on first use and kept: building
        it (CasADi's derivatives of the whole NLP) costs about as much as an IPOPT run, and only
        the initial guess and the bounds change between the solves of one problem."""
        opts = self.settings.ipopt_options(ipopt_options, verbose)
        key = repr(sorted(opts.items()))
        if key not in self._solvers:
            plugin_opts = {"ipopt": opts, "print_time": False, "error_on_fail": False}
            self._solvers[key] = ca.nlpsol("predictive_gait", "ipopt", self._nlp, plugin_opts)
        return self._solvers[key]

    # ----------------------------------------------------------------- guesses
    def generic_guess(self, amplitude: float = 1.0) -> np.ndarray:
        """A data-free initial guess (scaled decision vector): the textbook shapes of
        :func:`generic_gait` (joint excursions scaled by ``amplitude``), zero torques; u and q̈
        are backward differences of q."""
        s = self.settings
        T = s.stride_duration
        n_cycle = self._n_intervals_per_cycle
        t = np.arange(n_cycle) * T / n_cycle
        q = generic_gait(s.speed, T, t, self.body, amplitude)
        return self._pack_guess(t, q, T, n_cycle)

    def guess_from_solution(self, sol: GaitSolution, speed: float | None = None) -> np.ndarray:
        """Initial guess (scaled decision vector) from a previous solution, resampled to this
        grid by periodic linear interpolation over the normalised cycle; pelvis_tx is rescaled
        to ``speed`` (m/s; default this problem's speed) and the duration kept (clipped to the
        bounds)."""
        s = self.settings
        v = s.speed if speed is None else float(speed)
        T = float(np.clip(sol.duration, *s.duration_bounds)) if s.free_duration else s.stride_duration
        n_cycle = self._n_intervals_per_cycle
        t = np.arange(n_cycle) * T / n_cycle
        frac_src = sol.time / sol.duration
        q = np.empty((n_cycle, N_Q))
        for i in range(N_Q):
            y = sol.q[:, i] - (sol.speed * sol.time if i == 0 else 0.0)
            q[:, i] = np.interp(t / T, frac_src, y, period=1.0)
        q[:, 0] += v * t
        tau = np.empty((n_cycle, N_TAU))
        for j in range(N_TAU):
            tau[:, j] = np.interp(t / T, frac_src, sol.tau[:, j], period=1.0)
        return self._pack_guess(t, q, T, n_cycle, tau, speed=v)

    def cycle_differences(
        self, q: np.ndarray, T: float, n_cycle: int, speed: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """u and q̈ of a periodic cycle of ``n_cycle`` samples of q over duration T (s): the backward
        differences the collocation uses, wrapping around one stride (pelvis_tx moved back by v·T,
        v = ``speed``, default this problem's speed)."""
        h = T / n_cycle
        q_prev = np.roll(q, 1, axis=0)
        q_prev[0, 0] -= (self.settings.speed if speed is None else speed) * T
        u = (q - q_prev) / h
        return u, (u - np.roll(u, 1, axis=0)) / h

    def _pack_guess(
        self, t: np.ndarray, q: np.ndarray, T: float, n_cycle: int, tau: np.ndarray | None = None, speed: float | None = None
    ) -> np.ndarray:
        s, lay = self.settings, self.layout
        v = s.speed if speed is None else speed
        u, a = self.cycle_differences(q, T, n_cycle, v)
        tau = np.zeros((n_cycle, N_TAU)) if tau is None else tau
        n = lay.n
        nodes = np.concatenate(
            [q[:n] / self.q_scale, u[:n] / self.u_scale, a[:n] / self.a_scale, tau[:n] / self.tau_max], axis=1
        )
        z0 = np.concatenate([nodes.ravel(), [T, v]])
        return np.clip(z0, self._bounds["lbx"], self._bounds["ubx"])

    # ----------------------------------------------------------------- solving
    def solve(
        self,
        guess: GaitSolution | np.ndarray | None = None,
        *,
        ipopt_options: Mapping[str, Any] | None = None,
        verbose: bool = False,
        raise_on_failure: bool = True,
        fixed_speed: float | None = None,
    ) -> GaitSolution:
        """Run IPOPT from ``guess`` (None: :meth:`generic_guess`; a :class:`GaitSolution`; or a
        scaled decision vector) and return the solution.

        ``fixed_speed`` (m/s) fixes the average speed for this solve only, e.g. the first step of
        a continuation of a ``free_speed`` problem (solve at a fixed speed, then free it), or one
        speed of several solved on one problem (a :class:`GaitSolution` guess is then resampled
        at that speed). The IPOPT solver is built on the first solve with these options and
        kept for the next.

        Raises:
            OCPError: if IPOPT's status is not ``Solve_Succeeded`` and ``raise_on_failure``.
        """
        if guess is None:
            z0 = self.generic_guess()
        elif isinstance(guess, GaitSolution):
            z0 = self.guess_from_solution(guess, speed=fixed_speed)
        else:
            z0 = np.asarray(guess, dtype=float)
            if z0.shape != (self.layout.size,):
                raise ValueError(f"guess vector must have shape ({self.layout.size},), got {z0.shape}")
        bounds = self._bounds
        if fixed_speed is not None:
            bounds = {k: v.copy() for k, v in bounds.items()}
            bounds["lbx"][-1] = bounds["ubx"][-1] = fixed_speed
            z0 = z0.copy()
            z0[-1] = fixed_speed
        t0 = time.perf_counter()
        solver = self._get_solver(ipopt_options, verbose)
        build_time = time.perf_counter() - t0
        t0 = time.perf_counter()
        result = solver(x0=perturbation.perturb_guess(z0, bounds["lbx"], bounds["ubx"]), **bounds)
        solve_time = time.perf_counter() - t0
        stats = solver.stats()
        status = str(stats.get("return_status", "unknown"))
        sol = self._unpack(
            np.asarray(result["x"]).ravel(),
            status=status,
            iterations=int(stats.get("iter_count", -1)),
            solve_time=solve_time,
            build_time=build_time,
            objective=float(result["f"]),
        )
        if status not in SUCCESS_STATUSES and raise_on_failure:
            raise OCPError(
                status,
                f"IPOPT did not solve the predictive gait problem (speed {self.settings.speed} m/s, "
                f"{self.settings.n_nodes} nodes, {self.settings.gait_cycle} cycle): status {status!r} after "
                f"{sol.iterations} iterations",
                sol,
            )
        return sol

    def solve_start(
        self, start: Start, *, ipopt_options: Mapping[str, Any] | None = None, verbose: bool = False
    ) -> GaitSolution:
        """One start of :meth:`solve_multistart`: IPOPT from the data-free guess of ``start``
        (the caller's ``ipopt_options`` override the start's); never raises on failure."""
        return self.solve(
            self.generic_guess(start.amplitude),
            ipopt_options={**(start.ipopt_options or {}), **(ipopt_options or {})},
            verbose=verbose,
            raise_on_failure=False,
        )

    def solve_multistart(
        self,
        starts: Sequence[Start] = DEFAULT_STARTS,
        *,
        ipopt_options: Mapping[str, Any] | None = None,
        verbose: bool = False,
        raise_on_failure: bool = True,
        agree_rtol: float | None = None,
        solved: Mapping[int, GaitSolution] | None = None,
    ) -> GaitSolution:
        """Solve from the data-free guess once per start and return the successful solution
        with the lowest objective (the others listed in its ``starts``).

        With ``agree_rtol``, the starts stop as soon as two successful ones reach the same
        objective within this relative tolerance (two IPOPT paths to one optimum); the starts
        left out are listed with status "skipped". ``solved``: the solutions of starts (by index
        in ``starts``) already solved with :meth:`solve_start` elsewhere, e.g. in another
        process; they are taken instead of solved again.

        Raises:
            OCPError: no start succeeded (and ``raise_on_failure``); its solution is the best
                last iterate.
        """
        if not starts:
            raise ValueError("a multi-start needs at least one Start")
        solutions: list[GaitSolution] = []
        for k, start in enumerate(starts):
            new = (solved or {}).get(k)
            if new is None:
                new = self.solve_start(start, ipopt_options=ipopt_options, verbose=verbose)
            solutions.append(new)
            # earlier starts never agreed (the loop would have stopped), so a pair found holds the new one
            if agree_rtol is not None and objectives_agree([s.objective for s in solutions if s.success], agree_rtol):
                break
        best = min(range(len(solutions)), key=lambda i: solutions[i].start_rank)
        sol = solutions[best]
        sol.starts = [
            {**start.describe(), "status": s.status, "objective": s.objective, "iterations": s.iterations, "chosen": i == best}
            for i, (start, s) in enumerate(zip(starts, solutions))
        ] + [{**start.describe(), "status": "skipped", "chosen": False} for start in starts[len(solutions) :]]
        if not sol.success and raise_on_failure:
            raise OCPError(
                sol.status,
                f"IPOPT did not solve the predictive gait problem (speed {self.settings.speed} m/s, "
                f"{self.settings.n_nodes} nodes, {self.settings.gait_cycle} cycle) from any of {len(starts)} "
                f"starts: best status {sol.status!r}",
                sol,
            )
        return sol

    def _unpack(self, z: np.ndarray, **info: Any) -> GaitSolution:
        s, lay = self.settings, self.layout
        nodes, T = lay.split(z)
        v = float(lay.speed(z))
        sl = lay.slices
        q = (nodes[sl["q"]].T * self.q_scale).copy()
        u = nodes[sl["u"]].T * self.u_scale
        a = nodes[sl["a"]].T * self.a_scale
        tau = nodes[sl["tau"]].T * self.tau_max
        grf, w = (np.asarray(x) for x in dyn.contact_forces(q, u, self.body, self.contact))
        if s.gait_cycle == "half":
            q2 = mirror_states(q.T).T
            q2[:, 0] += v * T / 2
            q = np.vstack([q, q2])
            u, a, tau = (np.vstack([x, mirror_states(x.T).T]) for x in (u, a, tau))
            # the second half is the first with the feet swapped (the forces too: recomputed on the
            # mirrored states, a body with unequal legs would sink one foot into the floor)
            grf, w = np.vstack([grf, grf[:, [2, 3, 0, 1]]]), np.vstack([w, w[:, ::-1]])
        n_cycle = q.shape[0]
        return GaitSolution(
            time=np.arange(n_cycle) * T / n_cycle,
            q=q,
            u=u,
            qdd=a,
            tau=tau,
            grf=grf,
            w=w,
            speed=v,
            duration=float(T),
            body_parameters=self.body.to_dict(),
            settings=s.to_dict(),
            contact=asdict(self.contact),
            tau_max=self.tau_max.copy(),
            **info,
        )


def solve_predictive(
    speed: float,
    body: BodyParameters | None = None,
    *,
    n_nodes: int | None = None,
    effort: Effort = "cubed",
    gait_cycle: GaitCycle = "half",
    guess: GaitSolution | None = None,
    duration: float | None = None,
    free_duration: bool = False,
    contact: ContactParameters | None = None,
    joint_limits: JointLimits | None = None,
    ipopt_options: Mapping[str, Any] | None = None,
    verbose: bool = False,
    raise_on_failure: bool = True,
    rate_hz: float | None = None,
    starts: Sequence[Start] = DEFAULT_STARTS,
    **settings: Any,
) -> GaitSolution:
    """Predict a periodic gait cycle at average ``speed`` (m/s) by minimising joint-torque effort.

    See the module docstring for the formulation. Example::

        sol = solve_predictive(1.3)                 # walking, symmetric half cycle, 50 nodes
        run = solve_predictive(3.5, n_nodes=50)     # running (flight phase emerges)
        sol.save("results/ocp/walk_1.3")

    Args:
        speed: average forward speed, m/s (≥ 0; 0 gives quiet standing).
        body: body parameters (default: 1.75 m, 70 kg, Winter scaling).
        n_nodes: collocation nodes per simulated interval (default 50 for a half cycle, i.e. 100
            per stride, and 100 for a full cycle).
        effort: "squared" or "cubed" normalised-torque effort.
        gait_cycle: "half" (half a cycle with left/right symmetry) or "full" (one periodic cycle).
        guess: a previous :class:`GaitSolution` as initial guess (resampled to this grid);
            default: a multi-start from the data-free :meth:`PredictiveGaitProblem.generic_guess`
            (``starts``).
        duration: stride duration, s (default :func:`typical_stride_duration` of the speed);
            fixed unless ``free_duration``.
        free_duration: optimise the stride duration within ``duration_bounds`` (a setting).
        contact: contact-model parameters (default :class:`ContactParameters`).
        joint_limits: joint ranges, rad (default :func:`default_joint_limits`).
        ipopt_options: extra IPOPT options (override the defaults).
        verbose: print IPOPT's iteration log.
        raise_on_failure: raise :class:`OCPError` (naming IPOPT's status) unless the status is
            ``Solve_Succeeded``; if False, return the last iterate with its status.
        rate_hz: put the nodes on a sampling grid of this rate (e.g. 100 Hz: node spacing 10 ms,
            ``n_nodes`` from the stride duration; the duration must then be fixed). The solution
            then needs no resampling to that rate: its samples satisfy the dynamics exactly.
        starts: the multi-start used without a ``guess`` (default :data:`DEFAULT_STARTS`; one
            :class:`Start` for a single IPOPT run): the successful start with the lowest
            objective wins, and every start is listed in the solution's ``starts``.
        **settings: further :class:`OCPSettings` fields (e.g. ``duration_bounds``, ``w_acc``,
            ``tau_max``, ``max_iter``).

    Returns:
        The solution over one whole cycle (the mirrored second half appended for
        ``gait_cycle="half"``).

    Raises:
        OCPError: IPOPT did not return ``Solve_Succeeded`` (from any start; and ``raise_on_failure``).
    """
    speed = check_speed(speed)  # predictive.ocp.limits: reject what the model cannot do, before building
    if rate_hz is not None:
        if free_duration:
            raise ValueError("rate_hz needs a fixed stride duration (free_duration=False)")
        if n_nodes is not None:
            raise ValueError("give n_nodes or rate_hz, not both")
        T = duration if duration is not None else typical_stride_duration(speed)
        n_nodes = max(4, int(round(T * rate_hz / (1 if gait_cycle == "full" else 2))))
        check_nodes(n_nodes, f"rate_hz {rate_hz:g} Hz over a {T:.3g} s stride ({gait_cycle} cycle)")
        duration = n_nodes * (1 if gait_cycle == "full" else 2) / rate_hz
    if n_nodes is None:
        n_nodes = 100 if gait_cycle == "full" else 50
    cfg = OCPSettings(
        speed=float(speed),
        n_nodes=n_nodes,
        effort=effort,
        gait_cycle=gait_cycle,
        duration=duration,
        free_duration=free_duration,
        **settings,
    )
    problem = PredictiveGaitProblem(cfg, body, contact, joint_limits)
    if guess is None:
        return problem.solve_multistart(
            starts, ipopt_options=ipopt_options, verbose=verbose, raise_on_failure=raise_on_failure
        )
    return problem.solve(guess, ipopt_options=ipopt_options, verbose=verbose, raise_on_failure=raise_on_failure)
