"""Forward simulation of the sagittal model: fast numba single-state stepping and batched torch.

* NumPy/numba: :func:`simulate` (a whole rollout) and :func:`step` (one control interval)
  use the generated scalar kernels (``sspinn/_generated/model_numba.py``) and the integrators of
  :mod:`sspinn.integrators` compiled with numba; about a microsecond per model evaluation.
* torch: :func:`step_torch` advances any batch of states differentiably with the generated
  array code (``model_expr``), on CPU or CUDA.

Both use the forward-simulation contact model of :mod:`sspinn.contact` (or none).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from sspinn import dynamics
from sspinn._generated import model_numba as kernels
from sspinn.body import BodyParameters
from sspinn.contact import ContactParameters
from sspinn.conventions import N_GRF, N_Q, N_TAU
from sspinn.integrators import INTEGRATORS, make_rk4, make_semi_implicit_euler

_METHODS = tuple(INTEGRATORS)  # index passed into the compiled loop


@numba.njit(cache=True)
def cholesky_solve(M: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Solve M x = f for a small symmetric positive-definite M (no LAPACK call overhead).

    Hand-written because numba's ``np.linalg.solve`` goes through LAPACK with per-call
    allocation and checks that cost more than the 9×9 factorisation itself.
    """
    n = f.shape[0]
    L = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1):
            s = M[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = np.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
    y = np.empty(n)
    for i in range(n):
        s = f[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    x = np.empty(n)
    for i in range(n - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]
    return x


@numba.njit(cache=True)
def contact_state(q: np.ndarray, u: np.ndarray, p: np.ndarray, c: np.ndarray, with_contact: bool):
    """(grf (4,), w (2,)) of the forward-simulation contact model, zeros without contact."""
    grf = np.zeros(4)
    w = np.zeros(2)
    if with_contact:
        kernels.contact_simulation(q, u, p, c, grf, w)
    return grf, w


@numba.njit(cache=True)
def accel(q: np.ndarray, u: np.ndarray, tau: np.ndarray, p: np.ndarray, c: np.ndarray, with_contact: bool) -> np.ndarray:
    """q̈ for one state under joint torques tau and (optionally) ground contact."""
    grf, w = contact_state(q, u, p, c, with_contact)
    M = np.empty((9, 9))
    f = np.empty(9)
    kernels.mass_matrix_forcing(q, u, tau, grf, w, p, M, f)
    return cholesky_solve(M, f)


_rk4 = numba.njit(cache=True)(make_rk4(accel))
_semi_implicit_euler = numba.njit(cache=True)(make_semi_implicit_euler(accel))


@numba.njit(cache=True)
def _advance(q, u, tau, p, c, dt, substeps, method, with_contact):
    args = (tau, p, c, with_contact)
    for _ in range(substeps):
        if method == 0:
            q, u = _rk4(q, u, dt, args)
        else:
            q, u = _semi_implicit_euler(q, u, dt, args)
    return q, u


@numba.njit(cache=True)
def _rollout(q0, u0, torques, p, c, dt, substeps, method, with_contact):
    n = torques.shape[0]
    Q = np.empty((n + 1, 9))
    U = np.empty((n + 1, 9))
    G = np.empty((n + 1, 4))
    q, u = q0.copy(), u0.copy()
    for k in range(n + 1):
        Q[k], U[k] = q, u
        G[k] = contact_state(q, u, p, c, with_contact)[0]
        if k < n:
            q, u = _advance(q, u, torques[k], p, c, dt, substeps, method, with_contact)
    return Q, U, G


@dataclass(frozen=True)
class Trajectory:
    """A simulated motion sampled every ``substeps · dt`` seconds.

    Attributes: t (n,) s; q, u (n, 9); grf (n, 4) N (zero without contact); tau (n, 6) N·m
    (the torque held during the interval that starts at each sample; zero in the last row).
    """

    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    grf: np.ndarray
    tau: np.ndarray


def _method_index(method: str) -> int:
    if method not in _METHODS:
        raise ValueError(f"unknown integrator {method!r}; choose one of {', '.join(_METHODS)}")
    return _METHODS.index(method)


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
) -> Trajectory:
    """Integrate the model from (q0, u0) for ``duration`` seconds.

    Args:
        q0, u0: initial coordinates and speeds (9,), conventions of :mod:`sspinn.conventions`.
        body: body parameters (dataclass or 41-vector).
        duration: s.
        sample_dt: output (and torque) interval, s; each is split into ``substeps`` steps.
        torques: (n_samples, 6) joint torques in N·m held over each interval, or None (zero).
        contact: contact parameters, or None for no ground at all (free flight).
        method: "rk4" or "semi_implicit_euler".
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
    with_contact = contact is not None
    c = _vec(contact if with_contact else ContactParameters())
    Q, U, G = _rollout(
        np.ascontiguousarray(q0), np.ascontiguousarray(u0), np.ascontiguousarray(torques), p, c,
        sample_dt / substeps, substeps, _method_index(method), with_contact,
    )
    tau = np.vstack([torques, np.zeros((1, N_TAU))])
    return Trajectory(t=np.arange(n + 1) * sample_dt, q=Q, u=U, grf=G, tau=tau)


def step(
    q: np.ndarray, u: np.ndarray, tau: np.ndarray, p: np.ndarray, c: np.ndarray,
    dt: float, substeps: int = 1, method: str = "semi_implicit_euler", contact: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Advance one state by ``substeps`` steps of ``dt`` with constant torques (no input
    validation: this is the environment's hot path). Returns (q, u, grf at the new state)."""
    q, u = _advance(q, u, tau, p, c, dt, substeps, _method_index(method), contact)
    return q, u, contact_state(q, u, p, c, contact)[0]


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
