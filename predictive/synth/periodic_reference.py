"""Periodic gaits as references of single strides: resampled to any speed, duration and phase.

A chain of stride OCPs (:mod:`predictive.synth.chain`) needs, for each stride of any speed and
node count, an initial guess and a terminal target. :class:`PeriodicReference` holds the periodic
gaits of one body at a few nominal speeds (:mod:`predictive.synth.gait_library`), each on the
normalised phase (:class:`CycleShape`), blends them linearly in speed and stretches the cycle to
the stride (:meth:`PeriodicReference.stride`); :func:`blend_into` lets a reference stride continue
from the chain's actual previous state.

**Stride boundary.** Phase 0 of the references (the stride boundary) lies 12 % of the cycle
before the right foot's contact onset (:data:`DEFAULT_BOUNDARY`): mid-flight when running, left
single support when walking. A boundary at an impact made the terminal velocity target very
sensitive to timing (about 30 % more iterations when running).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np

from predictive.ocp.solution import GaitSolution

#: Stride boundary relative to the right foot's contact onset, fraction of the cycle.
DEFAULT_BOUNDARY: Final = -0.12


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

    @classmethod
    def at_rest(cls, rest: ReferenceStride, duration: float) -> CycleShape:
        """Standing still as a "cycle" at 0 m/s of ``duration`` (s): the q (pelvis_tx 0), τ and
        GRF of ``rest``'s first node at every phase, no motion."""
        phase = np.array([0.0, 0.5])
        q = np.tile(rest.q[0], (2, 1))
        q[:, 0] = 0.0
        return cls(0.0, duration, phase, q, np.zeros_like(q), np.tile(rest.tau[0], (2, 1)), np.tile(rest.grf[0], (2, 1)))

    def at(self, phase: np.ndarray) -> tuple[np.ndarray, ...]:
        """(q, u_phase, τ, GRF) at the phases (periodic linear interpolation)."""
        phase = np.asarray(phase, dtype=float)

        def interp(y: np.ndarray) -> np.ndarray:
            return np.stack([np.interp(phase, self.phase, y[:, i], period=1.0) for i in range(y.shape[1])], axis=1)

        return interp(self.q), interp(self.u_phase), interp(self.tau), interp(self.grf)


class PeriodicReference:
    """Periodic gaits of one body at a few nominal speeds, blended linearly in speed.

    :meth:`stride` gives the guess and the terminal target of a stride of any speed and node
    count (speeds outside the nominal range use the nearest nominal gait). With ``rest`` (a
    standing state: its q, τ and GRF at one node, :class:`ReferenceStride`) standing still is the
    gait at 0 m/s (:meth:`CycleShape.at_rest`), so strides slower than the slowest gait blend
    towards standing: shorter steps at the stride duration of the slowest gait, the targets of
    the strides that start and end walking (:mod:`predictive.synth.start_stop`; without it the
    first stride from rest had to end in the posture of the slowest gait, with its full step
    length, and stepped backwards first). Every cycle is
    rotated so that its phase 0 (the stride boundary) lies ``boundary`` (fraction of the cycle)
    after the right foot's contact onset: the default, 0.12 before it, is in the flight phase when
    running and in the left single support when walking, where the state changes smoothly
    (a boundary at an impact makes the terminal target of the velocities very sensitive to timing).
    """

    def __init__(
        self, solutions: Sequence[GaitSolution], boundary: float = DEFAULT_BOUNDARY, rest: ReferenceStride | None = None
    ) -> None:
        if not solutions:
            raise ValueError("PeriodicReference needs at least one periodic solution")
        shapes = [CycleShape.from_solution(s, boundary) for s in solutions]
        if rest is not None:
            shapes.append(CycleShape.at_rest(rest, min(shapes, key=lambda c: c.speed).duration))
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

    def stride(
        self, speed: float, n_nodes: int, h: float, x_prev: float = 0.0, phases: tuple[float, float] = (0.0, 1.0)
    ) -> ReferenceStride:
        """Reference stride of ``n_nodes`` nodes at ``speed`` (m/s), step ``h`` (s), after a
        previous state at pelvis_tx = ``x_prev`` (m).

        The reference cycle is stretched to the stride: node k lies at phase k/n, so the last
        node is the state just before the next stride's boundary. With ``phases`` = (φ0, φ1)
        only that part of the cycle is stretched to the stride (node k at φ0 + (φ1 − φ0)·k/n;
        the guesses of the strides that start or end at rest, :mod:`predictive.synth.chain`).

        Returns:
            The nodes' q, u, τ and GRF and the state before the first node on the same reference
            (pelvis_tx = x_prev).
        """
        T = n_nodes * h
        phase0, phase1 = phases
        if not 0.0 <= phase0 < phase1 <= 1.0:
            raise ValueError(f"phases must satisfy 0 <= phase0 < phase1 <= 1, got {phases}")
        phase = phase0 + np.arange(-1, n_nodes) * h / T * (phase1 - phase0)
        q, u_phase, tau, grf = self._blend(speed, phase)
        q[:, 0] += x_prev - q[0, 0] + speed * h * np.arange(n_nodes + 1)
        u = u_phase * (phase1 - phase0) / T
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


def blend_into(q: np.ndarray, q_ref_prev: np.ndarray, q_prev: np.ndarray, width: float = 5.0) -> np.ndarray:
    """The reference q shifted so that it continues from ``q_prev`` instead of ``q_ref_prev``,
    the offset decaying over ``width`` nodes (pelvis_tx is already continuous)."""
    dq = q_prev - q_ref_prev
    dq[0] = 0.0
    return q + dq[None, :] * np.exp(-np.arange(1, len(q) + 1) / width)[:, None]
