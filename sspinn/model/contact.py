"""Foot–ground contact model (SSPINNpose's smooth spring-damper, plus a forward-simulation variant).

Per foot, one ground reaction force (F_x, F_y) acts at a contact point on the heel–toe line:

* **Contact point**: ``P = toe + w·(heel − toe)`` with ``w = (tanh(k_α·α) + 1)/2``, where α is the
  foot's global angle (positive: toes up) and ``k_α = 7 /rad``. Toes up (heel strike) puts the
  force at the heel, toes down (push-off) at the toe.
* **Vertical force**: a spring-damper on the smooth penetration depth
  ``d = softplus(−β·y)/β`` (m, ≈ max(−y, 0) with a transition width of 1/β), ::

      F_y = BW · k · d · (1 − c · ẏ)

  with k = 100 BW/m, β = 300 /m and c = 0.75 s/m; y and ẏ are the contact point's height and
  vertical velocity. F_y is zero (to within e^{−β y}) above the ground.
* **Horizontal force, learned** (SSPINNpose): ``F_x = μ_max · tanh(μ̂) · F_y`` with μ_max = 0.5 and
  μ̂ a network output (the friction factor).
* **Horizontal force, forward simulation**: a regularised Coulomb law that opposes sliding of the
  contact point, ``F_x = −μ · tanh(ẋ / v_s) · F_y`` with μ = 0.8 and v_s = 0.05 m/s. It needs no
  learned input; the smaller v_s, the stiffer (and the smaller the integration step it needs:
  with v_s = 0.05 m/s explicit RK4 was stable only below ~1.3e-4 s, with v_s = 0.2 m/s below
  ~5e-4 s, measured in ``tests/test_dynamics.py``'s scenario).

The formulas are written once, here, as SymPy expressions; :mod:`sspinn.model.codegen` generates them
into every backend together with the equations of motion.
"""

from __future__ import annotations

from dataclasses import astuple, dataclass, fields
from typing import Final

import numpy as np
import sympy as sp

from sspinn.model.body import ParameterError, _check_finite


class softplus(sp.Function):  # noqa: N801 (SymPy function names are lower case)
    """softplus(x) = log(1 + exp(x)); generated as a numerically stable backend primitive."""

    nargs = 1

    def fdiff(self, argindex: int = 1) -> sp.Expr:
        x = self.args[0]
        return 1 / (1 + sp.exp(-x))


@dataclass(frozen=True)
class ContactParameters:
    """Parameters of the contact model (see the module docstring for the formulas).

    Attributes:
        stiffness: k, body weights per metre of penetration (BW/m).
        transition: β, sharpness of the softplus penetration, 1/m.
        damping: c, s/m (Hunt–Crossley-like factor 1 − c·ẏ).
        friction_max: μ_max of the learned friction law (dimensionless).
        friction: μ of the forward-simulation friction law (dimensionless).
        slip_velocity: v_s of the forward-simulation friction law, m/s.
        sharpness: k_α of the contact-point placement, 1/rad.
    """

    stiffness: float = 100.0
    transition: float = 300.0
    damping: float = 0.75
    friction_max: float = 0.5
    friction: float = 0.8
    slip_velocity: float = 0.05
    sharpness: float = 7.0

    def __post_init__(self) -> None:
        for f in fields(self):
            _check_finite(f"contact {f.name}", getattr(self, f.name), positive=f.name != "damping")
        if self.damping < 0:
            raise ParameterError(f"contact damping must be >= 0, got {self.damping}")

    def vector(self) -> np.ndarray:
        return np.array(astuple(self), dtype=np.float64)


#: Order of the contact-parameter vector.
CONTACT_PARAMETERS: Final[tuple[str, ...]] = tuple(f.name for f in fields(ContactParameters))
N_CONTACT_PARAMETERS: Final[int] = len(CONTACT_PARAMETERS)


def contact_fraction(foot_angle: sp.Expr, sharpness: sp.Expr) -> sp.Expr:
    """w ∈ (0, 1): the contact point's position from toe (0) to heel (1)."""
    return (sp.tanh(sharpness * foot_angle) + 1) / 2


def vertical_force(y: sp.Expr, vy: sp.Expr, body_weight: sp.Expr, c: dict[str, sp.Expr]) -> sp.Expr:
    """F_y (N) of the smooth spring-damper, from contact-point height y (m) and velocity ẏ (m/s)."""
    beta = c["transition"]
    penetration = softplus(-beta * y) / beta
    return body_weight * c["stiffness"] * penetration * (1 - c["damping"] * vy)


def friction_learned(fy: sp.Expr, mu_hat: sp.Expr, c: dict[str, sp.Expr]) -> sp.Expr:
    """F_x (N) of SSPINNpose: μ_max·tanh(μ̂)·F_y."""
    return c["friction_max"] * sp.tanh(mu_hat) * fy


def friction_simulation(fy: sp.Expr, vx: sp.Expr, c: dict[str, sp.Expr]) -> sp.Expr:
    """F_x (N) of the forward-simulation law: −μ·tanh(ẋ/v_s)·F_y."""
    return -c["friction"] * sp.tanh(vx / c["slip_velocity"]) * fy
