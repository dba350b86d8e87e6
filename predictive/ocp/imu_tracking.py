"""IMU tracking of an averaged stride: the label-free optimal-control baseline of SSPINNpose.

:func:`solve_imu_tracking` (Dorschky et al. 2019, J Biomech 95:109278) tracks the sagittal
signals (acc_x, acc_y, gyr_z) of every IMU of one averaged stride with virtual IMUs, plus effort,
over a full periodic cycle with the speed free (:func:`~predictive.ocp.tracking.solve_tracking`).

Scales: the across-trial standard deviation per sample when the averaged stride comes with
``variance.csv``, else each channel's standard deviation over the cycle. Weights: IMU channels 1,
effort 0.01, w_acc 0.001 (the predictive w_acc = 0.1 penalises the very accelerations that are
tracked). Initial guess: the predictive gait at a label-free speed guess from the stride duration
(:func:`speed_from_stride_duration`) on the same grid, **rolled to start at its right heel strike**
like the data (:func:`roll_cycle`; unrolled, its heel strike lay at 5–33 % of the cycle and IPOPT
ended in poor local optima, e.g. standing). Speed continuation: one solve at the fixed guessed
speed, then the speed is freed (without it, a walking guess sometimes drifted to standing). By
default a multi-start over three speed guesses (:data:`DEFAULT_SPEED_FACTORS`): among the
successful starts whose right heel strike lies at the data's first sample (± 5 % of the cycle; an
averaged stride is cut there), the lowest objective wins (label-free). The starts run from the
middle speed outwards, the slower first, and stop once two of those agree on the objective
(``agree_rtol``, the rule of the predictive multi-start): a start that is not run costs neither its
predictive guess nor its tracking. With these, starts from
0.9–1.5 m/s reached the same solution on the real data; the data-free
:meth:`~predictive.ocp.collocation.PredictiveGaitProblem.generic_guess` is less robust.

Cost: building an NLP's IPOPT solver (CasADi's exact derivatives of the whole collocation
problem) costs about as much as an IPOPT run, and every predictive guess is a multi-start of its
own. By default (``starts="shared"``) the guesses come from one predictive NLP by speed
continuation and all starts share one tracking NLP and solver; cheaper guesses were tried on the
real walking stride and did not pay: 25 instead of 50 nodes per half cycle, or the middle speed's
gait for every start, cost more tracking iterations than they saved or ended one start in
another optimum; a 25-node middle-speed multi-start refined on 50 nodes took as long (11.9 vs
11.6 s of guesses, 9.4 vs 6.9 s of tracking IPOPT); starting the middle speed from the shipped
1.3 m/s walking gait (``configs/agents/gaits/walk_1.3.npz``, 134–150 instead of 178–280
iterations) saved guess time but cost more in tracking (IPOPT 8.6 vs 6.5 s on the real stride,
20.7 vs 15.8 s on the synthetic one). On two cores a worker process solves part of the guesses
while this process solves the rest and builds the tracking NLP (:class:`ContinuedGuesses`,
:mod:`predictive.ocp.guess_worker`; the same results). ``benchmarks/speed/bench_imu_tracking.py``
times each step: every start in one process, the early stop, the worker.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from multiprocessing.pool import AsyncResult
from pathlib import Path
from typing import Any, Literal

import numpy as np

from predictive.ocp.collocation import (
    DEFAULT_STARTS,
    OCPSettings,
    PredictiveGaitProblem,
    objectives_agree,
    solve_predictive,
)
from predictive.ocp.guess_worker import FORK, GuessWorker, continued_gait, default_workers
from predictive.ocp.solution import GaitSolution
from predictive.ocp.tracking import TrackingResult, track_starts
from predictive.ocp.tracking_data import averaged_stride_scales, signals_from_recording, stride_duration
from sspinn.data.dataset import Recording
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.conventions import IMU_CHANNELS, imu_columns


def speed_from_stride_duration(duration: float) -> float:
    """A label-free speed guess (m/s) from the stride duration (s): the inverse of
    :func:`predictive.ocp.generic_gait.typical_stride_duration` (T = 1.4 − 0.2·v), clipped to 0.5–3.5."""
    return float(np.clip((1.4 - duration) / 0.2, 0.5, 3.5))


def predictive_guess(
    speed: float,
    duration: float,
    body: BodyParameters,
    *,
    n_nodes: int = 50,
    cache_dir: str | Path | None = None,
    verbose: bool = False,
) -> GaitSolution:
    """The predictive (effort-minimising, symmetric half-cycle) gait at ``speed`` (m/s) with the
    stride ``duration`` (s), used as initial guess for tracking. With ``cache_dir`` the solution
    is stored there and reused when the speed, duration, node count and body match."""
    path = _cache_path(cache_dir, "predictive", speed, duration, body, n_nodes)
    cached = _load_cached(path, speed, duration, body, n_nodes)
    if cached is not None:
        return cached
    sol = solve_predictive(speed, body, n_nodes=n_nodes, duration=duration, verbose=verbose)
    if path is not None:
        sol.save(path)
    return sol


#: Relative tolerance on the objective at which two starts of a predictive multi-start agree.
AGREE_RTOL: float = 1e-4


class ContinuedGuesses:
    """The predictive gaits of :func:`predictive_guess` at several ``speeds`` (m/s) and one stride
    ``duration`` (s), solved on demand by speed continuation on one NLP: ``chain[i]`` is the gait
    at ``speeds[i]``, computed the first time it is asked for (with the gaits it continues from).

    The median speed comes from the data-free multi-start
    (:data:`~predictive.ocp.collocation.DEFAULT_STARTS`, stopped once two starts agree on the
    objective within :data:`AGREE_RTOL`), every other speed from the solution at its neighbour
    towards the median (:func:`~predictive.ocp.guess_worker.continued_gait`: one IPOPT run with
    the monotone barrier, the speed fixed by its bounds; a failed continuation falls back to the
    predictive multi-start at that speed). One problem and its solvers serve all speeds, so the
    NLP is built once. Cached in ``cache_dir`` like :func:`predictive_guess` (under their own
    names). ``solve_time_s``: the seconds this process spent solving or waiting for them so far.

    With ``workers`` 2 (where the platform can fork), one worker process
    (:class:`~predictive.ocp.guess_worker.GuessWorker`, started at once) solves the multi-start's
    first start while this process solves its second (and whatever the caller does meanwhile,
    e.g. build the tracking NLP), the first continuation from that start on speculation, and,
    once the median speed's gait is known, the continuations ahead of their use, in
    :meth:`trial_order`. The results are those of ``workers`` 1. :meth:`close` (or ``with``) stops the worker.

    Measured (50 nodes per half cycle, the continuation from the median to × 0.85 and × 1.2, on
    the real walking stride and a synthetic 1.2 s one): with IPOPT's adaptive barrier the two
    runs took 322 and 457 iterations per stride, with the monotone barrier from 0.1 277 and 290
    (and it reached the lower of two optima at 0.85 m/s on the 1.2 s stride); in the five
    predictive multi-starts measured there (1.0–1.47 m/s) the third start never found a lower
    objective than two agreeing ones."""

    def __init__(
        self,
        speeds: Sequence[float],
        duration: float,
        body: BodyParameters,
        *,
        n_nodes: int = 50,
        cache_dir: str | Path | None = None,
        verbose: bool = False,
        workers: int = 1,
    ) -> None:
        self.speeds = [float(v) for v in speeds]
        self.duration, self.body, self.n_nodes, self.verbose = float(duration), body, n_nodes, verbose
        self.order = [int(i) for i in np.argsort(self.speeds, kind="stable")]  # slowest first
        self.anchor = self.order[(len(self.order) - 1) // 2]
        self.solve_time_s = 0.0
        self.settings = OCPSettings(speed=self.speeds[self.anchor], n_nodes=n_nodes, duration=self.duration)
        self._paths = [_cache_path(cache_dir, "continued", v, duration, body, n_nodes) for v in self.speeds]
        self._solutions: list[GaitSolution | None] = [
            _load_cached(p, v, duration, body, n_nodes) for p, v in zip(self._paths, self.speeds)
        ]
        self._problem: PredictiveGaitProblem | None = None
        self._worker: GuessWorker | None = None
        self._pending: dict[int, AsyncResult[GaitSolution]] = {}
        self._speculative: dict[int, AsyncResult[GaitSolution]] = {}  # continued from the worker's start
        if workers >= 2 and FORK and any(sol is None for sol in self._solutions):
            self._worker = GuessWorker(self.settings, body)
            if self._solutions[self.anchor] is None:
                self._pending[self.anchor] = self._worker.solve_start(0)
                first = next((j for j in self.trial_order()[1:2] if self._solutions[j] is None), None)
                if first is not None and self.neighbour(first) == self.anchor:
                    self._speculative[first] = self._worker.continued_from_start(0, self.speeds[first])
        #: processes solving the guesses: 2 with a worker (none where every gait was cached), else 1
        self.processes = 1 if self._worker is None else 2

    def __len__(self) -> int:
        return len(self.speeds)

    def __getitem__(self, i: int) -> GaitSolution:
        sol = self._solutions[i]
        if sol is None:
            neighbour = self.neighbour(i)
            prev = None if neighbour is None else self[neighbour]  # solved before the timer starts
            t0 = time.perf_counter()
            sol = self._solve(i, prev)
            self.solve_time_s += time.perf_counter() - t0
            self._solutions[i] = sol
            path = self._paths[i]
            if path is not None and not path.with_name(path.name + ".npz").exists():
                sol.save(path)
            self._hand_out()
        return sol

    def neighbour(self, i: int) -> int | None:
        """The speed whose gait ``speeds[i]`` continues from: its neighbour towards the median
        (None for the median itself)."""
        rank, anchor_rank = self.order.index(i), self.order.index(self.anchor)
        if rank == anchor_rank:
            return None
        return self.order[rank + 1 if rank < anchor_rank else rank - 1]

    def trial_order(self) -> list[int]:
        """The speeds from the median outwards, the slower of two equally far first (a
        multi-start that may stop early tries them in this order; every guess it needs then
        continues from one it already has)."""
        anchor_rank = self.order.index(self.anchor)
        return sorted(range(len(self)), key=lambda i: (abs(self.order.index(i) - anchor_rank), self.order.index(i)))

    def close(self) -> None:
        """Stop the worker process, if any (what it is still solving is abandoned)."""
        if self._worker is not None:
            self._worker.close()
            self._worker = None
            self._pending.clear()
            self._speculative.clear()

    def __enter__(self) -> ContinuedGuesses:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _solve(self, i: int, prev: GaitSolution | None) -> GaitSolution:
        if self._problem is None:
            self._problem = PredictiveGaitProblem(self.settings, self.body)
        pending = self._pending.pop(i, None)
        if prev is None and pending is not None:  # the first start in the worker, the second here
            second = self._problem.solve_start(DEFAULT_STARTS[1], verbose=self.verbose)
            solved = {0: pending.get(), 1: second}
            sol = self._problem.solve_multistart(verbose=self.verbose, agree_rtol=AGREE_RTOL, solved=solved)
            if sol is solved[0]:  # the worker's start: its continuation on speculation is the one needed
                self._pending.update(self._speculative)
            self._speculative.clear()
            return sol
        if prev is None:
            return self._problem.solve_multistart(verbose=self.verbose, agree_rtol=AGREE_RTOL)
        if pending is not None:
            return pending.get()
        return continued_gait(self._problem, prev, self.speeds[i], verbose=self.verbose)

    def _hand_out(self) -> None:
        """Give the worker, in :meth:`trial_order`, every continuation whose starting gait is known."""
        if self._worker is None:
            return
        for j in self.trial_order():
            neighbour = self.neighbour(j)
            if self._solutions[j] is None and j not in self._pending and neighbour is not None:
                prev = self._solutions[neighbour]
                if prev is not None:
                    self._pending[j] = self._worker.continued_gait(prev, self.speeds[j])


def _cache_path(
    cache_dir: str | Path | None, tag: str, speed: float, duration: float, body: BodyParameters, n_nodes: int
) -> Path | None:
    """Where a guess is cached (without suffix), or None without ``cache_dir``."""
    if cache_dir is None:
        return None
    return Path(cache_dir) / f"{tag}_v{speed:.3f}_T{duration:.4f}_H{body.height:.3f}_M{body.mass:.1f}_n{n_nodes}"


def _load_cached(
    path: Path | None, speed: float, duration: float, body: BodyParameters, n_nodes: int
) -> GaitSolution | None:
    """The cached successful guess at ``path`` if its speed, duration, node count and body
    match, else None."""
    if path is None or not path.with_name(path.name + ".npz").exists():
        return None
    cached = GaitSolution.load(path)
    same = (
        cached.success
        and cached.body == body
        and cached.settings.get("n_nodes") == n_nodes
        and math.isclose(cached.speed, speed, abs_tol=1e-9)
        and math.isclose(cached.duration, duration, abs_tol=1e-9)
    )
    return cached if same else None


def roll_cycle(sol: GaitSolution, start: int) -> GaitSolution:
    """The same periodic cycle started at node ``start``: node k of the result is node
    (start + k) mod n of ``sol``; pelvis_tx continues across the wrap by one stride (v·T) and is
    shifted to start at 0. Times, speed and duration are unchanged."""
    n = sol.n_nodes
    idx = (np.arange(n) + start) % n
    q = sol.q[idx].copy()
    q[np.arange(n) + start % n >= n, 0] += sol.stride_length
    q[:, 0] -= q[0, 0]
    return dataclasses.replace(sol, q=q, u=sol.u[idx], qdd=sol.qdd[idx], tau=sol.tau[idx], grf=sol.grf[idx], w=sol.w[idx])


#: Default multi-start of :func:`solve_imu_tracking`: factors on the stride-duration speed guess.
DEFAULT_SPEED_FACTORS: tuple[float, ...] = (0.85, 1.0, 1.2)

#: How the starts of :func:`solve_imu_tracking`'s multi-start are built: "shared" (one
#: predictive NLP for the guesses by speed continuation, :class:`ContinuedGuesses`, and one
#: tracking NLP for all starts, :func:`~predictive.ocp.tracking.track_starts`) or "independent"
#: (a predictive multi-start and a tracking NLP per start).
StartMode = Literal["shared", "independent"]

#: IMU channels tracked by default: every sagittal channel of every IMU.
IMU_SIGNALS: tuple[str, ...] = tuple(imu_columns())


def solve_imu_tracking(
    recording: Recording,
    body: BodyParameters | None = None,
    *,
    n_nodes: int = 100,
    imu_weight: float = 1.0,
    effort_weight: float = 0.01,
    w_acc: float = 0.001,
    speed_guess: float | Sequence[float] | None = None,
    free_speed: bool = True,
    guess: GaitSolution | str = "predictive",
    guess_cache: str | Path | None = None,
    imu_scales: Mapping[str, float | np.ndarray] | str = "auto",
    placement: IMUPlacement | None = None,
    ipopt_options: Mapping[str, Any] | None = None,
    verbose: bool = False,
    raise_on_failure: bool = False,
    heel_strike_tolerance: float | None = 0.05,
    starts: StartMode = "shared",
    agree_rtol: float | None = AGREE_RTOL,
    workers: int | None = None,
    **settings: Any,
) -> TrackingResult:
    """Label-free gait estimation from one averaged stride of IMU data (Dorschky et al. 2019).

    Tracks acc_x, acc_y and gyr_z of every IMU of ``recording`` with virtual IMUs at
    ``placement`` (default: ``recording.placement``, i.e. the positions of the data's meta), plus
    effort, over a full periodic cycle of the data's stride duration with the speed free. Only
    the IMU data (and their across-trial variance), the stride duration and height/mass are
    used — no labels.

    Args:
        recording: one averaged stride starting at right heel strike
            (:func:`sspinn.data.csv_readers.read_averaged_stride` with ``periods=1``).
        body: body parameters (default: Winter scaling from the recording's height and mass).
        n_nodes: collocation nodes per stride.
        imu_weight: weight of every IMU channel.
        effort_weight: weight of the torque effort (dimensionless, see :mod:`predictive.ocp.tracking`).
        w_acc: weight of the q̈ regularisation (the predictive default 0.1 competes with the
            tracked accelerations; 0.1 led to slow-walking local optima in tests).
        speed_guess: initial speed(s), m/s (default: a multi-start from the label-free
            :func:`speed_from_stride_duration` × :data:`DEFAULT_SPEED_FACTORS`). Several values:
            a multi-start — one solve from each, the successful one with the lowest objective is
            returned (label-free choice; see ``heel_strike_tolerance``); all are listed in
            ``result.info["starts"]``. A single
            start is one IPOPT path: on another CPU a 1.2 m/s stride tracked from 1.0 m/s ended at
            0.93 m/s, which the multi-start's lowest objective rules out.
        free_speed: optimise the speed (else it is fixed to the (first) speed guess).
        guess: "predictive" (:func:`predictive_guess` at each speed guess on the same grid,
            ``n_nodes/2`` nodes per half cycle, cached in ``guess_cache``, started at its right
            heel strike like the data: :func:`roll_cycle`), "generic" (data-free textbook shapes)
            or a :class:`GaitSolution` (used as it is).
        imu_scales: "variance" (across-trial standard deviation per sample,
            :func:`averaged_stride_scales`, from ``variance.csv`` in the recording's source
            folder, as Dorschky et al.), "std" (each channel's standard deviation over the
            cycle, :func:`default_scale`), "auto" (variance if that file exists, else std) or a
            mapping channel → scale.
        heel_strike_tolerance: an averaged stride starts at right heel strike (that is how it
            was cut), so a multi-start prefers the solutions whose right heel strike lies within
            this fraction of the cycle of the first sample, the lowest objective among them
            winning (None: the lowest objective alone). On the real averaged walking stride the
            lowest objective alone chose a start whose heel strike came 7.5 % of the cycle early
            (moment correlation r 0.37 instead of 0.63).
        starts: how the multi-start is built (:data:`StartMode`): "shared" (default) solves
            the predictive guesses by speed continuation on one NLP
            (:class:`ContinuedGuesses`: a multi-start at the middle speed only) and every
            start, both continuation steps included, on one tracking NLP and IPOPT solver
            (:func:`~predictive.ocp.tracking.track_starts`); "independent" runs a predictive
            multi-start (:func:`predictive_guess`) and builds a tracking NLP per start. Both
            reach the same optimum on the real and synthetic strides of
            ``benchmarks/speed/bench_imu_tracking.py``; "shared" in less than half the time. With a
            fixed speed the starts are independent.
        agree_rtol: with ``starts="shared"``, the starts run from the middle speed guess
            outwards, the slower first (:meth:`ContinuedGuesses.trial_order`), and stop once two
            successful starts whose heel strike lies within ``heel_strike_tolerance`` reach the
            same objective within this relative tolerance (two IPOPT paths from different
            speeds to one optimum, the rule of the predictive multi-start); the starts left are
            listed with status "skipped" and their guesses are not solved. None: every start runs.
        workers: with ``starts="shared"``, processes for the predictive guesses: 2 hands some of
            them to a worker process (:class:`ContinuedGuesses`; where the platform can fork),
            with the same results; default 2 where this process may use two or more CPU cores
            (:func:`~predictive.ocp.guess_worker.default_workers`), else 1.
        **settings: further :class:`TrackingSettings` fields.

    Returns:
        The tracking result; ``result.solution`` holds angles, torques, GRFs and the speed;
        ``result.info`` the scaling used, the starts, ``processes`` (1, or 2 with a worker for
        the guesses), ``wall_time_s`` (everything: predictive
        guesses, NLP construction, all IPOPT runs), ``guess_time_s`` (the predictive guesses)
        and ``ipopt_time_s`` (all IPOPT runs of the tracking).
    """
    t_start = time.perf_counter()
    body = body if body is not None else BodyParameters.from_anthropometry(recording.height, recording.mass)
    duration = stride_duration(recording)
    if speed_guess is None:
        v0 = speed_from_stride_duration(duration)
        speeds = [v0 * f for f in DEFAULT_SPEED_FACTORS]
    else:
        speeds = [float(v) for v in np.atleast_1d(np.asarray(speed_guess, dtype=float))]
    if isinstance(guess, str) and guess not in ("predictive", "generic"):
        raise ValueError(f"guess must be 'predictive', 'generic' or a GaitSolution, got {guess!r}")
    if starts not in ("shared", "independent"):
        raise ValueError(f"starts must be 'shared' or 'independent', got {starts!r}")
    shared = starts == "shared" and free_speed
    half = max(n_nodes // 2, 4)
    workers = default_workers() if workers is None else workers
    # the guesses first: with a worker, it starts on the middle speed's multi-start at once
    chain = ContinuedGuesses(
        speeds, duration, body, n_nodes=half, cache_dir=guess_cache, workers=workers if shared and guess == "predictive" else 1
    )
    try:
        names = [f"{s}_{c}" for s in recording.segments for c in IMU_CHANNELS]
        scales, scaling = _imu_scales(recording, names, n_nodes, imu_scales)
        signals = signals_from_recording(
            recording, names, n_nodes, duration=duration, scales=scales, weights={n: imu_weight for n in names}
        )
        trial = chain.trial_order() if shared else list(range(len(speeds)))
        t_guess = time.perf_counter()
        guesses: list[GaitSolution | None | Callable[[], GaitSolution]]
        if guess == "predictive" and shared:
            guesses = [functools.partial(_at_heel_strike, chain, i) for i in trial]  # solved when their start runs
        elif guess == "predictive":
            predicted = [predictive_guess(v0, duration, body, n_nodes=half, cache_dir=guess_cache) for v0 in speeds]
            guesses = [roll_cycle(p, p.right_heel_strike()) for p in predicted]
        else:
            guesses = [guess if isinstance(guess, GaitSolution) else None] * len(speeds)
        guess_time = time.perf_counter() - t_guess
        kw: dict[str, Any] = {
            "free_speed": free_speed,
            "effort_weight": effort_weight,
            "w_acc": w_acc,
            "placement": placement if placement is not None else recording.placement,
            "ipopt_options": ipopt_options,
            "verbose": verbose,
            "raise_on_failure": raise_on_failure,
            **settings,
        }
        done: list[TrackingResult | None] = [None] * len(speeds)
        if shared:
            stop = None if agree_rtol is None else functools.partial(_two_agree, rtol=agree_rtol, tolerance=heel_strike_tolerance)
            ran = track_starts(
                signals, duration, float(np.median(speeds)), body, guesses=guesses, start_speeds=[speeds[i] for i in trial],
                stop=stop, **kw
            )
            for i, r in zip(trial, ran):
                done[i] = r
        else:
            done = [track_starts(signals, duration, v0, body, guesses=[g], **kw)[0] for v0, g in zip(speeds, guesses)]
    finally:
        chain.close()
    results = [r for r in done if r is not None]
    guess_time += chain.solve_time_s
    best = min(results, key=lambda r: _start_rank(r.solution, heel_strike_tolerance))
    best.info = {
        "scaling": scaling,
        "guess": guess if isinstance(guess, str) else "solution",
        "starts": [_describe_start(v0, r, r is best) for v0, r in zip(speeds, done)],
        "processes": chain.processes,
        "ipopt_time_s": float(sum(r.solution.solve_time for r in results)),
        "guess_time_s": guess_time,
        "wall_time_s": time.perf_counter() - t_start,
    }
    return best


def _at_heel_strike(chain: ContinuedGuesses, i: int) -> GaitSolution:
    """The guess of start ``i``: the chain's gait at ``speeds[i]`` started at its right heel strike."""
    sol = chain[i]
    return roll_cycle(sol, sol.right_heel_strike())


def _two_agree(results: Sequence[TrackingResult], rtol: float, tolerance: float | None) -> bool:
    """Whether two of the starts ``results`` are successful, in phase (heel strike within
    ``tolerance`` of the first sample) and equal in objective within ``rtol`` (relative)."""
    good = [r.solution.objective for r in results if _start_rank(r.solution, tolerance)[:2] == (False, False)]
    return objectives_agree(good, rtol)


def _describe_start(speed_guess: float, result: TrackingResult | None, chosen: bool) -> dict[str, Any]:
    """One start of the multi-start for ``result.info["starts"]`` (status "skipped": not run)."""
    if result is None:
        return {"speed_guess": speed_guess, "status": "skipped", "chosen": False}
    sol = result.solution
    return {
        "speed_guess": speed_guess,
        "status": sol.status,
        "objective": sol.objective,
        "speed": sol.speed,
        "iterations": sol.iterations,
        "solve_time_s": sol.solve_time,
        "heel_strike_pct": 100.0 * sol.right_heel_strike() / sol.n_nodes,
        "chosen": chosen,
    }


def heel_strike_offset(sol: GaitSolution) -> float:
    """Cyclic distance of the solution's right heel strike from its first node, fraction of the
    cycle (0 … 0.5)."""
    frac = sol.right_heel_strike() / sol.n_nodes
    return float(min(frac, 1.0 - frac))


def _start_rank(sol: GaitSolution, heel_strike_tolerance: float | None) -> tuple[bool, bool, float]:
    """:attr:`GaitSolution.start_rank` with, between success and objective, (with a tolerance)
    solutions whose right heel strike lies at the data's first sample first."""
    off_phase = heel_strike_tolerance is not None and heel_strike_offset(sol) > heel_strike_tolerance
    failed, objective = sol.start_rank
    return (failed, off_phase, objective)


def _imu_scales(
    recording: Recording, names: Sequence[str], n_nodes: int, imu_scales: Mapping[str, float | np.ndarray] | str
) -> tuple[Mapping[str, float | np.ndarray] | None, str]:
    """(scales for :func:`signals_from_recording`, name of the scaling) from ``imu_scales``."""
    if not isinstance(imu_scales, str):
        return imu_scales, "given"
    source = recording.provenance.get("source")
    has_variance = source is not None and (Path(source) / "variance.csv").exists()
    if imu_scales == "variance" or (imu_scales == "auto" and has_variance):
        if not has_variance:
            raise FileNotFoundError(f"{recording.name}: no variance.csv in the recording's source folder {source!r}")
        return averaged_stride_scales(Path(source), names, n_nodes), "variance"
    if imu_scales in ("std", "auto"):
        return None, "std"
    raise ValueError(f"imu_scales must be 'auto', 'variance', 'std' or a mapping, got {imu_scales!r}")
