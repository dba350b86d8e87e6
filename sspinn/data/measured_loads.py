"""Measured ground reaction loads as inputs of the model's inverse dynamics.

A force plate measures, per foot, a force and a moment about a fixed point; the model applies
each foot's force at a point of its heel–toe line (``w``). :func:`grf_inputs` turns measured loads
into the ``grf`` and ``w`` of :func:`sspinn.model.dynamics.inverse_dynamics`, choosing the point
whose line of action reproduces the measured moment (:func:`contact_fraction_for_load`): the
applied load is then exact, free moment included. Used by synthetic quiet standing
(:mod:`predictive.synth.standing`) and by the inverse-dynamics checks against real data
(``benchmarks/accuracy/inverse_dynamics.py``).
"""

from __future__ import annotations

from typing import Final

import numpy as np

from sspinn.model.body import BodyParameters
from sspinn.model.conventions import N_Q, SIDES
from sspinn.model.kinematics import point_index, point_kinematics

#: Vertical force below which a foot is taken to be off the ground, N.
CONTACT_THRESHOLD_N: Final[float] = 20.0


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of the 2-D cross product a × b."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def contact_fraction_for_load(toe: np.ndarray, heel: np.ndarray, force: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """Position w of the application point on the heel–toe line that reproduces a measured load.

    The model applies a force F at ``P(w) = toe + w·(heel − toe)`` (global, m). A measured load
    (F, M_O), with M_O the z-moment (N·m, CCW seen from the right) about the global origin, is
    reproduced when ``P(w) × F = M_O``; this linear equation gives
    ``w = (M_O − toe × F) / ((heel − toe) × F)``. It is the intersection of the heel–toe line
    with the force's line of action (the 2×2 system ``toe + w·d = C + s·F`` for any point C on
    that line, e.g. the centre of pressure). w is any real number (the line extends beyond the
    foot); it is undefined when F is parallel to the heel–toe line (in practice, F ≈ 0).

    Args:
        toe, heel: (..., 2) global positions of the model's toe and heel points, m.
        force: (..., 2) force on the foot, N. moment: (...) M_O, N·m.
    """
    d = np.asarray(heel) - np.asarray(toe)
    return (np.asarray(moment) - _cross(np.asarray(toe), force)) / _cross(d, force)


def grf_inputs(
    q: np.ndarray,
    p: BodyParameters,
    loads: dict[str, np.ndarray],
    threshold: float = CONTACT_THRESHOLD_N,
) -> tuple[np.ndarray, np.ndarray]:
    """``grf`` (n, 4) and ``w`` (n, 2) for :func:`sspinn.model.dynamics.inverse_dynamics`.

    Args:
        q: (n, 9) generalized coordinates (only positions matter here).
        p: body parameters (heel and toe of each foot).
        loads: per side ("r"/"l") an (n, 3) array [F_x, F_y, M_O] of the load on that foot
            (N, N, N·m about the global origin); missing sides get no load.
        threshold: vertical force (N) below which the foot is unloaded (w = 0.5, F = 0).
    """
    n = q.shape[0]
    zeros = np.zeros((n, N_Q))
    pk = point_kinematics(q, zeros, zeros, np.zeros((n, 2)), p)
    grf = np.zeros((n, 4))
    w = np.full((n, 2), 0.5)
    for k, side in enumerate(SIDES):
        if side not in loads:
            continue
        load = np.asarray(loads[side], dtype=float)
        on = load[:, 1] > threshold
        toe = pk[on, point_index(f"toe_{side}"), :2]
        heel = pk[on, point_index(f"heel_{side}"), :2]
        w_on = contact_fraction_for_load(toe, heel, load[on, :2], load[on, 2])
        if not np.all(np.isfinite(w_on)):
            raise ValueError(f"foot {side}: force parallel to the heel–toe line, contact point undefined")
        grf[on, 2 * k : 2 * k + 2] = load[on, :2]
        w[on, k] = w_on
    return grf, w
