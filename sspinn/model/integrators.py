"""Fixed-step integrators for second-order systems q̈ = accel(q, u, *args), u = q̇.

Each integrator is a factory ``make_<name>(accel)`` returning ``step(q, u, dt, args) -> (q, u)``.
Written once with plain array arithmetic, the same steppers advance NumPy arrays and torch tensors
(batched, differentiable; :func:`sspinn.model.simulation.step_torch`). ``args`` is a tuple of extra
arguments passed through to ``accel`` (torques, parameters...).

The single-state numba stepper :func:`sspinn.model.simulation.advance` writes the same formulas out
in place (preallocated stage buffers, no temporaries per model evaluation); ``tests/test_dynamics.py``
checks that it agrees with these definitions (through ``step_torch``) to ≈1e-12. Change a formula
here and there together.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

Accel = Callable[..., Any]
Step = Callable[[Any, Any, float, tuple], tuple[Any, Any]]


def make_rk4(accel: Accel) -> Step:
    """Classical Runge–Kutta 4 (global error O(dt⁴)), four model evaluations per step."""

    def rk4_step(q, u, dt, args):
        a1 = accel(q, u, *args)
        u2 = u + 0.5 * dt * a1
        a2 = accel(q + 0.5 * dt * u, u2, *args)
        u3 = u + 0.5 * dt * a2
        a3 = accel(q + 0.5 * dt * u2, u3, *args)
        u4 = u + dt * a3
        a4 = accel(q + dt * u3, u4, *args)
        q_next = q + dt / 6.0 * (u + 2.0 * u2 + 2.0 * u3 + u4)
        u_next = u + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        return q_next, u_next

    return rk4_step


def make_semi_implicit_euler(accel: Accel) -> Step:
    """Symplectic (semi-implicit) Euler: u ← u + dt·q̈(q, u); q ← q + dt·u. Error O(dt), one
    model evaluation per step, good long-term energy behaviour."""

    def semi_implicit_euler_step(q, u, dt, args):
        u_next = u + dt * accel(q, u, *args)
        return q + dt * u_next, u_next

    return semi_implicit_euler_step


INTEGRATORS: dict[str, Callable[[Accel], Step]] = {
    "rk4": make_rk4,
    "semi_implicit_euler": make_semi_implicit_euler,
}
