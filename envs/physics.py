"""Allocation-free numba stepper for the single-state environment hot path.

It advances one state with the *same* generated kernels (``sspinn/_generated/model_numba.py``:
``contact_simulation`` and ``mass_matrix_forcing``) and the same update formulas as
:func:`sspinn.simulation.step` (semi-implicit Euler or RK4, actuator torques held constant over the
control interval, forward-simulation contact), so the two agree to round-off (checked in
``tests/test_env.py``). What differs is the bookkeeping:

* the state is updated **in place** and every scratch array (mass matrix, forcing, Runge–Kutta
  stages) is allocated once per call instead of once per model evaluation;
* the 9×9 Cholesky factorisation is done in place in the mass-matrix buffer;
* the whole control interval (all substeps) is one compiled call.

Measured on the 2-core development machine (``benchmarks/bench_env.py``, minimum of alternating
rounds, load-dependent): 54–80 µs per 50-substep control interval against 81–125 µs for
:func:`sspinn.simulation.step` (which allocates its temporaries — mass matrix, Cholesky factor,
integrator intermediates — in every model evaluation), i.e. ≈1.5× faster. The Cholesky solve
multiplies by reciprocals of the diagonal instead of dividing, so results differ from
``sspinn.simulation.step`` by round-off (≈1e-13 m after 50 substeps) rather than bit for bit.

The environment also adds passive joint moments (:func:`envs.task.passive_torque`) to the torques at
the start of every substep; with the passive parameters all zero this is exactly the bare model. If
this stepper proves useful it belongs in :mod:`sspinn.simulation`; it lives here only because the
environment task must not modify ``sspinn/``.
"""

from __future__ import annotations

import numba
import numpy as np

from envs.task import passive_torque
from sspinn._generated import model_numba as kernels

#: Integrator names accepted by :func:`advance` (index = ``method`` argument), as in
#: :data:`sspinn.integrators.INTEGRATORS`.
METHODS: tuple[str, ...] = ("rk4", "semi_implicit_euler")

_passive_torque = numba.njit(cache=True)(passive_torque)


@numba.njit(cache=True)
def _accel_into(q, u, tau, p, c, M, f, inv, grf, w, out) -> None:  # pragma: no cover - compiled
    """out ← q̈(q, u) with contact; grf/w receive the contact forces used (N) and fractions."""
    kernels.contact_simulation(q, u, p, c, grf, w)
    kernels.mass_matrix_forcing(q, u, tau, grf, w, p, M, f)
    # in-place Cholesky M = L Lᵀ (lower triangle of M overwritten by L); the reciprocals of the
    # diagonal are kept in ``inv`` so that the 45 + 18 divisions become 9 (divisions dominate the cost)
    n = 9
    for j in range(n):
        s = M[j, j]
        for k in range(j):
            s -= M[j, k] * M[j, k]
        r = 1.0 / np.sqrt(s)
        inv[j] = r
        for i in range(j + 1, n):
            s = M[i, j]
            for k in range(j):
                s -= M[i, k] * M[j, k]
            M[i, j] = s * r
    for i in range(n):
        s = f[i]
        for k in range(i):
            s -= M[i, k] * out[k]
        out[i] = s * inv[i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, n):
            s -= M[k, i] * out[k]
        out[i] = s * inv[i]


@numba.njit(cache=True)
def advance(q, u, tau, passive, p, c, dt, substeps, method, grf) -> bool:  # pragma: no cover - compiled
    """Advance (q, u) in place by ``substeps`` steps of ``dt`` seconds under constant torques.

    Args:
        q, u: float64 (9,) coordinates (m, rad) and speeds (m/s, rad/s), overwritten.
        tau: float64 (6,) actuator joint torques, N·m.
        passive: float64 (14,) passive joint parameters (:func:`envs.task.passive_parameters`); the
            passive moments (:func:`envs.task.passive_torque`) are evaluated at the start of every
            substep and added to ``tau`` for that substep (for semi-implicit Euler this is the same
            as evaluating them inside the model).
        p, c: body (41,) and contact (7,) parameter vectors.
        dt: substep, s. substeps: number of substeps. method: index into :data:`METHODS`.
        grf: float64 (4,) output, ground reaction forces (N) at the *final* state.

    Returns:
        True when the final state is finite.
    """
    M = np.empty((9, 9))
    f = np.empty(9)
    inv = np.empty(9)
    w = np.empty(2)
    t = np.empty(6)
    a1 = np.empty(9)
    a2 = np.empty(9)
    a3 = np.empty(9)
    a4 = np.empty(9)
    qs = np.empty(9)
    us2 = np.empty(9)
    us3 = np.empty(9)
    us4 = np.empty(9)
    k = passive[12]
    b = passive[13]
    for _ in range(substeps):
        for j in range(6):
            t[j] = tau[j] + _passive_torque(q[3 + j], u[3 + j], passive[j], passive[6 + j], k, b)
        if method == 1:  # semi-implicit Euler: u ← u + dt·q̈(q, u); q ← q + dt·u
            _accel_into(q, u, t, p, c, M, f, inv, grf, w, a1)
            for i in range(9):
                u[i] = u[i] + dt * a1[i]
                q[i] = q[i] + dt * u[i]
        else:  # classical RK4, the formulas of sspinn.integrators.make_rk4
            _accel_into(q, u, t, p, c, M, f, inv, grf, w, a1)
            for i in range(9):
                us2[i] = u[i] + 0.5 * dt * a1[i]
                qs[i] = q[i] + 0.5 * dt * u[i]
            _accel_into(qs, us2, t, p, c, M, f, inv, grf, w, a2)
            for i in range(9):
                us3[i] = u[i] + 0.5 * dt * a2[i]
                qs[i] = q[i] + 0.5 * dt * us2[i]
            _accel_into(qs, us3, t, p, c, M, f, inv, grf, w, a3)
            for i in range(9):
                us4[i] = u[i] + dt * a3[i]
                qs[i] = q[i] + dt * us3[i]
            _accel_into(qs, us4, t, p, c, M, f, inv, grf, w, a4)
            for i in range(9):
                q[i] = q[i] + dt / 6.0 * (u[i] + 2.0 * us2[i] + 2.0 * us3[i] + us4[i])
                u[i] = u[i] + dt / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i])
    kernels.contact_simulation(q, u, p, c, grf, w)
    finite = True
    for i in range(9):
        if not (np.isfinite(q[i]) and np.isfinite(u[i])):
            finite = False
    return finite


@numba.njit(cache=True)
def contact_into(q, u, p, c, grf) -> None:  # pragma: no cover - compiled
    """grf (4,) ← ground reaction forces (N) of the forward-simulation contact model at (q, u)."""
    w = np.empty(2)
    kernels.contact_simulation(q, u, p, c, grf, w)
