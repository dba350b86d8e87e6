"""What the predictive model can be asked, and what a solution must satisfy to count as one.

Requests outside the model's range are rejected before anything is built (the collocation would
otherwise "succeed" with nonsense, e.g. 30 m strides at 50 m/s):

* speed: finite, 0 ≤ speed ≤ :data:`MAX_SPEED` (10 m/s, above human sprinting ≈ 9.6 m/s top
  speed); 0 is quiet standing. The command line asks for a positive speed (> 0).
* height :data:`HEIGHT_RANGE` (1.0–2.3 m) and mass :data:`MASS_RANGE` (20–250 kg): the range of
  the anthropometric (Winter) scaling the body model is built from; a height of 175 means cm.
* collocation nodes per solved cycle :data:`NODES_RANGE` (4–1000; also when they follow from a
  sampling rate, :data:`RATE_RANGE_HZ`), stride duration :data:`DURATION_RANGE_S` and cost
  weights :data:`WEIGHT_RANGE`: the ranges of the command-line options (:func:`check_nodes`).

A returned solution is checked by :func:`solution_problems`: every array finite, the dynamics
residual at the solution's own samples (its nodes, with the collocation's own accelerations)
within :data:`NODE_RESIDUAL_TOL`, and the figures physically possible (peak vertical GRF per foot
≤ :data:`MAX_PEAK_GRF_BW`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Final

import numpy as np

from sspinn.errors import UserError
from sspinn.model.trajectory import first_non_finite

if TYPE_CHECKING:
    from predictive.ocp.solution import GaitSolution

#: Highest average speed, m/s, the model is asked for (human sprint top speed ≈ 9.6 m/s).
MAX_SPEED: Final = 10.0
#: Body heights (m) and masses (kg) of the anthropometric scaling.
HEIGHT_RANGE: Final = (1.0, 2.3)
MASS_RANGE: Final = (20.0, 250.0)
#: Collocation nodes per solved cycle (half or full); the NLP's memory and IPOPT's time grow with
#: them (100 nodes: a few seconds; 1000 a few minutes), and no gait needs more than 1 kHz sampling.
NODES_RANGE: Final = (4, 1000)
#: Sampling rate of the node grid (``rate_hz``), Hz.
RATE_RANGE_HZ: Final = (1.0, 1000.0)
#: Stride durations, s (a human stride takes 0.5–1.6 s; shuffling and slow walking stretch it).
DURATION_RANGE_S: Final = (0.2, 3.0)
#: Weights of cost terms given on the command line (dimensionless).
WEIGHT_RANGE: Final = (0.0, 1e6)
#: Most L-BFGS iterations of the gait generator's per-gait fine-tune (the comparison uses 200).
MAX_REFINE_ITERATIONS: Final = 5000
#: Largest Kane residual at the solution's nodes (BW for forces, BW·height for moments); IPOPT's
#: own solutions are at ~1e-9 (README), so this is loose and only fails broken solutions.
NODE_RESIDUAL_TOL: Final = 1e-4
#: Largest plausible peak vertical GRF of one foot, body weights (running impacts ≈ 2–3 BW; the
#: torque-driven model's running reaches ≈ 5 BW).
MAX_PEAK_GRF_BW: Final = 8.0


class RequestError(UserError):
    """A request the predictive model cannot answer (the message names the value and the range)."""


def check_speed(speed: float, name: str = "speed", allow_zero: bool = True) -> float:
    """``speed`` (m/s) as a float if finite and within [0 (or >0), MAX_SPEED], else RequestError."""
    try:
        value = float(speed)
    except (TypeError, ValueError):
        raise RequestError(f"{name} must be a number in m/s, got {speed!r}") from None
    low_ok = value >= 0 if allow_zero else value > 0
    if not math.isfinite(value) or not low_ok or value > MAX_SPEED:
        low = "0" if allow_zero else "above 0"
        raise RequestError(
            f"{name} {speed!r} m/s is outside what the model can do ({low} to {MAX_SPEED:g} m/s, "
            "human sprinting tops out near 9.6 m/s); give a speed in m/s"
        )
    return value


def check_body(height: float, mass: float) -> None:
    """RequestError unless height (m) and mass (kg) are finite and within the anthropometric range."""
    for name, value, (low, high), unit in (("height", height, HEIGHT_RANGE, "m"), ("mass", mass, MASS_RANGE, "kg")):
        if not isinstance(value, (int, float)) or not math.isfinite(value) or not low <= value <= high:
            hint = " (a height in cm? give metres)" if name == "height" and isinstance(value, (int, float)) and value > 100 else ""
            raise RequestError(f"body {name} {value!r} {unit} is outside the anthropometric range {low:g}–{high:g} {unit}{hint}")


def check_nodes(n_nodes: int, how: str = "n_nodes") -> int:
    """``n_nodes`` if within :data:`NODES_RANGE`, else RequestError naming ``how`` it was asked."""
    low, high = NODES_RANGE
    if not low <= n_nodes <= high:
        raise RequestError(f"{how} gives {n_nodes} collocation nodes; the solver takes {low}–{high}")
    return int(n_nodes)


def solution_problems(sol: GaitSolution) -> list[str]:
    """Why ``sol`` is not an acceptable gait (empty if it is): non-finite values, a node residual
    above NODE_RESIDUAL_TOL, or a peak GRF above MAX_PEAK_GRF_BW."""
    bad = first_non_finite({name: getattr(sol, name) for name in ("q", "u", "tau", "grf")})
    if bad is not None:
        return [f"{bad[0]} has {bad[2]} non-finite value(s)"]
    problems = []
    residual = float(np.abs(sol.node_residual()).max())
    if not residual <= NODE_RESIDUAL_TOL:
        problems.append(f"Kane residual at its own nodes {residual:.3g} exceeds {NODE_RESIDUAL_TOL:g} BW(·H)")
    peak = float(sol.grf_bw()[:, [1, 3]].max())
    if not peak <= MAX_PEAK_GRF_BW:
        problems.append(f"peak vertical GRF {peak:.3g} BW exceeds the plausible {MAX_PEAK_GRF_BW:g} BW")
    return problems
