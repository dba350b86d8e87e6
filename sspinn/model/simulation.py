"""Forward simulation of the sagittal model: fast numba single-state stepping and batched torch.

* NumPy/numba: :func:`advance` is *the* single-state stepper — an in-place compiled control
  interval (allocating nothing but its workspace; :func:`advance_forced_into` takes the caller's,
  as the environments do) built on the generated scalar kernels
  (``sspinn/model/_generated/model_numba.py``). :func:`step` (one control interval, returns new arrays),
  :func:`simulate` (a whole rollout) and the Gymnasium environment (``envs/``) all call it;
  :func:`accel` evaluates q̈ once. About 0.4–0.5 µs per model evaluation with contact
  (``benchmarks/speed/bench_env.py``, 2-core development machine).
* torch: :func:`step_torch` advances any batch of states differentiably with the generated
  array code (``model_expr``) and the generic integrators of :mod:`sspinn.model.integrators`, on CPU or
  CUDA.

Both use the forward-simulation contact model of :mod:`sspinn.model.contact` (or none) and, optionally,
the passive joint moments of :mod:`sspinn.model.passive`.

The numba stepper implements **exactly the formulas** of :func:`sspinn.model.integrators.make_rk4` and
:func:`sspinn.model.integrators.make_semi_implicit_euler`, written out with preallocated buffers
(numba cannot fuse the closures' temporaries away); ``tests/test_dynamics.py`` checks that
:func:`simulate` and :func:`step_torch` agree to ≈1e-12 for both integrators, with contact.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from sspinn.model import dynamics
from sspinn.model._generated import model_numba as kernels
from sspinn.model.body import BodyParameters
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import N_GRF, N_Q, N_TAU
from sspinn.model.integrators import INTEGRATORS
from sspinn.model.passive import N_PASSIVE, passive_torque

#: Integrator names; the index is the ``method`` argument of :func:`advance`.
METHODS: tuple[str, ...] = tuple(INTEGRATORS)
_RK4 = METHODS.index("rk4")
_SEMI_IMPLICIT_EULER = METHODS.index("semi_implicit_euler")

#: Passive parameters of the bare model (no passive joint moments), see :mod:`sspinn.model.passive`.
_NO_PASSIVE = np.zeros(N_PASSIVE)
#: No external generalized force (the ``force`` argument of :func:`advance_forced`).
_NO_FORCE = np.zeros(N_Q)

_passive_torque = numba.njit(cache=True)(passive_torque)


@numba.njit(cache=True)
def _contact_into(q, u, p, c, with_contact, grf, w) -> None:  # pragma: no cover - compiled
    """grf (4,) ← ground reaction forces (N), w (2,) ← contact fractions; zeros without contact."""
    if with_contact:
        kernels.contact_simulation(q, u, p, c, grf, w)
    else:
        grf[:] = 0.0
        w[:] = 0.0


@numba.njit(cache=True)
def _accel_into(q, u, tau, force, p, c, with_contact, M, f, grf, w, out) -> None:  # pragma: no cover - compiled
    """out ← q̈(q, u, τ) = M⁻¹ (f + force), ``force`` (9,) an external generalized force.
    M (9, 9), f (9,), w (2,) are scratch; grf (4,) receives the ground reaction forces used (N,
    zeros without contact).

    With contact, one generated kernel evaluates the contact model and the equations of motion
    together (they share their trigonometry). M x = f is solved by the generated
    ``solve_mass_matrix`` kernel: an L·D·Lᵀ factorisation unrolled over the nonzeros of M's factor
    (:func:`sspinn.model.codegen.generate_mass_matrix_solver`) instead of numba's
    ``np.linalg.solve``, whose LAPACK call allocates and checks more than the 9×9 factorisation
    costs; the result differs from an LU solve by round-off only.
    """
    if with_contact:  # one kernel: contact and equations of motion share their trigonometry
        kernels.contact_mass_matrix_forcing(q, u, tau, p, c, grf, w, M, f)
    else:
        grf[:] = 0.0
        w[:] = 0.0
        kernels.mass_matrix_forcing(q, u, tau, grf, w, p, M, f)
    for i in range(9):
        f[i] += force[i]
    kernels.solve_mass_matrix(M, f, out)


@numba.njit(cache=True)
def accel(q: np.ndarray, u: np.ndarray, tau: np.ndarray, p: np.ndarray, c: np.ndarray, with_contact: bool) -> np.ndarray:
    """q̈ (9,) for one state under joint torques tau (6,, N·m) and (optionally) ground contact; one
    model evaluation of :func:`advance` (no passive joint moments)."""
    out = np.empty(9)
    _accel_into(q, u, tau, _NO_FORCE, p, c, with_contact, np.empty((9, 9)), np.empty(9), np.empty(4), np.empty(2), out)
    return out


@numba.njit(cache=True)
def advance(q, u, tau, passive, p, c, dt, substeps, method, with_contact, grf) -> bool:  # pragma: no cover - compiled
    """Advance (q, u) **in place** by ``substeps`` steps of ``dt`` seconds under constant torques:
    :func:`advance_forced` without an external force (see there for the arguments)."""
    return advance_forced(q, u, tau, _NO_FORCE, passive, p, c, dt, substeps, method, with_contact, grf)


#: Rows of the workspace of :func:`advance_forced_into`, float64 (WORK_ROWS, 9): the mass matrix
#: (rows 0–8), the forcing, the contact fractions, the torques, the Runge–Kutta stages a1–a4 and
#: the stage states qs, u2–u4.
WORK_ROWS = 20


@numba.njit(cache=True)
def advance_forced_into(q, u, tau, force, passive, p, c, dt, substeps, method, with_contact, grf, work) -> bool:  # pragma: no cover - compiled
    """Advance (q, u) **in place** by ``substeps`` steps of ``dt`` seconds under constant torques
    and a constant external generalized force.

    The single-state stepper of sspinn: the whole control interval is one compiled call that
    allocates nothing — the mass matrix, forcing and Runge–Kutta stages live in the caller's
    workspace ``work`` (:func:`advance_forced` makes one per call; the environments keep one per
    walker): 12 small allocations per control interval cost 8–10 % of the physics' time.

    Args:
        q, u: float64 (9,) coordinates (m, rad) and speeds (m/s, rad/s), overwritten.
        tau: float64 (6,) actuator joint torques, N·m, held constant.
        force: float64 (9,) external generalized force, held constant, added to the right-hand side
            of the equations of motion. Entries 0 and 1 are the horizontal and vertical force (N) on
            the hip joint centre — the origin of the HAT segment, whose global position is
            (pelvis_tx, pelvis_ty), so its partial velocities are the unit vectors of those two
            coordinates — and entries 2–8 torques (N·m) on the other coordinates. Zeros: none.
        passive: float64 (14,) passive joint parameters (:func:`sspinn.model.passive.passive_parameters`;
            all zeros = bare model). The passive moments (:func:`sspinn.model.passive.passive_torque`) are
            evaluated at the start of every substep and added to ``tau`` for that substep — for
            semi-implicit Euler the same as evaluating them inside the model, for RK4 they are held
            over the four stages.
        p, c: body (41,) and contact (7,) parameter vectors.
        dt: substep, s. substeps: number of substeps. method: index into :data:`METHODS`.
        with_contact: ground contact on (forward-simulation model) or off (free flight).
        grf: float64 (4,) output, ground reaction forces (N) at the *final* state.
        work: float64 (:data:`WORK_ROWS`, 9) workspace, overwritten (its contents on entry do not matter).

    Returns:
        True when the final state is finite.

    The updates are those of :mod:`sspinn.model.integrators` (same formulas, same order of operations):

    * semi-implicit Euler: u ← u + dt·q̈(q, u); q ← q + dt·u;
    * RK4: a1 = q̈(q, u), u2 = u + dt/2·a1, a2 = q̈(q + dt/2·u, u2), u3 = u + dt/2·a2,
      a3 = q̈(q + dt/2·u2, u3), u4 = u + dt·a3, a4 = q̈(q + dt·u3, u4),
      q ← q + dt/6·(u + 2·u2 + 2·u3 + u4), u ← u + dt/6·(a1 + 2·a2 + 2·a3 + a4).
    """
    M = work[0:9]
    f = work[9]
    w = work[10, 0:2]
    t = work[11, 0:6]
    a1 = work[12]
    a2 = work[13]
    a3 = work[14]
    a4 = work[15]
    qs = work[16]
    us2 = work[17]
    us3 = work[18]
    us4 = work[19]
    k = passive[12]
    b = passive[13]
    for _ in range(substeps):
        for j in range(6):
            t[j] = tau[j] + _passive_torque(q[3 + j], u[3 + j], passive[j], passive[6 + j], k, b)
        if method == _SEMI_IMPLICIT_EULER:
            _accel_into(q, u, t, force, p, c, with_contact, M, f, grf, w, a1)
            for i in range(9):
                u[i] = u[i] + dt * a1[i]
                q[i] = q[i] + dt * u[i]
        else:  # _RK4
            _accel_into(q, u, t, force, p, c, with_contact, M, f, grf, w, a1)
            for i in range(9):
                us2[i] = u[i] + 0.5 * dt * a1[i]
                qs[i] = q[i] + 0.5 * dt * u[i]
            _accel_into(qs, us2, t, force, p, c, with_contact, M, f, grf, w, a2)
            for i in range(9):
                us3[i] = u[i] + 0.5 * dt * a2[i]
                qs[i] = q[i] + 0.5 * dt * us2[i]
            _accel_into(qs, us3, t, force, p, c, with_contact, M, f, grf, w, a3)
            for i in range(9):
                us4[i] = u[i] + dt * a3[i]
                qs[i] = q[i] + dt * us3[i]
            _accel_into(qs, us4, t, force, p, c, with_contact, M, f, grf, w, a4)
            for i in range(9):
                q[i] = q[i] + dt / 6.0 * (u[i] + 2.0 * us2[i] + 2.0 * us3[i] + us4[i])
                u[i] = u[i] + dt / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i])
    _contact_into(q, u, p, c, with_contact, grf, w)
    finite = True
    for i in range(9):
        if not (np.isfinite(q[i]) and np.isfinite(u[i])):
            finite = False
    return finite


@numba.njit(cache=True)
def advance_forced(q, u, tau, force, passive, p, c, dt, substeps, method, with_contact, grf) -> bool:  # pragma: no cover - compiled
    """:func:`advance_forced_into` with a workspace of its own (one allocation per call); see there
    for the arguments."""
    return advance_forced_into(q, u, tau, force, passive, p, c, dt, substeps, method, with_contact, grf,
                               np.empty((WORK_ROWS, 9)))


@numba.njit(cache=True)
def contact_into(q, u, p, c, with_contact, grf) -> None:  # pragma: no cover - compiled
    """grf (4,) ← ground reaction forces (N) of the forward-simulation contact model at (q, u)
    (zeros without contact)."""
    _contact_into(q, u, p, c, with_contact, grf, np.empty(2))


@numba.njit(cache=True)
def _rollout(q0, u0, torques, passive, p, c, dt, substeps, method, with_contact):  # pragma: no cover - compiled
    """Samples (Q, U, G) of :func:`advance` over ``len(torques)`` control intervals."""
    n = torques.shape[0]
    Q = np.empty((n + 1, 9))
    U = np.empty((n + 1, 9))
    G = np.empty((n + 1, 4))
    q, u, grf = q0.copy(), u0.copy(), np.empty(4)
    contact_into(q, u, p, c, with_contact, grf)
    Q[0], U[0], G[0] = q, u, grf
    for k in range(n):
        advance(q, u, torques[k], passive, p, c, dt, substeps, method, with_contact, grf)
        Q[k + 1], U[k + 1], G[k + 1] = q, u, grf
    return Q, U, G


@dataclass(frozen=True)
class Rollout:
    """A simulated motion sampled every ``substeps · dt`` seconds: what the integrator hands
    back (no q̈ or contact fractions, τ held over intervals), not the analysis type
    :class:`sspinn.model.trajectory.Trajectory` (which has them).

    Attributes: t (n,) s; q, u (n, 9); grf (n, 4) N (zero without contact); tau (n, 6) N·m
    (the actuator torque held during the interval that starts at each sample, without passive
    moments; zero in the last row).
    """

    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    grf: np.ndarray
    tau: np.ndarray


def _method_index(method: str) -> int:
    if method not in METHODS:
        raise ValueError(f"unknown integrator {method!r}; choose one of {', '.join(METHODS)}")
    return METHODS.index(method)


def _vec(value: Any) -> np.ndarray:
    if isinstance(value, (BodyParameters, ContactParameters)):
        return value.vector()
    return np.ascontiguousarray(value, dtype=np.float64)


def simulate(
    q0: np.ndarray,
    u0: np.ndarray,
    body: BodyParameters | np.ndarray,
    *,
    duration: float,
    sample_dt: float = 0.01,
    substeps: int = 10,
    torques: np.ndarray | None = None,
    contact: ContactParameters | np.ndarray | None = ContactParameters(),  # noqa: B008 (frozen, immutable)
    method: str = "rk4",
    passive: np.ndarray | None = None,
) -> Rollout:
    """Integrate the model from (q0, u0) for ``duration`` seconds (a compiled loop over :func:`advance`).

    Args:
        q0, u0: initial coordinates and speeds (9,), conventions of :mod:`sspinn.model.conventions`.
        body: body parameters (dataclass or 41-vector).
        duration: s.
        sample_dt: output (and torque) interval, s; each is split into ``substeps`` steps.
        torques: (n_samples, 6) joint torques in N·m held over each interval, or None (zero).
        contact: contact parameters, or None for no ground at all (free flight).
        method: "rk4" or "semi_implicit_euler".
        passive: (14,) passive joint parameters (:func:`sspinn.model.passive.passive_parameters`), or None
            for none (the bare model).
    """
    q0 = dynamics.check_input("q0", q0, N_Q)
    u0 = dynamics.check_input("u0", u0, N_Q)
    if duration <= 0 or sample_dt <= 0 or substeps < 1:
        raise ValueError(f"need duration > 0, sample_dt > 0, substeps >= 1; got {duration}, {sample_dt}, {substeps}")
    n = int(round(duration / sample_dt))
    if torques is None:
        torques = np.zeros((n, N_TAU))
    torques = dynamics.check_input("torques", torques, N_TAU)
    if torques.shape != (n, N_TAU):
        raise ValueError(f"torques must have shape ({n}, {N_TAU}) for {duration} s at {sample_dt} s, got {torques.shape}")
    p = dynamics.check_input("body parameters", _vec(body), len(_vec(body)))
    passive = _NO_PASSIVE if passive is None else dynamics.check_input("passive", _vec(passive), N_PASSIVE)
    with_contact = contact is not None
    c = _vec(contact if with_contact else ContactParameters())
    Q, U, G = _rollout(
        np.ascontiguousarray(q0), np.ascontiguousarray(u0), np.ascontiguousarray(torques), passive, p, c,
        sample_dt / substeps, substeps, _method_index(method), with_contact,
    )
    tau = np.vstack([torques, np.zeros((1, N_TAU))])
    return Rollout(t=np.arange(n + 1) * sample_dt, q=Q, u=U, grf=G, tau=tau)


def step(
    q: np.ndarray, u: np.ndarray, tau: np.ndarray, p: np.ndarray, c: np.ndarray,
    dt: float, substeps: int = 1, method: str = "semi_implicit_euler", contact: bool = True,
    passive: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Advance one state by ``substeps`` steps of ``dt`` with constant torques; :func:`advance` on
    copies of q and u (float64 (9,) arrays; no input validation: this is a hot path). ``passive``:
    (14,) passive joint parameters or None (none). Returns (q, u, grf at the new state)."""
    q = np.array(q, dtype=np.float64)
    u = np.array(u, dtype=np.float64)
    grf = np.empty(N_GRF)
    advance(q, u, tau, _NO_PASSIVE if passive is None else passive, p, c, dt, substeps, _method_index(method), contact, grf)
    return q, u, grf


def step_torch(q, u, tau, p, c=None, *, dt: float, substeps: int = 1, method: str = "semi_implicit_euler", contact: bool = True):
    """Batched, differentiable step of torch states (..., 9) under torques (..., 6).

    Returns (q, u, grf) with grf (..., 4) at the new state (zeros without contact).
    """
    c = ContactParameters() if c is None else c
    if method not in INTEGRATORS:
        _method_index(method)  # raises with the list of methods

    def qdd(q_, u_, tau_):
        if contact:
            return dynamics.forward_dynamics_with_contact(q_, u_, tau_, p, c)[0]
        zeros = q_.new_zeros(*q_.shape[:-1], N_GRF)
        return dynamics.forward_dynamics(q_, u_, tau_, zeros, q_.new_zeros(*q_.shape[:-1], 2), p)

    integrator_step = INTEGRATORS[method](qdd)
    for _ in range(substeps):
        q, u = integrator_step(q, u, dt, (tau,))
    grf = dynamics.contact_forces(q, u, p, c)[0] if contact else q.new_zeros(*q.shape[:-1], N_GRF)
    return q, u, grf
