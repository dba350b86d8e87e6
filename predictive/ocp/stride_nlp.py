"""The single-stride NLP of the synthetic-data stride chain (backward Euler on the 100 Hz grid).

The periodic solutions of :mod:`predictive.ocp.collocation` repeat one gait cycle forever;
synthetic recordings are chains of single strides instead (:mod:`predictive.synth.chain`), each
an NLP of this module. Its model, bounds, effort and IPOPT settings are those of the periodic
problem (:class:`~predictive.ocp.settings.ProblemSettings`, the base of :class:`StrideSettings`):

* **Grid.** Backward Euler with a fixed step ``h`` (default 0.01 s, so the nodes are the 100 Hz
  samples of a recording). Stride ``k`` has ``N_k = round(T_k/h)`` nodes (:class:`StridePlan`).
* **Chaining.** The state "before" the first node of stride ``k`` is the *fixed* last node of
  stride ``k − 1`` (an NLP parameter), so ``q_0 − q_prev = h·u_0`` and ``u_0 − u_prev = h·q̈_0``
  hold across stride boundaries exactly as inside a stride: a recording is one backward-Euler
  trajectory whose Kane residual ``M(q)·q̈ − f(q, u, τ, F(q, u), w(q))`` is zero to IPOPT's
  constraint tolerance at every sample, with q̈ the backward difference of u and F, w the
  contact model's forces and contact points (forward-simulation friction law, as in
  :mod:`predictive.ocp.collocation`).
* **Variables per node** as in :mod:`predictive.ocp.collocation`: q, u, q̈, τ (scaled); pelvis_tx is
  taken relative to the previous state's, so the NLP is translation invariant and well scaled
  however far the subject has walked.
* **Constraints.** Backward-Euler kinematics and the Kane residual (scaled by BW and BW·H) at every
  node, and each stride's average speed: ``pelvis_tx(last node) − pelvis_tx(prev) = v_k·T_k``
  (exact). Bounds as in the periodic problem (joint ranges, pelvis height and tilt, |τ| ≤ 3·τmax).
* **Objective.** The periodic problem's dimensionless effort with per-joint weights ``c_j``,
  ``mean_k Σ_j c_j·|τ_kj/τmax_j · s_j(θ)|^e + w_acc·mean_k Σ_i (q̈_ki·T²/(4π²))²`` per stride
  (e = 3 for the default ``effort="cubed"``), summed over the horizon, with the periodic problem's
  human priors (:mod:`predictive.ocp.settings`): the GRF cap at the stride's planned speed, and
  — instead of Winter's angles, whose phase a stride of a chain does not know — the angle prior
  towards the stride's guess (the subject's periodic gait at that speed and phase, blended from
  the previous state; the posture at rest for strides from and to rest: ``prior_q`` of
  :meth:`StrideProblem.solve`) and the vertical-GRF prior towards that gait's forces
  (``prior_grf``), plus a terminal tracking term
  ``w_terminal · (Σ_{i≥1} ((q_i − q_ref,i)/σ_q)² + Σ_i ((u_i − u_ref,i)/σ_u,i)²) / 18`` at the
  horizon's last node toward the periodic gait at that stride's speed and phase. Without it the
  end state is free and a chain of greedy strides drifts (a single stride's effort is lowest
  when the body is let down at its end). With ``w_slip`` > 0 the effort of every node also has
  ``w_slip · Σ_feet (F_x · ẋ_c / BW)²``, the squared power of the friction force on the contact
  point's sliding (BW·m/s): the smooth contact model (a softplus penetration 3.3 mm wide, friction
  −0.8·tanh(ẋ/0.05 m/s)·F_y) lets a swinging foot carry a few per cent of body weight a few
  millimetres above the floor and skid, a free brake the optimiser otherwise uses (synthetic
  walking: loads ≥ 0.5 %BW on contact points sliding faster than 0.5 m/s in 26–47 % of the
  samples; ``w_slip = 100``: 5–8 %, at the same IPOPT iterations per stride).
* **Horizon.** One NLP holds ``1 + lookahead`` strides, one bucket each (see
  :func:`~predictive.synth.chain.simulate_chain` for how horizons are chained).
* **Node-count buckets.** One compiled NLP serves every stride of up to ``bucket`` nodes: nodes
  beyond ``N_k`` are inactive copies of the stride's last node (their constraints switch, by a
  0/1 parameter, to ``q = q_prev, u = u_prev, q̈ = 0``), so a handful of solvers
  (:data:`DEFAULT_BUCKETS`, about 16 % apart) cover all stride durations. The body parameters are
  NLP parameters too, so the solvers are shared by all subjects (:class:`StrideSolverCache`).
* **IPOPT warm start.** The initial guess (the previous horizon's lookahead stride, or the
  periodic reference resampled to the stride and blended into the previous state) is close to a
  solution and often has joints on their bounds (a straight knee): IPOPT's default bound push
  (1e-2) and initial barrier (0.1) move it far from the guess and cost hundreds of iterations,
  so the first attempt uses ``bound_push = bound_frac = 1e-8`` and a monotone barrier from
  1e-4 (:data:`WARM_START_IPOPT`; an unperturbed walking stride: ~20 instead of ~140
  iterations); a failed stride is retried with IPOPT's defaults and the reference guess. Strides
  whose speed or duration differ from the reference need a new contact timing and take more
  (about 90 iterations, 3 s per stride on a shared 2-core CPU, for the default 2 %
  variability). Giving the GRF their own variables (lifted contact) and sampling the guess at
  the reference's own pace instead of stretching it were tried and did not reduce the iterations.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Final

import casadi as ca
import numpy as np

from predictive.ocp import perturbation
from predictive.ocp import settings as ocp
from predictive.ocp.collocation import OCPSettings
from sspinn.model import dynamics as dyn
from sspinn.model.body import N_PARAMETERS, BodyParameters, JointLimits
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import N_Q, N_TAU
from sspinn.model.trajectory import Trajectory

#: Maximal nodes per stride of the compiled NLPs (h = 0.01 s: 0.24 … 1.6 s strides).
DEFAULT_BUCKETS: Final[tuple[int, ...]] = (24, 28, 32, 37, 43, 50, 58, 67, 78, 90, 104, 120, 139, 160)

#: IPOPT options of the first attempt (near-optimal guess, see the module docstring).
WARM_START_IPOPT: Final[dict[str, Any]] = {
    "mu_strategy": "monotone",
    "mu_init": 1e-4,
    "bound_push": 1e-8,
    "bound_frac": 1e-8,
}

_PER_NODE: Final = 3 * N_Q + N_TAU  # q_rel, u, q̈, τ (scaled)
_NODE_PAR: Final = 6 + 2 * N_TAU  # active, 1/N, T, effort weights, GRF cap (BW), prior joint angles (rad), prior F_y (BW)


def bucket_for(n_nodes: int, buckets: Sequence[int] = DEFAULT_BUCKETS) -> int:
    """The smallest bucket holding ``n_nodes`` nodes."""
    for b in sorted(buckets):
        if n_nodes <= b:
            return int(b)
    raise ValueError(f"a stride of {n_nodes} nodes exceeds the largest bucket {max(buckets)}")


@dataclass(frozen=True, kw_only=True)
class StrideSettings(ocp.ProblemSettings):
    """Settings of the stride OCPs (shared by every stride of a dataset; keyword-only): the
    stride problem's own fields below plus the model, bounds, effort and IPOPT fields of
    :class:`~predictive.ocp.settings.ProblemSettings` (``tau_max``, ``tau_bound``, ``w_acc``,
    ``ankle_strength_slope``, ``pelvis_height_bounds``, ``tilt_bounds``, ``tol``), with tighter
    IPOPT defaults for the strides.

    Attributes:
        h: time step, s (backward Euler; the sample interval of the recordings).
        w_terminal: weight of the terminal tracking term (dimensionless, see the module docstring).
        sigma_q: terminal tolerance of q (except pelvis_tx), m or rad.
        sigma_u_joint: terminal tolerance of the angular speeds, rad/s.
        sigma_u_ty: terminal tolerance of the vertical pelvis speed, m/s.
        sigma_u_tx: terminal tolerance of the forward pelvis speed, fraction of max(v, 1 m/s).
        constr_tol: IPOPT constr_viol_tol, here 1e-9 (the labels must satisfy the dynamics).
        max_iter: IPOPT iteration limit per attempt, here 1000 (a failed stride has fallbacks).
        residual_tol: largest accepted Kane residual at a node, BW / BW·H (checked with NumPy).
        buckets: node-count buckets of the compiled NLPs.
    """

    h: float = 0.01
    w_terminal: float = 2.0
    sigma_q: float = 0.05
    sigma_u_joint: float = 0.5
    sigma_u_ty: float = 0.2
    sigma_u_tx: float = 0.1
    constr_tol: float = 1e-9
    max_iter: int = 1000
    residual_tol: float = 1e-7
    buckets: tuple[int, ...] = DEFAULT_BUCKETS

    def __post_init__(self) -> None:
        if not self.h > 0:
            raise ValueError(f"h must be > 0 s, got {self.h}")
        super().__post_init__()
        if self.w_terminal < 0:
            raise ValueError(f"w_terminal must be >= 0, got {self.w_terminal}")
        if not self.buckets or min(self.buckets) < 2:
            raise ValueError(f"buckets must be node counts >= 2, got {self.buckets}")

    def ocp_settings(self, speed: float, n_nodes: int, duration: float) -> OCPSettings:
        """The periodic (half-cycle) problem of the same model at ``speed`` (m/s): these
        :data:`~predictive.ocp.settings.ProblemSettings.MODEL_FIELDS`, the periodic problem's own
        IPOPT settings."""
        return OCPSettings(speed=speed, n_nodes=n_nodes, duration=duration, **self.model_settings())


@dataclass(frozen=True)
class StridePlan:
    """What one stride of a chain should do.

    Attributes:
        speed: average forward speed over the stride, m/s (pelvis_tx advances speed·n_nodes·h).
        n_nodes: nodes (samples) of the stride; its duration is n_nodes·h.
        effort_weights: per-joint weights c_j of the effort (JOINTS order, dimensionless).
    """

    speed: float
    n_nodes: int
    effort_weights: tuple[float, ...] = (1.0,) * N_TAU

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed >= 0):
            raise ValueError(f"stride speed must be finite and >= 0 m/s, got {self.speed}")
        if self.n_nodes < 2:
            raise ValueError(f"a stride needs >= 2 nodes, got {self.n_nodes}")
        if len(self.effort_weights) != N_TAU or min(self.effort_weights) <= 0:
            raise ValueError(f"effort_weights must be {N_TAU} positive numbers, got {self.effort_weights}")


# ---------------------------------------------------------------------------------------------
# The NLP of one horizon
# ---------------------------------------------------------------------------------------------
@dataclass
class _ParamLayout:
    """Layout of the NLP parameter vector for a horizon of ``n_nodes`` nodes in ``n_strides``."""

    n_strides: int
    n_nodes: int
    slices: dict[str, slice] = field(default_factory=dict)

    def __post_init__(self) -> None:
        sizes = {
            "body": N_PARAMETERS,
            "res_scale": N_Q,
            "tau_max": N_TAU,
            "u_scale": N_Q,
            "q_prev": N_Q,
            "u_prev": N_Q,
            "q_ref": N_Q,
            "u_ref": N_Q,
            "sigma_u": N_Q,
            "dx": self.n_strides,
            "node": _NODE_PAR * self.n_nodes,
        }
        start = 0
        for name, n in sizes.items():
            self.slices[name] = slice(start, start + n)
            start += n
        self.size = start

    def pack(self, values: Mapping[str, np.ndarray]) -> np.ndarray:
        out = np.empty(self.size)
        for name, sl in self.slices.items():
            v = np.asarray(values[name], dtype=float).ravel(order="F")
            if v.size != sl.stop - sl.start:
                raise ValueError(f"parameter {name!r}: expected {sl.stop - sl.start} values, got {v.size}")
            out[sl] = v
        return out


@dataclass
class StrideResult:
    """The active nodes of a solved horizon (physical units, absolute pelvis_tx).

    Attributes:
        q, u, qdd, tau: (N, 9), (N, 9), (N, 9), (N, 6) at the nodes (m, rad; /s; /s²; N·m), the
            strides of the horizon one after the other; q̈ is the backward difference of u.
        node_counts: nodes per stride of the horizon.
        status: IPOPT return status.
        iterations: IPOPT iterations.
        solve_time: wall-clock time of the IPOPT call, s.
        objective: final objective (dimensionless).
        max_residual: max |Kane residual| at the nodes, BW (translations) / BW·H (rotations),
            NumPy backend, contact forces recomputed.
        max_kinematic: max |(q_k − q_{k−1})/h − u_k| (m/s, rad/s).
    """

    q: np.ndarray
    u: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    node_counts: tuple[int, ...]
    status: str
    iterations: int
    solve_time: float
    objective: float
    max_residual: float = float("nan")
    max_kinematic: float = float("nan")

    def stride(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(q, u, q̈, τ) of the horizon's stride ``i``."""
        start = sum(self.node_counts[:i])
        sl = slice(start, start + self.node_counts[i])
        return self.q[sl], self.u[sl], self.qdd[sl], self.tau[sl]


class StrideProblem:
    """The NLP of a horizon of strides with at most ``buckets[i]`` nodes each.

    The body, the previous state, the references and every stride's plan are NLP parameters, so
    one instance solves any horizon that fits its buckets.
    """

    def __init__(
        self,
        buckets: Sequence[int],
        settings: StrideSettings,
        contact: ContactParameters | None = None,
        joint_limits: JointLimits | None = None,
        ipopt_options: Mapping[str, Any] | None = None,
    ) -> None:
        if not buckets or min(buckets) < 2:
            raise ValueError(f"buckets must be a non-empty sequence of ints >= 2, got {buckets}")
        self.buckets = tuple(int(n) for n in buckets)
        self.n = sum(self.buckets)
        self.settings = settings
        self.contact = contact if contact is not None else ContactParameters()
        self.joint_limits = joint_limits if joint_limits is not None else ocp.default_joint_limits()
        self.ipopt_options = dict(ipopt_options or {})
        self.params = _ParamLayout(len(self.buckets), self.n)
        self.a_scale = np.full(N_Q, ocp.ACC_SCALE)
        t0 = time.perf_counter()
        self._solver = self._build()
        self.build_time = time.perf_counter() - t0

    # ------------------------------------------------------------------ building
    def _node_function(self) -> ca.Function:
        """One node's constraints (27) and cost (1) as an SX function, mapped over the nodes.

        Inputs: the node's scaled variables (33); the previous node's scaled (q_rel, u) (18);
        body (41), residual scale (9), τmax (6), u scale (9), previous pelvis_tx (1); the node
        parameters (active, 1/N, T, effort weights (6), GRF cap (BW), prior joint angles (6),
        prior vertical GRF (2, BW)).
        """
        s = self.settings
        z, zp = ca.SX.sym("z", _PER_NODE), ca.SX.sym("zp", 2 * N_Q)
        body = ca.SX.sym("body", N_PARAMETERS)
        res_scale, tau_max, us = ca.SX.sym("res_scale", N_Q), ca.SX.sym("tau_max", N_TAU), ca.SX.sym("us", N_Q)
        x0 = ca.SX.sym("x0")
        npar = ca.SX.sym("node", _NODE_PAR)
        active, inv_n, T, c = npar[0], npar[1], npar[2], npar[3 : 3 + N_TAU]
        cap, joints_prior, fy_prior = npar[3 + N_TAU], npar[4 + N_TAU : 4 + 2 * N_TAU], npar[4 + 2 * N_TAU :]
        as_ = ca.DM(self.a_scale)
        q_rel, u, a = z[0:N_Q], z[N_Q : 2 * N_Q] * us, z[2 * N_Q : 3 * N_Q] * as_
        tn = z[3 * N_Q :]
        q = ca.vertcat(q_rel[0] + x0, q_rel[1:])
        q_prev_rel, u_prev = zp[0:N_Q], zp[N_Q:] * us
        grf, w = dyn.contact_forces(q, u, body, self.contact)
        res = dyn.kane_residual(q, u, a, tn * tau_max, grf, w, body) / res_scale
        g_active = ca.vertcat(((q_rel - q_prev_rel) / s.h - u) / us, ((u - u_prev) / s.h - a) / as_, res)
        g_copy = ca.vertcat((q_rel - q_prev_rel) / (s.h * us), (u - u_prev) / (s.h * as_), z[2 * N_Q : 3 * N_Q])
        te = ocp.strength_scaled(tn, q, s.ankle_strength_slope)
        effort = ca.dot(c, ocp.effort_power(te, s.effort)) + s.w_acc * ocp.acceleration_regularisation(a, T)
        if s.w_grf_cap:
            effort = effort + s.w_grf_cap * ocp.grf_cap_penalty(ca.vertcat(grf[1], grf[3]) / res_scale[0], cap)
        if s.w_angle_prior:
            effort = effort + s.w_angle_prior * ocp.angle_prior(q[3:], joints_prior, s.angle_prior_sd_deg)
        if s.w_grf_prior:
            dev = (ca.vertcat(grf[1], grf[3]) / res_scale[0] - fy_prior) / s.grf_prior_sd_bw
            effort = effort + s.w_grf_prior * ca.sumsqr(dev) / 2
        if s.w_slip:  # the power of the friction forces on sliding contact points, in BW·m/s
            effort = effort + s.w_slip * ca.sumsqr(ocp.sliding_power(q, u, a, grf, w, body) / res_scale[0])
        g = active * g_active + (1 - active) * g_copy
        cost = active * effort * inv_n + (1 - active) * 1e-3 * ca.sumsqr(tn)
        return ca.Function("stride_node", [z, zp, body, res_scale, tau_max, us, x0, npar], [g, cost])

    def _build(self) -> ca.Function:
        s, lay, n = self.settings, self.params, self.n
        P = ca.MX.sym("P", lay.size)
        par = {name: P[sl] for name, sl in lay.slices.items()}
        z = ca.MX.sym("z", n * _PER_NODE)
        Z = ca.reshape(z, _PER_NODE, n)
        us = par["u_scale"]
        zp0 = ca.vertcat(0, par["q_prev"][1:], par["u_prev"] / us)
        Zp = ca.horzcat(zp0, Z[0 : 2 * N_Q, 0 : n - 1]) if n > 1 else zp0
        node_par = ca.reshape(par["node"], _NODE_PAR, n)
        mapped = self._node_function().map(n, "serial")
        G, cost = mapped(Z, Zp, par["body"], par["res_scale"], par["tau_max"], us, par["q_prev"][0], node_par)
        g: list[Any] = [ca.vec(G)]
        # each stride's average speed: pelvis_tx (relative to q_prev's) advances exactly v·T
        ends = np.cumsum(self.buckets) - 1
        for i, end in enumerate(ends):
            x_start = 0 if i == 0 else Z[0, int(ends[i - 1])]
            g.append(Z[0, int(end)] - x_start - par["dx"][i])
        objective = ca.sum2(cost)
        q_end, u_end = Z[0:N_Q, n - 1], Z[N_Q : 2 * N_Q, n - 1] * us
        dq = (q_end[1:] - par["q_ref"][1:]) / s.sigma_q
        du = (u_end - par["u_ref"]) / par["sigma_u"]
        objective += s.w_terminal * (ca.sumsqr(dq) + ca.sumsqr(du)) / (2 * N_Q)
        nlp = {"x": z, "p": P, "f": objective, "g": ca.vertcat(*g)}
        self.n_constraints = int(nlp["g"].shape[0])
        plugin = {"ipopt": s.ipopt_options(self.ipopt_options), "print_time": False, "error_on_fail": False, "expand": True}
        return ca.nlpsol("stride_chain", "ipopt", nlp, plugin)

    # ------------------------------------------------------------------ solving
    def scales(self, body: BodyParameters, speed: float) -> dict[str, np.ndarray]:
        """Residual (N, N·m), torque (N·m) and speed (m/s, rad/s) scales of ``body`` at ``speed``
        (:func:`~predictive.ocp.settings.nlp_scales`)."""
        return ocp.nlp_scales(self.settings, body, speed)

    def solve(
        self,
        body: BodyParameters,
        q_prev: np.ndarray,
        u_prev: np.ndarray,
        plans: Sequence[StridePlan],
        q_ref: np.ndarray,
        u_ref: np.ndarray,
        guess_q: np.ndarray,
        guess_tau: np.ndarray,
        prior_q: np.ndarray | None = None,
        prior_grf: np.ndarray | None = None,
    ) -> StrideResult:
        """Solve the horizon ``plans`` (one per bucket) from the fixed previous state.

        Args:
            body: the (true) body parameters.
            q_prev, u_prev: (9,) state before the first node (m, rad; m/s, rad/s).
            plans: one :class:`StridePlan` per bucket, ``n_nodes <= bucket``.
            q_ref, u_ref: (9,) terminal reference (pelvis_tx of q_ref is ignored).
            guess_q: (Σ n_nodes, 9) initial guess of q (absolute pelvis_tx); u and q̈ of the
                guess are its backward differences from the previous state.
            guess_tau: (Σ n_nodes, 6) initial guess of τ, N·m.
            prior_q: (Σ n_nodes, 9) the angle prior's target (its joint angles, rad); default
                ``guess_q``.
            prior_grf: (Σ n_nodes, 4) the GRF prior's target (its vertical forces, N); needed
                when ``settings.w_grf_prior`` > 0.
        """
        s = self.settings
        if len(plans) != len(self.buckets):
            raise ValueError(f"need one plan per bucket ({len(self.buckets)}), got {len(plans)}")
        counts = tuple(p.n_nodes for p in plans)
        if any(c > b for c, b in zip(counts, self.buckets)):
            raise ValueError(f"strides of {counts} nodes do not fit the buckets {self.buckets}")
        n_active = sum(counts)
        prior_q = guess_q if prior_q is None else prior_q
        if prior_grf is None:
            if s.w_grf_prior:
                raise ValueError("w_grf_prior > 0 needs prior_grf, the GRF prior's target")
            prior_grf = np.zeros((n_active, 4))
        if prior_grf.shape != (n_active, 4):
            raise ValueError(f"prior_grf must be ({n_active}, 4), got {prior_grf.shape}")
        if guess_q.shape != (n_active, N_Q) or guess_tau.shape != (n_active, N_TAU) or prior_q.shape != guess_q.shape:
            raise ValueError(
                f"guess and prior must be ({n_active}, 9), ({n_active}, 6) and ({n_active}, 9), got {guess_q.shape}, "
                f"{guess_tau.shape}, {prior_q.shape}"
            )
        v_max = max(p.speed for p in plans)
        sc = self.scales(body, v_max)
        sigma_u = np.array([s.sigma_u_tx * max(v_max, 1.0), s.sigma_u_ty] + [s.sigma_u_joint] * (N_Q - 2))
        node = np.zeros((_NODE_PAR, self.n))
        active = np.zeros(self.n, dtype=bool)
        start = done = 0
        for plan, bucket in zip(plans, self.buckets):
            cols = slice(start, start + bucket)
            node[0, start : start + plan.n_nodes] = 1.0
            node[1, cols] = 1.0 / plan.n_nodes
            node[2, cols] = plan.n_nodes * s.h
            node[3 : 3 + N_TAU, cols] = np.asarray(plan.effort_weights)[:, None]
            node[3 + N_TAU, cols] = ocp.grf_cap_bw(plan.speed, s.grf_cap_fraction)
            node[4 + N_TAU : 4 + 2 * N_TAU, start : start + plan.n_nodes] = prior_q[done : done + plan.n_nodes, 3:].T
            node[4 + 2 * N_TAU :, start : start + plan.n_nodes] = prior_grf[done : done + plan.n_nodes][:, [1, 3]].T / body.body_weight
            active[start : start + plan.n_nodes] = True
            start += bucket
            done += plan.n_nodes
        params = self.params.pack(
            {
                "body": body.vector(),
                **sc,
                "q_prev": q_prev,
                "u_prev": u_prev,
                "q_ref": q_ref,
                "u_ref": u_ref,
                "sigma_u": sigma_u,
                "dx": [p.speed * p.n_nodes * s.h for p in plans],
                "node": node,
            }
        )
        z0 = self._pack_guess(q_prev, u_prev, guess_q, guess_tau, sc, active)
        lbx, ubx = self._bounds(body)
        t0 = time.perf_counter()
        x0 = perturbation.perturb_guess(np.clip(z0, lbx, ubx), lbx, ubx)
        out = self._solver(x0=x0, p=params, lbx=lbx, ubx=ubx, lbg=0.0, ubg=0.0)
        solve_time = time.perf_counter() - t0
        stats = self._solver.stats()
        nodes = np.asarray(out["x"]).reshape(self.n, _PER_NODE)[active]
        q = nodes[:, :N_Q].copy()
        q[:, 0] += q_prev[0]
        u = nodes[:, N_Q : 2 * N_Q] * sc["u_scale"]
        tau = nodes[:, 3 * N_Q :] * sc["tau_max"]
        qdd = np.diff(np.vstack([u_prev, u]), axis=0) / s.h
        result = StrideResult(
            q=q,
            u=u,
            qdd=qdd,
            tau=tau,
            node_counts=counts,
            status=str(stats.get("return_status", "unknown")),
            iterations=int(stats.get("iter_count", -1)),
            solve_time=solve_time,
            objective=float(out["f"]),
        )
        if np.all(np.isfinite(nodes)):
            result.max_residual = float(np.abs(stride_trajectory(q, u, qdd, tau, s.h, body, self.contact).kane_residual(body)).max())
            result.max_kinematic = float(np.abs(np.diff(np.vstack([q_prev, q]), axis=0) / s.h - u).max())
        return result

    def _bounds(self, body: BodyParameters) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.settings.node_bounds(self.joint_limits, body.height)
        return np.tile(lo, self.n), np.tile(hi, self.n)

    def _pack_guess(
        self,
        q_prev: np.ndarray,
        u_prev: np.ndarray,
        q: np.ndarray,
        tau: np.ndarray,
        sc: Mapping[str, np.ndarray],
        active: np.ndarray,
    ) -> np.ndarray:
        """Scaled decision vector: the guess at the active nodes, copies of the stride's last
        node (q̈ = τ = 0) at the inactive ones."""
        h = self.settings.h
        u = np.diff(np.vstack([q_prev, q]), axis=0) / h
        a = np.diff(np.vstack([u_prev, u]), axis=0) / h
        q_rel = q - np.array([q_prev[0]] + [0.0] * (N_Q - 1))
        act = np.concatenate([q_rel, u / sc["u_scale"], a / self.a_scale, tau / sc["tau_max"]], axis=1)
        nodes = np.zeros((self.n, _PER_NODE))
        nodes[active] = act
        idx = np.flatnonzero(active)
        for k in np.flatnonzero(~active):
            last = idx[idx < k][-1]
            nodes[k, : 2 * N_Q] = nodes[last, : 2 * N_Q]
        return nodes.ravel()


def stride_trajectory(
    q: np.ndarray,
    u: np.ndarray,
    qdd: np.ndarray,
    tau: np.ndarray,
    h: float,
    body: BodyParameters,
    contact: ContactParameters | None = None,
) -> Trajectory:
    """Samples of the backward-Euler grid (a stride, a horizon or a whole chain) as a
    :class:`~sspinn.model.trajectory.Trajectory` at times k·h (s), with the contact model's GRF and w
    (default contact parameters if None); its Kane residual is what the NLP constrains."""
    return Trajectory.from_contact_model(np.arange(len(q)) * h, q, u, qdd, tau, body, contact)


class StrideSolverCache:
    """Compiled :class:`StrideProblem` s by (buckets, attempt), built on first use.

    Compiling one costs a few seconds; each is reused for every subject, speed and plan whose
    strides fit its buckets. With ``reuse=False`` every :meth:`get` builds its problem anew (the
    same problem: the baseline of ``benchmarks/speed/bench_synth.py``). ``builds`` counts the problems
    built, ``build_time`` their seconds.
    """

    def __init__(self, settings: StrideSettings, contact: ContactParameters | None = None, reuse: bool = True) -> None:
        self.settings = settings
        self.contact = contact if contact is not None else ContactParameters()
        self.reuse = reuse
        self._problems: dict[tuple[tuple[int, ...], bool], StrideProblem] = {}
        self.build_time = 0.0
        self.builds = 0

    def get(self, node_counts: Sequence[int], warm: bool = True) -> StrideProblem:
        """The problem whose buckets hold strides of ``node_counts`` nodes; ``warm`` selects the
        warm-start IPOPT options (:data:`WARM_START_IPOPT`), else IPOPT's defaults."""
        buckets = tuple(bucket_for(int(n), self.settings.buckets) for n in node_counts)
        key = (buckets, warm)
        if key not in self._problems or not self.reuse:
            options = WARM_START_IPOPT if warm else None
            problem = StrideProblem(buckets, self.settings, self.contact, ipopt_options=options)
            self.build_time += problem.build_time
            self.builds += 1
            self._problems[key] = problem
        return self._problems[key]

    def __len__(self) -> int:
        return len(self._problems)
