"""Equations of motion of the sagittal model for NumPy, torch and CasADi inputs alike.

Every function dispatches on the type of ``q`` (see :mod:`sspinn.model.backends`) and evaluates the
same generated code (``sspinn/model/_generated/model_expr.py``). Shapes: vectors along the last axis
(q, u, qdd: 9; tau: 6; grf: 4 = [Fx_r, Fy_r, Fx_l, Fy_l]; w: 2; body parameters p: 41; contact
parameters c: 7) with any broadcastable leading batch dimensions for NumPy and torch; single
column vectors for CasADi. Units and signs: :mod:`sspinn.model.conventions`.

``p`` may be a :class:`~sspinn.model.body.BodyParameters` and ``c`` a
:class:`~sspinn.model.contact.ContactParameters`; they are converted to vectors of ``q``'s kind.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sspinn.model._generated import model_expr as gen
from sspinn.model.backends import backend_name, ops_for
from sspinn.model.body import N_PARAMETERS, BodyParameters
from sspinn.model.contact import N_CONTACT_PARAMETERS, ContactParameters
from sspinn.model.conventions import N_GRF, N_Q, N_TAU

Array = Any  # numpy.ndarray | torch.Tensor | casadi.SX/MX/DM


class StateError(ValueError):
    """Raised for inputs of the wrong shape or with NaN/inf values."""


def as_vector(value: Any, like: Array) -> Array:
    """Parameters (dataclass or array) as an array of ``like``'s kind, dtype and device."""
    if isinstance(value, (BodyParameters, ContactParameters)):
        value = value.vector()
    kind = backend_name(like)
    if kind == "torch":
        import torch

        return torch.as_tensor(value, dtype=like.dtype, device=like.device)
    if kind == "casadi":
        import casadi as ca

        return value if backend_name(value) == "casadi" else ca.DM(np.asarray(value, dtype=float))
    return np.asarray(value, dtype=np.float64)


def check_input(name: str, x: Array, size: int) -> Array:
    """Check the last-axis size (all backends) and finiteness (NumPy) of one input."""
    kind = backend_name(x)
    if kind == "casadi":
        if x.numel() != size:
            raise StateError(f"{name}: expected {size} elements, got shape {x.shape}")
        return x
    shape = tuple(x.shape) if hasattr(x, "shape") else np.shape(x)
    if len(shape) == 0 or shape[-1] != size:
        raise StateError(f"{name}: expected last axis of size {size}, got shape {shape}")
    if kind == "numpy":
        x = np.asarray(x, dtype=np.float64)
        if not np.all(np.isfinite(x)):
            bad = np.argwhere(~np.isfinite(x))[0]
            raise StateError(f"{name}: non-finite value {x[tuple(bad)]} at index {tuple(int(i) for i in bad)}")
    return x


def prepare_inputs(q: Array, p: Any, **vectors: tuple[Array, int]) -> tuple[Any, Array, Array, dict[str, Array]]:
    """Validate q, the body parameters p (may be None) and named (value, size) vectors."""
    q = check_input("q", q, N_Q)
    if p is not None:
        p = check_input("p (body parameters)", as_vector(p, q), N_PARAMETERS)
    out = {name: check_input(name, as_vector(x, q), n) for name, (x, n) in vectors.items()}
    return ops_for(q), q, p, out


def mass_matrix(q: Array, p: Any) -> Array:
    """M(q), shape (..., 9, 9), kg / kg·m / kg·m² per coordinate pair."""
    ops, q, p, _ = prepare_inputs(q, p)
    return gen.mass_matrix(ops, q, p)


def forcing(q: Array, u: Array, tau: Array, grf: Array, w: Array, p: Any) -> Array:
    """f(q, u, τ, F, w) with M·q̈ = f, shape (..., 9)."""
    ops, q, p, v = prepare_inputs(q, p, u=(u, N_Q), tau=(tau, N_TAU), grf=(grf, N_GRF), w=(w, 2))
    return gen.forcing(ops, q, v["u"], v["tau"], v["grf"], v["w"], p)


def kane_residual(q: Array, u: Array, qdd: Array, tau: Array, grf: Array, w: Array, p: Any) -> Array:
    """r = M(q)·q̈ − f(q, u, τ, F, w), shape (..., 9) (N for pelvis_tx/ty, N·m otherwise)."""
    ops, q, p, v = prepare_inputs(q, p, u=(u, N_Q), qdd=(qdd, N_Q), tau=(tau, N_TAU), grf=(grf, N_GRF), w=(w, 2))
    return gen.kane_residual(ops, q, v["u"], v["qdd"], v["tau"], v["grf"], v["w"], p)


def forward_dynamics(q: Array, u: Array, tau: Array, grf: Array, w: Array, p: Any) -> Array:
    """q̈ = M(q)⁻¹ f(q, u, τ, F, w), shape (..., 9).

    One generated function (``model_expr.forward_dynamics``): M's upper triangle and f from one
    common-subexpression elimination, then an L·D·Lᵀ solve unrolled over the nonzeros of M's
    factor (:func:`sspinn.model.codegen.mass_matrix_solve_lines`) — elementwise operations only,
    so batches need no batched LU call and ``torch.compile`` fuses the whole evaluation; the
    numba stepper solves with the same formulas.
    """
    ops, q, p, v = prepare_inputs(q, p, u=(u, N_Q), tau=(tau, N_TAU), grf=(grf, N_GRF), w=(w, 2))
    return gen.forward_dynamics(ops, q, v["u"], v["tau"], v["grf"], v["w"], p)


def inverse_dynamics(q: Array, u: Array, qdd: Array, grf: Array, w: Array, p: Any) -> tuple[Array, Array]:
    """Joint torques that produce q̈ given the external forces.

    Because τ_j is the generalized force of joint coordinate j (see conventions), the Kane
    residual without torques is r(τ=0) = [r_pelvis, τ]. Returns ``(tau, pelvis_residual)``:
    tau (..., 6) in N·m and the residual generalized forces on the pelvis coordinates (..., 3)
    (N, N, N·m), which vanish for motion consistent with the external forces.
    """
    zeros_tau = _zeros_like_vector(q, N_TAU)
    r = kane_residual(q, u, qdd, zeros_tau, grf, w, p)
    return take_last(r, slice(3, None)), take_last(r, slice(0, 3))


def energy(q: Array, u: Array, p: Any) -> tuple[Array, Array]:
    """(kinetic, potential) energy in J; potential is zero with every centre of mass at y = 0."""
    ops, q, p, v = prepare_inputs(q, p, u=(u, N_Q))
    e = gen.energy(ops, q, v["u"], p)
    return take_last(e, 0), take_last(e, 1)


def contact_fraction(q: Array, c: Any = None) -> Array:
    """w per foot (..., 2): position of the contact point from toe (0) to heel (1)."""
    c = ContactParameters() if c is None else c
    ops, q, _, v = prepare_inputs(q, None, c=(c, N_CONTACT_PARAMETERS))
    return gen.contact_fraction(ops, q, v["c"])


def contact_forces(q: Array, u: Array, p: Any, c: Any = None, mu_hat: Array | None = None) -> tuple[Array, Array]:
    """Ground reaction forces (..., 4) in N and contact fractions w (..., 2).

    With ``mu_hat`` (..., 2) the learned SSPINNpose friction law is used, else the
    forward-simulation law (see :mod:`sspinn.model.contact`).
    """
    c = ContactParameters() if c is None else c
    ops, q, p, v = prepare_inputs(q, p, u=(u, N_Q), c=(c, N_CONTACT_PARAMETERS))
    w = gen.contact_fraction(ops, q, v["c"])
    if mu_hat is None:
        return gen.contact_forces_simulation(ops, q, v["u"], p, v["c"]), w
    mu_hat = check_input("mu_hat", as_vector(mu_hat, q), 2)
    return gen.contact_forces_learned(ops, q, v["u"], mu_hat, p, v["c"]), w


def contact_from_ankles(q: Array, u: Array, ankle: Array, mu_hat: Array, p: Any, c: Any = None) -> Array:
    """SSPINNpose's ground contact from separately estimated ankle kinematics.

    ``ankle`` (..., 8) = [x, y, vx, vy] of the right then left ankle (m, m/s, global); the foot
    angle and rate come from q, u; ``mu_hat`` (..., 2) is the learned friction factor. Returns
    (..., 2, 6): per foot [Fx, Fy, x, y, vx, vy] — the learned-friction GRF (N) and the contact
    point's position and (material) velocity. With ``ankle`` equal to the forward kinematics the
    forces equal :func:`contact_forces` with ``mu_hat``.
    """
    c = ContactParameters() if c is None else c
    ops, q, p, v = prepare_inputs(q, p, u=(u, N_Q), ankle=(ankle, 8), mu_hat=(mu_hat, 2), c=(c, N_CONTACT_PARAMETERS))
    return gen.contact_from_ankles(ops, q, v["u"], v["ankle"], v["mu_hat"], p, v["c"])


def forward_dynamics_with_contact(q: Array, u: Array, tau: Array, p: Any, c: Any = None) -> tuple[Array, Array]:
    """q̈ and GRF (..., 4) under the forward-simulation contact model."""
    grf, w = contact_forces(q, u, p, c)
    return forward_dynamics(q, u, tau, grf, w, p), grf


def take_last(x: Array, i: int | slice) -> Array:
    """``x[..., i]`` for NumPy/torch, ``x[i]`` for CasADi column vectors."""
    return x[i] if backend_name(x) == "casadi" else x[..., i]


def _zeros_like_vector(q: Array, n: int) -> Array:
    kind = backend_name(q)
    if kind == "torch":
        return q.new_zeros(*q.shape[:-1], n)
    if kind == "casadi":
        import casadi as ca

        return ca.DM.zeros(n, 1)
    return np.zeros(np.shape(q)[:-1] + (n,))
