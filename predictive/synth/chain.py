"""Dynamically exact, non-periodic gait: a chain of single-stride optimal control problems.

The periodic solutions of :mod:`predictive.ocp.collocation` repeat one gait cycle forever. Synthetic
recordings need stride-to-stride variability and speed changes while every sample still obeys
the equations of motion. :func:`simulate_chain` builds them stride by stride (receding horizon)
from the single-stride NLP of :mod:`predictive.ocp.stride_nlp` (grid, chaining, variables,
constraints, objective, buckets and IPOPT's warm start are described there):

* **Chaining.** Each stride starts from the *fixed* last sample of the previous one, so the
  recording is one backward-Euler trajectory whose Kane residual is zero to IPOPT's constraint
  tolerance at every sample (:class:`ChainResult`, a :class:`~sspinn.model.trajectory.Trajectory`).
* **Horizon.** ``1 + lookahead`` strides; only the first is kept, the next horizon starts from
  its last node, and a solved lookahead stride is the next horizon's initial guess.
* **Guesses and targets.** Otherwise the initial guess is the periodic reference
  (:class:`~predictive.synth.periodic_reference.PeriodicReference`) resampled to the stride and
  blended into the previous state, and the terminal target is the reference at the horizon's
  last stride.
* **Fallback ladder** (:data:`FALLBACKS`). One IPOPT run from one guess is one sample of a
  distribution, so a stride that fails is tried again on further rungs (IPOPT's defaults, a
  perturbed guess, a nominal or smaller change of the plan); if every rung fails the recording
  ends cleanly after its last solved stride (see :func:`simulate_chain`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Final

import numpy as np

from predictive.ocp.stride_nlp import StridePlan, StrideResult, StrideSolverCache, stride_trajectory
from predictive.synth.periodic_reference import PeriodicReference, ReferenceStride, blend_into
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import N_Q
from sspinn.model.trajectory import Trajectory, save_npz

#: IPOPT statuses accepted for a stride (the node residual is checked separately).
ACCEPTED_STATUSES: Final = ("Solve_Succeeded",)


class ChainError(RuntimeError):
    """A stride of the chain could not be solved to the required accuracy."""


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


@dataclass(kw_only=True)
class ChainResult(Trajectory):
    """A solved chain: the ground truth at every sample, a :class:`~sspinn.model.trajectory.Trajectory`
    (units of :mod:`sspinn.model.conventions`; built with keywords) with its chain's statistics.

    Attributes:
        time: (T,) sample times k·h, s (the state before the first sample is at −h).
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

    The Kane residual of the stored labels is :meth:`~sspinn.model.trajectory.Trajectory.kane_residual`.
    """

    speed: np.ndarray
    stride: np.ndarray
    q_prev: np.ndarray
    u_prev: np.ndarray
    strides: list[StrideRecord]
    h: float
    ended_early: str = ""

    SAMPLE_SHAPES = {**Trajectory.SAMPLE_SHAPES, "speed": (), "stride": ()}
    #: The arrays of the npz file (the cache's format: ``time`` is not stored, it is k·h).
    _ARRAYS = ("q", "u", "qdd", "tau", "grf", "w", "speed", "stride", "q_prev", "u_prev")

    def save(self, path: str | Path) -> Path:
        """Write ``<path>.npz`` (arrays and the per-stride statistics as a structured array),
        atomically; refused if a sample value is not finite."""
        path = Path(path).with_suffix(".npz")
        stats = np.array([tuple(asdict(r).values()) for r in self.strides], dtype=_STRIDE_DTYPE)
        arrays = {"h": self.h, "strides": stats, "ended_early": np.array(self.ended_early)}
        arrays |= {k: getattr(self, k) for k in self._ARRAYS}
        return save_npz(path, arrays, finite=self._ARRAYS, what="a stride chain")

    @classmethod
    def load(cls, path: str | Path) -> ChainResult:
        with np.load(Path(path).with_suffix(".npz")) as data:
            arrays = {k: data[k] for k in cls._ARRAYS}
            strides = [
                StrideRecord(**{name: row[name].item() for name in _STRIDE_DTYPE.names}) for row in data["strides"]
            ]
            h = float(data["h"])
            return cls(
                time=np.arange(len(arrays["q"])) * h, **arrays, strides=strides, h=h, ended_early=str(data["ended_early"])
            )


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
    start: tuple[np.ndarray, np.ndarray] | None = None,
    targets: Mapping[int, tuple[np.ndarray, np.ndarray]] | None = None,
    rest_solvers: StrideSolverCache | None = None,
) -> ChainResult:
    """Solve the strides ``plans`` one after the other (see the module docstring).

    The chain starts from the reference's periodic state at the first plan's speed (pelvis_tx 0
    before the first sample), or from the state ``start``. Each horizon holds the kept stride
    and ``lookahead`` further strides (the last plan repeated past the end).

    **Standing, starting and stopping** (:mod:`predictive.synth.start_stop`). A plan of speed 0
    is a stretch of standing (pelvis_tx ends where it began). A stride of speed > 0 after one of
    speed 0 (or first, from ``start``) starts from rest, one before a stride of speed 0 ends at
    rest: their guesses are parts of the reference cycle that begin or end with the feet side by
    side (:func:`_rest_guess`) instead of the reference blended into the previous state; the
    fallback rungs that change the plan take the start's forward speed as the previous speed.
    ``targets`` maps a plan's index to the terminal target (q, u) of the horizons that end with
    it, instead of the reference (e.g. a standing posture at rest, or the sway of standing);
    ``rest_solvers`` (same step ``h``) solve the horizons whose kept plan has speed 0, e.g. with a
    stronger terminal weight.

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
        start: (9,) q and u (m, rad; m/s, rad/s) of the state before the first sample.
        targets: plan index → (9,) q and u of its terminal target (pelvis_tx ignored).
        rest_solvers: compiled NLPs of the plans of speed 0 (default ``solvers``).

    Raises:
        ChainError: every rung failed for one of the first ``min_strides`` strides.
    """
    s = solvers.settings
    h = s.h
    if not plans:
        raise ValueError("simulate_chain needs at least one stride plan")
    if lookahead < 0:
        raise ValueError(f"lookahead must be >= 0, got {lookahead}")
    targets = dict(targets or {})
    for name, state in [("start", start)] + [(f"targets[{j}]", t) for j, t in targets.items()]:
        if state is not None and (len(state) != 2 or any(np.shape(x) != (N_Q,) or not np.all(np.isfinite(x)) for x in state)):
            raise ValueError(f"{name} must be a pair of finite (9,) arrays (q, u), got {state!r}")
    if rest_solvers is not None and rest_solvers.settings.h != h:
        raise ValueError(f"rest_solvers must have the step of solvers ({h} s), got {rest_solvers.settings.h} s")
    if any(not 0 <= j < len(plans) for j in targets):
        raise ValueError(f"targets must be indices of plans (0 … {len(plans) - 1}), got {sorted(targets)}")
    padded = list(plans) + [plans[-1]] * lookahead
    if start is None:
        first = reference.stride(plans[0].speed, plans[0].n_nodes, h, 0.0)
        q_prev, u_prev = first.q_prev, first.u_prev
        previous_speed = plans[0].speed
    else:
        q_prev, u_prev = (np.asarray(x, dtype=float).copy() for x in start)
        previous_speed = max(float(u_prev[0]), 0.0)
    q0_prev, u0_prev = q_prev.copy(), u_prev.copy()
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
            guess_q, guess_tau, target, prior_q, prior_grf = _horizon_guess(
                rung, horizon, reference, h, q_prev, carried if rung == "warm" else None, k,
                rests=_rests(padded, k, len(horizon), start is not None, targets, reference, h),
            )
            q_ref, u_ref = targets.get(k + len(horizon) - 1, (target.q[-1], target.u[-1]))
            n_try += 1
            cache = rest_solvers if rest_solvers is not None and plan.speed == 0 else solvers
            problem = cache.get([p.n_nodes for p in horizon], warm=rung == "warm")
            result = problem.solve(body, q_prev, u_prev, horizon, q_ref, u_ref, guess_q, guess_tau, prior_q, prior_grf)
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
            max_residual=float(np.abs(stride_trajectory(q, u, qdd, tau, h, body, solvers.contact).kane_residual(body)).max()),
            fallback=rung,
            planned_speed=planned.speed,
        )
        records.append(record)
        if on_stride is not None:
            on_stride(record)
    q, u, qdd, tau, speed, stride = (np.concatenate(parts) for parts in zip(*chunks))
    return ChainResult(
        **stride_trajectory(q, u, qdd, tau, h, body, solvers.contact).arrays(),
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
    rests: Mapping[int, np.ndarray | None] | None = None,
) -> tuple[np.ndarray, np.ndarray, ReferenceStride, np.ndarray, np.ndarray]:
    """Initial guess (q, τ) of a horizon on ``rung``, the terminal target (the reference stride
    of the horizon's last plan), the angle prior's target q (the guess before the ``perturbed``
    rung's perturbation) and the GRF prior's target (the reference strides' GRF, N;
    :meth:`~predictive.ocp.stride_nlp.StrideProblem.solve`'s ``prior_q`` and ``prior_grf``). ``warm``: the carried lookahead stride (if any) or the reference
    blended from the previous guess; other rungs: the reference blended into ``q_prev``, on
    ``perturbed`` with a deterministic relative perturbation of the angles and torques.

    ``rests`` maps the horizon's strides that start at rest to None and those that end at rest to
    the posture at rest; their guesses are :func:`_rest_guess` on every rung."""
    rests = rests or {}
    qs: list[np.ndarray] = []
    taus: list[np.ndarray] = []
    grfs: list[np.ndarray] = []
    x_last, q_last = q_prev[0], q_prev
    target = None
    for i, p in enumerate(horizon):
        target = reference.stride(p.speed, p.n_nodes, h, x_last)
        if i in rests:
            q, tau, grf = _rest_guess(reference, p, h, qs[-1][-1] if qs else q_prev, rests[i])
            qs.append(q)
            taus.append(tau)
            grfs.append(grf)
        elif i == 0 and carried is not None:
            qs.append(carried[0])
            taus.append(carried[1])
            grfs.append(target.grf)
        else:
            start = q_last if rung == "warm" else (q_prev if i == 0 else target.q_prev)
            qs.append(blend_into(target.q, target.q_prev, start))
            taus.append(target.tau)
            grfs.append(target.grf)
        x_last, q_last = qs[-1][-1, 0], qs[-1][-1]
    assert target is not None
    q, tau = np.vstack(qs), np.vstack(taus)
    prior = q
    if rung == "perturbed":
        rng = np.random.default_rng([index, 7])
        q = q.copy()
        q[:, 2:] += PERTURBATION * np.abs(q[:, 2:]).max(axis=0) * rng.standard_normal(q[:, 2:].shape)
        tau = tau * (1 + PERTURBATION * rng.standard_normal(tau.shape))
    return q, tau, target, prior, np.vstack(grfs)


#: Parts of the reference cycle (phases from the stride boundary, which lies 0.12 of the cycle
#: before the right heel strike: left single support when walking,
#: :data:`~predictive.synth.periodic_reference.DEFAULT_BOUNDARY`) that the guesses of a stride from
#: rest and of a stride to rest are stretched over: from rest, the cycle from the double support
#: after the right heel strike to the next boundary (the left foot steps first); to rest, from the
#: boundary to the left foot's mid-swing, where the feet are side by side. Measured on a 1.2 m/s
#: walker's first stride at 0.25 × 1.2 m/s from quiet standing: from phase 0.2 the pelvis never
#: moved backwards faster than 0.02 m/s and the vertical GRF stayed within 0.63–1.41 BW
#: (85 IPOPT iterations); from 0.4 it stepped back at up to 0.33 m/s (at 0.35 × 1.2 m/s) with a
#: near-flight (0.02 BW) and 2.7 BW landing.
INITIATION_PHASES: Final = (0.2, 1.0)
TERMINATION_PHASES: Final = (0.0, 0.45)


def _rests(
    plans: Sequence[StridePlan],
    k: int,
    n: int,
    started: bool,
    targets: Mapping[int, tuple[np.ndarray, np.ndarray]],
    reference: PeriodicReference,
    h: float,
) -> dict[int, np.ndarray | None]:
    """The strides of the horizon of ``n`` strides from plan ``k`` that start at rest (→ None:
    speed > 0 after a plan of speed 0, or the first plan of a chain ``started`` from a given state)
    or end at rest (→ the posture at rest: its target, else the reference at 0 m/s; speed > 0
    before a plan of speed 0)."""
    out: dict[int, np.ndarray | None] = {}
    for i in range(n):
        j = k + i
        if plans[j].speed == 0:
            continue
        if (j == 0 and started) or (j > 0 and plans[j - 1].speed == 0):
            out[i] = None
        elif j + 1 < len(plans) and plans[j + 1].speed == 0:
            out[i] = targets[j][0] if j in targets else reference.stride(0.0, plans[j].n_nodes, h).q[-1]
    return out


def _rest_guess(
    reference: PeriodicReference, plan: StridePlan, h: float, q_prev: np.ndarray, q_rest: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Initial guess (q, τ) and the GRF prior's target (N) of a stride that starts at rest
    (``q_rest`` None) or ends at rest in
    the posture ``q_rest``: the reference at the plan's speed over :data:`INITIATION_PHASES` or
    :data:`TERMINATION_PHASES`, its angles blended from ``q_prev`` or into ``q_rest`` over a
    quarter of the stride, and pelvis_tx accelerating from rest (x ∝ s², s the fraction of the
    stride) or decelerating to rest (x ∝ 1 − (1 − s)²), so the stride still advances
    ``plan.speed`` × its duration.

    (The reference stride blended into the standing state over :func:`blend_into`'s 5 nodes,
    without the standing gait in the reference, started walking at 1.3 m/s with a backward hop:
    a flight phase and a 3.4 BW landing.)"""
    n = plan.n_nodes
    start = q_rest is None
    target = reference.stride(plan.speed, n, h, q_prev[0], INITIATION_PHASES if start else TERMINATION_PHASES)
    s = np.arange(1, n + 1) / n
    width = n / 4
    if q_rest is None:
        q = blend_into(target.q, target.q_prev, q_prev, width)
        q[:, 0] = q_prev[0] + plan.speed * n * h * s**2
    else:
        q = target.q.copy()
        dq = q_rest - target.q[-1]
        q[:, 1:] += dq[None, 1:] * np.exp(-np.arange(n - 1, -1, -1) / width)[:, None]
        q[:, 0] = q_prev[0] + plan.speed * n * h * (1 - (1 - s) ** 2)
    return q, target.tau, target.grf
