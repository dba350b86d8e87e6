"""Dynamically exact, non-periodic gait: a chain of single-stride optimal control problems.

The periodic solutions of :mod:`predictive.ocp.collocation` repeat one gait cycle forever. Synthetic
recordings need stride-to-stride variability and speed changes while every sample still obeys
the equations of motion. :func:`simulate_chain` builds them stride by stride (receding horizon):

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
  ``mean_k Σ_j c_j·(τ_kj/τmax_j · s_j(θ))² + w_acc·mean_k Σ_i (q̈_ki·T²/(4π²))²`` per stride,
  summed over the horizon, plus a terminal tracking term
  ``w_terminal · (Σ_{i≥1} ((q_i − q_ref,i)/σ_q)² + Σ_i ((u_i − u_ref,i)/σ_u,i)²) / 18`` at the
  horizon's last node toward the periodic gait at that stride's speed and phase. Without it the
  end state is free and a chain of greedy strides drifts (a single stride's effort is lowest
  when the body is let down at its end).
* **Horizon.** ``1 + lookahead`` strides; only the first is kept, the next horizon starts from
  its last node, and a solved lookahead stride is the next horizon's initial guess.
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
  1e-4 (an unperturbed walking stride: ~20 instead of ~140 iterations); a failed stride is
  retried with IPOPT's defaults and the reference guess. Strides whose speed or duration differ
  from the reference need a new contact timing and take more (about 90 iterations, 3 s per
  stride on a shared 2-core CPU, for the default 2 % variability). Giving the GRF their own
  variables (lifted contact) and sampling the guess at the reference's own pace instead of
  stretching it were tried and did not reduce the iterations.
* **Stride boundary.** Phase 0 of the references (the stride boundary) lies 12 % of the cycle
  before the right foot's contact onset: mid-flight when running, left single support when
  walking. A boundary at an impact made the terminal velocity target very sensitive to timing
  (about 30 % more iterations when running).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Final

import casadi as ca
import numpy as np

from predictive.ocp import perturbation
from predictive.ocp.collocation import OCPSettings, _joint_type_values, default_joint_limits
from predictive.ocp.solution import GaitSolution
from sspinn import dynamics as dyn
from sspinn.body import N_PARAMETERS, BodyParameters, JointLimits
from sspinn.contact import ContactParameters
from sspinn.conventions import N_Q, N_TAU

#: IPOPT statuses accepted for a stride (the node residual is checked separately).
ACCEPTED_STATUSES: Final = ("Solve_Succeeded",)

#: Maximal nodes per stride of the compiled NLPs (h = 0.01 s: 0.24 … 1.6 s strides).
DEFAULT_BUCKETS: Final[tuple[int, ...]] = (24, 28, 32, 37, 43, 50, 58, 67, 78, 90, 104, 120, 139, 160)

#: IPOPT options of the first attempt (near-optimal guess, see the module docstring).
WARM_START_IPOPT: Final[dict[str, Any]] = {
    "mu_strategy": "monotone",
    "mu_init": 1e-4,
    "bound_push": 1e-8,
    "bound_frac": 1e-8,
}

#: Stride boundary relative to the right foot's contact onset, fraction of the cycle.
DEFAULT_BOUNDARY: Final = -0.12

_PER_NODE: Final = 3 * N_Q + N_TAU  # q_rel, u, q̈, τ (scaled)
_NODE_PAR: Final = 3 + N_TAU  # active, 1/N, T, effort weights


class ChainError(RuntimeError):
    """A stride of the chain could not be solved to the required accuracy."""


def bucket_for(n_nodes: int, buckets: Sequence[int] = DEFAULT_BUCKETS) -> int:
    """The smallest bucket holding ``n_nodes`` nodes."""
    for b in sorted(buckets):
        if n_nodes <= b:
            return int(b)
    raise ValueError(f"a stride of {n_nodes} nodes exceeds the largest bucket {max(buckets)}")


@dataclass(frozen=True)
class StrideSettings:
    """Settings of the stride OCPs (shared by every stride of a dataset).

    Attributes:
        h: time step, s (backward Euler; the sample interval of the recordings).
        w_acc: weight of the q̈ regularisation (as in :class:`~predictive.ocp.collocation.OCPSettings`).
        w_terminal: weight of the terminal tracking term (dimensionless, see the module docstring).
        sigma_q: terminal tolerance of q (except pelvis_tx), m or rad.
        sigma_u_joint: terminal tolerance of the angular speeds, rad/s.
        sigma_u_ty: terminal tolerance of the vertical pelvis speed, m/s.
        sigma_u_tx: terminal tolerance of the forward pelvis speed, fraction of max(v, 1 m/s).
        tau_max: normalising torque per joint type (hip, knee, ankle), BW·H.
        tau_bound: torque bound as a multiple of τmax.
        ankle_strength_slope: k of the ankle's angle-dependent strength exp(±k·θ), 1/rad.
        pelvis_height_bounds: pelvis_ty range, fractions of body height.
        tilt_bounds: pelvis_tilt range, rad.
        tol: IPOPT tolerance.
        constr_tol: IPOPT constr_viol_tol (scaled units: BW, BW·H, scaled rates).
        max_iter: IPOPT iteration limit per attempt.
        residual_tol: largest accepted Kane residual at a node, BW / BW·H (checked with NumPy).
        buckets: node-count buckets of the compiled NLPs.
    """

    h: float = 0.01
    w_acc: float = 0.1
    w_terminal: float = 2.0
    sigma_q: float = 0.05
    sigma_u_joint: float = 0.5
    sigma_u_ty: float = 0.2
    sigma_u_tx: float = 0.1
    tau_max: tuple[float, float, float] = (0.1, 0.1, 0.1)
    tau_bound: float = 3.0
    ankle_strength_slope: float = 1.0
    pelvis_height_bounds: tuple[float, float] = (0.3, 0.7)
    tilt_bounds: tuple[float, float] = (-0.6, 0.6)
    tol: float = 1e-6
    constr_tol: float = 1e-9
    max_iter: int = 1000
    residual_tol: float = 1e-7
    buckets: tuple[int, ...] = DEFAULT_BUCKETS

    def __post_init__(self) -> None:
        if not self.h > 0:
            raise ValueError(f"h must be > 0 s, got {self.h}")
        for name in ("w_acc", "w_terminal"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if not self.buckets or min(self.buckets) < 2:
            raise ValueError(f"buckets must be node counts >= 2, got {self.buckets}")

    def ocp_settings(self, speed: float, n_nodes: int, duration: float) -> OCPSettings:
        """The matching settings of the periodic (half-cycle) problem at ``speed`` (m/s)."""
        return OCPSettings(
            speed=speed,
            n_nodes=n_nodes,
            duration=duration,
            w_acc=self.w_acc,
            tau_max=self.tau_max,
            tau_bound=self.tau_bound,
            ankle_strength_slope=self.ankle_strength_slope,
            pelvis_height_bounds=self.pelvis_height_bounds,
            tilt_bounds=self.tilt_bounds,
        )

    def to_dict(self) -> dict[str, Any]:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> StrideSettings:
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})


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
        self.joint_limits = joint_limits if joint_limits is not None else default_joint_limits()
        self.ipopt_options = dict(ipopt_options or {})
        self.params = _ParamLayout(len(self.buckets), self.n)
        self.a_scale = np.full(N_Q, 10.0)
        t0 = time.perf_counter()
        self._solver = self._build()
        self.build_time = time.perf_counter() - t0

    # ------------------------------------------------------------------ building
    def _node_function(self) -> ca.Function:
        """One node's constraints (27) and cost (1) as an SX function, mapped over the nodes.

        Inputs: the node's scaled variables (33); the previous node's scaled (q_rel, u) (18);
        body (41), residual scale (9), τmax (6), u scale (9), previous pelvis_tx (1); the node
        parameters (active, 1/N, T, effort weights (6)).
        """
        s = self.settings
        z, zp = ca.SX.sym("z", _PER_NODE), ca.SX.sym("zp", 2 * N_Q)
        body = ca.SX.sym("body", N_PARAMETERS)
        res_scale, tau_max, us = ca.SX.sym("res_scale", N_Q), ca.SX.sym("tau_max", N_TAU), ca.SX.sym("us", N_Q)
        x0 = ca.SX.sym("x0")
        npar = ca.SX.sym("node", _NODE_PAR)
        active, inv_n, T, c = npar[0], npar[1], npar[2], npar[3:]
        as_ = ca.DM(self.a_scale)
        q_rel, u, a = z[0:N_Q], z[N_Q : 2 * N_Q] * us, z[2 * N_Q : 3 * N_Q] * as_
        tn = z[3 * N_Q :]
        q = ca.vertcat(q_rel[0] + x0, q_rel[1:])
        q_prev_rel, u_prev = zp[0:N_Q], zp[N_Q:] * us
        grf, w = dyn.contact_forces(q, u, body, self.contact)
        res = dyn.kane_residual(q, u, a, tn * tau_max, grf, w, body) / res_scale
        g_active = ca.vertcat(((q_rel - q_prev_rel) / s.h - u) / us, ((u - u_prev) / s.h - a) / as_, res)
        g_copy = ca.vertcat((q_rel - q_prev_rel) / (s.h * us), (u - u_prev) / (s.h * as_), z[2 * N_Q : 3 * N_Q])
        te = self._strength_scaled(tn, q) if s.ankle_strength_slope else tn
        effort = ca.dot(c, te**2) + s.w_acc * ca.sumsqr(a * (T**2 / (4 * math.pi**2)))
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
        opts: dict[str, Any] = {
            "tol": s.tol,
            "constr_viol_tol": s.constr_tol,
            "max_iter": s.max_iter,
            "linear_solver": "mumps",
            "mu_strategy": "adaptive",
            "print_level": 0,
            "sb": "yes",
            **self.ipopt_options,
            **perturbation.extra_ipopt_options(),
        }
        plugin = {"ipopt": opts, "print_time": False, "error_on_fail": False, "expand": True}
        return ca.nlpsol("stride_chain", "ipopt", nlp, plugin)

    def _strength_scaled(self, tn: Any, q: Any) -> Any:
        """As :meth:`PredictiveGaitProblem._strength_scaled`: ankle torque / exp(±k·θ)."""
        k = self.settings.ankle_strength_slope
        out = [tn[j] for j in range(N_TAU)]
        for j in (2, 5):  # ankle_r, ankle_l in JOINTS order
            out[j] = tn[j] * ca.exp(k * q[3 + j] * ca.tanh(tn[j] / 0.02))
        return ca.vertcat(*out)

    # ------------------------------------------------------------------ solving
    def scales(self, body: BodyParameters, speed: float) -> dict[str, np.ndarray]:
        """Residual (N, N·m), torque (N·m) and speed (m/s, rad/s) scales of ``body`` at ``speed``."""
        bw, H = body.body_weight, body.height
        return {
            "res_scale": np.array([bw, bw] + [bw * H] * (N_Q - 2)),
            "tau_max": _joint_type_values(self.settings.tau_max) * bw * H,
            "u_scale": np.array([max(speed, 1.0), 1.0, 2.0] + [5.0] * N_TAU),
        }

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
        """
        s = self.settings
        if len(plans) != len(self.buckets):
            raise ValueError(f"need one plan per bucket ({len(self.buckets)}), got {len(plans)}")
        counts = tuple(p.n_nodes for p in plans)
        if any(c > b for c, b in zip(counts, self.buckets)):
            raise ValueError(f"strides of {counts} nodes do not fit the buckets {self.buckets}")
        n_active = sum(counts)
        if guess_q.shape != (n_active, N_Q) or guess_tau.shape != (n_active, N_TAU):
            raise ValueError(
                f"guess must be ({n_active}, 9) and ({n_active}, 6), got {guess_q.shape}, {guess_tau.shape}"
            )
        v_max = max(p.speed for p in plans)
        sc = self.scales(body, v_max)
        sigma_u = np.array([s.sigma_u_tx * max(v_max, 1.0), s.sigma_u_ty] + [s.sigma_u_joint] * (N_Q - 2))
        node = np.zeros((_NODE_PAR, self.n))
        active = np.zeros(self.n, dtype=bool)
        start = 0
        for plan, bucket in zip(plans, self.buckets):
            cols = slice(start, start + bucket)
            node[0, start : start + plan.n_nodes] = 1.0
            node[1, cols] = 1.0 / plan.n_nodes
            node[2, cols] = plan.n_nodes * s.h
            node[3:, cols] = np.asarray(plan.effort_weights)[:, None]
            active[start : start + plan.n_nodes] = True
            start += bucket
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
            result.max_residual = float(np.abs(node_residual(q, u, qdd, tau, body, self.contact)).max())
            result.max_kinematic = float(np.abs(np.diff(np.vstack([q_prev, q]), axis=0) / s.h - u).max())
        return result

    def _bounds(self, body: BodyParameters) -> tuple[np.ndarray, np.ndarray]:
        s = self.settings
        lo_j, hi_j = self.joint_limits.arrays()
        H = body.height
        q_lo = np.concatenate([[-np.inf, s.pelvis_height_bounds[0] * H, s.tilt_bounds[0]], lo_j])
        q_hi = np.concatenate([[np.inf, s.pelvis_height_bounds[1] * H, s.tilt_bounds[1]], hi_j])
        lo = np.concatenate([q_lo, np.full(2 * N_Q, -np.inf), np.full(N_TAU, -s.tau_bound)])
        hi = np.concatenate([q_hi, np.full(2 * N_Q, np.inf), np.full(N_TAU, s.tau_bound)])
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


def node_residual(
    q: np.ndarray,
    u: np.ndarray,
    qdd: np.ndarray,
    tau: np.ndarray,
    body: BodyParameters,
    contact: ContactParameters | None = None,
    grf: np.ndarray | None = None,
    w: np.ndarray | None = None,
) -> np.ndarray:
    """(T, 9) Kane residual at the samples (NumPy backend), scaled to BW (pelvis_tx, pelvis_ty
    rows) and BW·H (rotational rows). GRF and w default to the contact model's values."""
    if grf is None or w is None:
        grf_c, w_c = dyn.contact_forces(q, u, body, contact if contact is not None else ContactParameters())
        grf = grf_c if grf is None else grf
        w = w_c if w is None else w
    r = dyn.kane_residual(q, u, qdd, tau, grf, w, body)
    bw = body.body_weight
    return np.asarray(r) / np.array([bw, bw] + [bw * body.height] * (N_Q - 2))


class StrideSolverCache:
    """Compiled :class:`StrideProblem` s by (buckets, attempt), built on first use.

    Compiling one costs a few seconds; each is reused for every subject, speed and plan whose
    strides fit its buckets.
    """

    def __init__(self, settings: StrideSettings, contact: ContactParameters | None = None) -> None:
        self.settings = settings
        self.contact = contact if contact is not None else ContactParameters()
        self._problems: dict[tuple[tuple[int, ...], bool], StrideProblem] = {}
        self.build_time = 0.0

    def get(self, node_counts: Sequence[int], warm: bool = True) -> StrideProblem:
        """The problem whose buckets hold strides of ``node_counts`` nodes; ``warm`` selects the
        warm-start IPOPT options (:data:`WARM_START_IPOPT`), else IPOPT's defaults."""
        buckets = tuple(bucket_for(int(n), self.settings.buckets) for n in node_counts)
        key = (buckets, warm)
        if key not in self._problems:
            options = WARM_START_IPOPT if warm else None
            problem = StrideProblem(buckets, self.settings, self.contact, ipopt_options=options)
            self.build_time += problem.build_time
            self._problems[key] = problem
        return self._problems[key]

    def __len__(self) -> int:
        return len(self._problems)


# ---------------------------------------------------------------------------------------------
# Periodic references
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CycleShape:
    """A periodic cycle on the normalised phase φ ∈ [0, 1): q with pelvis_tx detrended
    (q_x − v·t), u with the mean speed removed from pelvis_tx and multiplied by T (rates per unit
    phase), τ (N·m), GRF (N)."""

    speed: float
    duration: float
    phase: np.ndarray
    q: np.ndarray
    u_phase: np.ndarray
    tau: np.ndarray
    grf: np.ndarray

    @classmethod
    def from_solution(cls, sol: GaitSolution, boundary: float = 0.0) -> CycleShape:
        """The cycle of ``sol`` with phase 0 at ``boundary`` (fraction of the cycle) after the
        right foot's contact onset, so that cycles of different speeds line up."""
        q = sol.q.copy()
        q[:, 0] -= sol.speed * sol.time
        u = sol.u.copy()
        u[:, 0] -= sol.speed
        origin = sol.right_heel_strike() / sol.n_nodes + boundary
        phase = (sol.time / sol.duration - origin) % 1.0
        order = np.argsort(phase)
        return cls(
            sol.speed, sol.duration, phase[order], q[order], u[order] * sol.duration, sol.tau[order], sol.grf[order]
        )

    def at(self, phase: np.ndarray) -> tuple[np.ndarray, ...]:
        """(q, u_phase, τ, GRF) at the phases (periodic linear interpolation)."""
        phase = np.asarray(phase, dtype=float)

        def interp(y: np.ndarray) -> np.ndarray:
            return np.stack([np.interp(phase, self.phase, y[:, i], period=1.0) for i in range(y.shape[1])], axis=1)

        return interp(self.q), interp(self.u_phase), interp(self.tau), interp(self.grf)


class PeriodicReference:
    """Periodic gaits of one body at a few nominal speeds, blended linearly in speed.

    :meth:`stride` gives the guess and the terminal target of a stride of any speed and node
    count (speeds outside the nominal range use the nearest nominal gait). Every cycle is
    rotated so that its phase 0 (the stride boundary) lies ``boundary`` (fraction of the cycle)
    after the right foot's contact onset: the default, 0.12 before it, is in the flight phase when
    running and in the left single support when walking, where the state changes smoothly
    (a boundary at an impact makes the terminal target of the velocities very sensitive to timing).
    """

    def __init__(self, solutions: Sequence[GaitSolution], boundary: float = DEFAULT_BOUNDARY) -> None:
        if not solutions:
            raise ValueError("PeriodicReference needs at least one periodic solution")
        shapes = (CycleShape.from_solution(s, boundary) for s in solutions)
        self.shapes = sorted(shapes, key=lambda c: c.speed)
        self.speeds = np.array([c.speed for c in self.shapes])

    def nominal_duration(self, speed: float) -> float:
        """Stride duration at ``speed`` (m/s) interpolated between the nominal solutions, s."""
        return float(np.interp(speed, self.speeds, [c.duration for c in self.shapes]))

    def _blend(self, speed: float, phase: np.ndarray) -> tuple[np.ndarray, ...]:
        if speed <= self.speeds[0]:
            return self.shapes[0].at(phase)
        if speed >= self.speeds[-1]:
            return self.shapes[-1].at(phase)
        i = int(np.searchsorted(self.speeds, speed))  # speeds[i-1] < speed <= speeds[i]
        a, b = self.shapes[i - 1], self.shapes[i]
        lam = (speed - a.speed) / (b.speed - a.speed)
        return tuple((1 - lam) * xa + lam * xb for xa, xb in zip(a.at(phase), b.at(phase)))

    def stride(self, speed: float, n_nodes: int, h: float, x_prev: float = 0.0) -> ReferenceStride:
        """Reference stride of ``n_nodes`` nodes at ``speed`` (m/s), step ``h`` (s), after a
        previous state at pelvis_tx = ``x_prev`` (m).

        The reference cycle is stretched to the stride: node k lies at phase k/n, so the last
        node is the state just before the next stride's boundary.

        Returns:
            The nodes' q, u, τ and GRF and the state before the first node on the same reference
            (pelvis_tx = x_prev).
        """
        T = n_nodes * h
        phase = np.arange(-1, n_nodes) * h / T
        q, u_phase, tau, grf = self._blend(speed, phase)
        q[:, 0] += x_prev - q[0, 0] + speed * h * np.arange(n_nodes + 1)
        u = u_phase / T
        u[:, 0] += speed
        return ReferenceStride(q[1:], u[1:], tau[1:], grf[1:], q[0], u[0])


@dataclass(frozen=True)
class ReferenceStride:
    """A stride sampled from a :class:`PeriodicReference`: q, u (n, 9), τ (n, 6), GRF (n, 4) at
    the nodes and the state before the first node, q_prev and u_prev (9,) (SI units)."""

    q: np.ndarray
    u: np.ndarray
    tau: np.ndarray
    grf: np.ndarray
    q_prev: np.ndarray
    u_prev: np.ndarray


def _blend_into(q: np.ndarray, q_ref_prev: np.ndarray, q_prev: np.ndarray, width: float = 5.0) -> np.ndarray:
    """The reference q shifted so that it continues from ``q_prev`` instead of ``q_ref_prev``,
    the offset decaying over ``width`` nodes (pelvis_tx is already continuous)."""
    dq = q_prev - q_ref_prev
    dq[0] = 0.0
    return q + dq[None, :] * np.exp(-np.arange(1, len(q) + 1) / width)[:, None]


# ---------------------------------------------------------------------------------------------
# The chain
# ---------------------------------------------------------------------------------------------
@dataclass
class StrideRecord:
    """Statistics of one kept stride: its plan (speed m/s, nodes), IPOPT's status, iterations and
    time (s, all attempts), the number of attempts, the objective, the max Kane residual at its
    nodes (BW / BW·H), the rung of :data:`FALLBACKS` that solved it and the speed it was planned
    at (differs from ``speed`` on the rungs that change the plan)."""

    index: int
    speed: float
    n_nodes: int
    status: str
    iterations: int
    solve_time: float
    attempts: int
    objective: float
    max_residual: float
    fallback: str = "warm"
    planned_speed: float = float("nan")


@dataclass
class ChainResult:
    """A solved chain: the ground truth at every sample (units of :mod:`sspinn.conventions`).

    Attributes:
        q, u, qdd: (T, 9) coordinates, speeds (the collocation u) and accelerations (backward
            differences of u; the first uses ``u_prev``).
        tau: (T, 6) joint torques, N·m.
        grf: (T, 4) contact-model ground reaction forces, N; w: (T, 2) contact-point fractions.
        speed: (T,) the average pelvis speed of the sample's stride, m/s.
        stride: (T,) index of the sample's stride.
        q_prev, u_prev: (9,) the state before the first sample.
        strides: per-stride statistics.
        h: time step, s.
        ended_early: empty, or why the chain ended before its last planned stride (every rung of
            the fallback ladder failed; see :func:`simulate_chain`).
    """

    q: np.ndarray
    u: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    grf: np.ndarray
    w: np.ndarray
    speed: np.ndarray
    stride: np.ndarray
    q_prev: np.ndarray
    u_prev: np.ndarray
    strides: list[StrideRecord]
    h: float
    ended_early: str = ""

    _ARRAYS = ("q", "u", "qdd", "tau", "grf", "w", "speed", "stride", "q_prev", "u_prev")

    @property
    def n_samples(self) -> int:
        return self.q.shape[0]

    def residual(self, body: BodyParameters) -> np.ndarray:
        """(T, 9) Kane residual of the stored labels (q, u, q̈, τ, GRF, w), BW and BW·H."""
        return node_residual(self.q, self.u, self.qdd, self.tau, body, grf=self.grf, w=self.w)

    def save(self, path: str | Path) -> Path:
        """Write ``<path>.npz`` (arrays and the per-stride statistics as a structured array)."""
        path = Path(path).with_suffix(".npz")
        path.parent.mkdir(parents=True, exist_ok=True)
        stats = np.array([tuple(asdict(r).values()) for r in self.strides], dtype=_STRIDE_DTYPE)
        tmp = path.with_name(path.stem + ".tmp.npz")
        np.savez(
            tmp,
            h=self.h,
            strides=stats,
            ended_early=np.array(self.ended_early),
            **{k: getattr(self, k) for k in self._ARRAYS},
        )
        tmp.replace(path)
        return path

    @classmethod
    def load(cls, path: str | Path) -> ChainResult:
        with np.load(Path(path).with_suffix(".npz")) as data:
            arrays = {k: data[k] for k in cls._ARRAYS}
            strides = [
                StrideRecord(**{name: row[name].item() for name in _STRIDE_DTYPE.names}) for row in data["strides"]
            ]
            return cls(**arrays, strides=strides, h=float(data["h"]), ended_early=str(data["ended_early"]))


_STRIDE_DTYPE = np.dtype(
    [
        ("index", "i8"),
        ("speed", "f8"),
        ("n_nodes", "i8"),
        ("status", "U32"),
        ("iterations", "i8"),
        ("solve_time", "f8"),
        ("attempts", "i8"),
        ("objective", "f8"),
        ("max_residual", "f8"),
        ("fallback", "U16"),
        ("planned_speed", "f8"),
    ]
)


#: The fallback ladder of a stride, tried in this order until one solves (see :func:`simulate_chain`).
FALLBACKS: Final[tuple[str, ...]] = ("warm", "default", "perturbed", "nominal", "smaller_change", "previous_speed")

#: Relative size of the "perturbed" rung's guess perturbation (joint angles and torques).
PERTURBATION: Final = 0.02


def _rung_plan(rung: str, plan: StridePlan, previous_speed: float, reference: PeriodicReference, h: float) -> StridePlan:
    """The stride plan that ``rung`` of :data:`FALLBACKS` solves instead of ``plan``."""
    if rung in ("warm", "default", "perturbed"):
        return plan
    speed = {
        "nominal": plan.speed,
        "smaller_change": 0.5 * (plan.speed + previous_speed),
        "previous_speed": previous_speed,
    }[rung]
    return StridePlan(speed=speed, n_nodes=max(2, int(round(reference.nominal_duration(speed) / h))))


def simulate_chain(
    body: BodyParameters,
    plans: Sequence[StridePlan],
    reference: PeriodicReference,
    solvers: StrideSolverCache,
    *,
    lookahead: int = 0,
    on_stride: Callable[[StrideRecord], None] | None = None,
    min_strides: int = 1,
) -> ChainResult:
    """Solve the strides ``plans`` one after the other (see the module docstring).

    The chain starts from the reference's periodic state at the first plan's speed (pelvis_tx 0
    before the first sample). Each horizon holds the kept stride and ``lookahead`` further
    strides (the last plan repeated past the end).

    **Fallback ladder.** One IPOPT run from one guess is one sample of a distribution (another
    machine's rounding can end in ``Infeasible_Problem_Detected`` where this one succeeds), so a
    stride that fails is tried again down :data:`FALLBACKS`, and the first rung that reaches
    ``Solve_Succeeded`` with a node residual ≤ ``residual_tol`` is kept:

    1. ``warm``: the plan, the carried (lookahead) or reference guess, warm-start IPOPT options;
    2. ``default``: the plan, the reference guess blended into the previous state, IPOPT's
       default options;
    3. ``perturbed``: as 2 with joint angles and torques of the guess perturbed by
       :data:`PERTURBATION` (relative, seeded by the stride index: deterministic);
    4. ``nominal``: the planned speed at the reference's nominal duration and unit effort
       weights (no stride-to-stride variability), default options;
    5. ``smaller_change``: half the planned change of speed from the previous stride, nominal
       duration and effort;
    6. ``previous_speed``: the previous stride's speed (a steady stride), nominal duration.

    Rungs 4–6 change the stride's plan; the labels stay exact (they come from the solution) and
    each :class:`StrideRecord` names its rung. If every rung fails, the recording **ends cleanly
    after the last solved stride** (``ChainResult.ended_early`` says why) provided at least
    ``min_strides`` were solved; otherwise :class:`ChainError` is raised.

    Args:
        body: the (true) body parameters.
        plans: the strides to keep.
        reference: periodic gaits of ``body`` (guesses and terminal targets).
        solvers: compiled NLPs (shared between calls).
        lookahead: strides solved beyond the kept one (0 or more).
        on_stride: called with each kept stride's statistics (progress).
        min_strides: strides that must be solved before the recording may end early.

    Raises:
        ChainError: every rung failed for one of the first ``min_strides`` strides.
    """
    s = solvers.settings
    h = s.h
    if not plans:
        raise ValueError("simulate_chain needs at least one stride plan")
    if lookahead < 0:
        raise ValueError(f"lookahead must be >= 0, got {lookahead}")
    padded = list(plans) + [plans[-1]] * lookahead
    first = reference.stride(plans[0].speed, plans[0].n_nodes, h, 0.0)
    q_prev, u_prev = first.q_prev, first.u_prev
    q0_prev, u0_prev = q_prev.copy(), u_prev.copy()
    previous_speed = plans[0].speed
    carried: tuple[np.ndarray, np.ndarray] | None = None  # solved lookahead (q, τ) of the next stride
    chunks: list[tuple[np.ndarray, ...]] = []
    records: list[StrideRecord] = []
    ended_early = ""
    for k, planned in enumerate(plans):
        result: StrideResult | None = None
        total_iter, total_time, n_try = 0, 0.0, 0
        failures: list[str] = []
        plan = planned
        for rung in FALLBACKS:
            plan = _rung_plan(rung, planned, previous_speed, reference, h)
            if rung in ("nominal", "smaller_change", "previous_speed") and plan == planned:
                continue  # nothing new to try on this rung
            horizon = [plan] + padded[k + 1 : k + 1 + lookahead]
            guess_q, guess_tau, target = _horizon_guess(
                rung, horizon, reference, h, q_prev, carried if rung == "warm" else None, k
            )
            n_try += 1
            problem = solvers.get([p.n_nodes for p in horizon], warm=rung == "warm")
            result = problem.solve(body, q_prev, u_prev, horizon, target.q[-1], target.u[-1], guess_q, guess_tau)
            total_iter += result.iterations
            total_time += result.solve_time
            if result.status in ACCEPTED_STATUSES and result.max_residual <= s.residual_tol:
                break
            failures.append(f"{rung}: {result.status}, residual {result.max_residual:.3g}")
            result = None
        if result is None:
            reason = (
                f"stride {k} (speed {planned.speed:.3f} m/s, {planned.n_nodes} nodes) failed on every rung of the "
                f"fallback ladder ({'; '.join(failures)})"
            )
            if k < min_strides:
                raise ChainError(reason)
            ended_early = f"ended after stride {k - 1}: {reason}"
            break
        q, u, qdd, tau = result.stride(0)
        chunks.append((q, u, qdd, tau, np.full(len(q), plan.speed), np.full(len(q), k)))
        carried = None
        if lookahead and plan == planned:
            nq, _, _, ntau = result.stride(1)
            carried = (nq, ntau)
        q_prev, u_prev = q[-1], u[-1]
        previous_speed = plan.speed
        record = StrideRecord(
            index=k,
            speed=plan.speed,
            n_nodes=plan.n_nodes,
            status=result.status,
            iterations=total_iter,
            solve_time=total_time,
            attempts=n_try,
            objective=result.objective,
            max_residual=float(np.abs(node_residual(q, u, qdd, tau, body, solvers.contact)).max()),
            fallback=rung,
            planned_speed=planned.speed,
        )
        records.append(record)
        if on_stride is not None:
            on_stride(record)
    q, u, qdd, tau, speed, stride = (np.concatenate(parts) for parts in zip(*chunks))
    grf, w = dyn.contact_forces(q, u, body, solvers.contact)
    return ChainResult(
        q=q,
        u=u,
        qdd=qdd,
        tau=tau,
        grf=np.asarray(grf),
        w=np.asarray(w),
        speed=speed,
        stride=stride.astype(np.int64),
        q_prev=q0_prev,
        u_prev=u0_prev,
        strides=records,
        h=h,
        ended_early=ended_early,
    )


def _horizon_guess(
    rung: str,
    horizon: Sequence[StridePlan],
    reference: PeriodicReference,
    h: float,
    q_prev: np.ndarray,
    carried: tuple[np.ndarray, np.ndarray] | None,
    index: int,
) -> tuple[np.ndarray, np.ndarray, ReferenceStride]:
    """Initial guess (q, τ) of a horizon on ``rung`` and the terminal target (the reference stride
    of the horizon's last plan). ``warm``: the carried lookahead stride (if any) or the reference
    blended from the previous guess; other rungs: the reference blended into ``q_prev``, on
    ``perturbed`` with a deterministic relative perturbation of the angles and torques."""
    qs: list[np.ndarray] = []
    taus: list[np.ndarray] = []
    x_last, q_last = q_prev[0], q_prev
    target = None
    for i, p in enumerate(horizon):
        target = reference.stride(p.speed, p.n_nodes, h, x_last)
        if i == 0 and carried is not None:
            qs.append(carried[0])
            taus.append(carried[1])
        else:
            start = q_last if rung == "warm" else (q_prev if i == 0 else target.q_prev)
            qs.append(_blend_into(target.q, target.q_prev, start))
            taus.append(target.tau)
        x_last, q_last = qs[-1][-1, 0], qs[-1][-1]
    assert target is not None
    q, tau = np.vstack(qs), np.vstack(taus)
    if rung == "perturbed":
        rng = np.random.default_rng([index, 7])
        q = q.copy()
        q[:, 2:] += PERTURBATION * np.abs(q[:, 2:]).max(axis=0) * rng.standard_normal(q[:, 2:].shape)
        tau = tau * (1 + PERTURBATION * rng.standard_normal(tau.shape))
    return q, tau, target
