"""The predictive guesses of IMU tracking on two CPU cores: one worker process beside the caller.

:class:`predictive.ocp.imu_tracking.ContinuedGuesses` solves the middle speed's multi-start and
the speed continuations of its guesses. With a second core it hands some of them to one worker
process (:class:`GuessWorker`) — the first start of the multi-start, the first continuation from
it on speculation (kept when the multi-start chooses that start, as it did on the real and the
synthetic stride of ``benchmarks/speed/bench_imu_tracking.py``), and each other continuation ahead of
the tracking start that needs it — while the caller solves the second start and builds and runs
the tracking NLP. Every solve here is the same code on the same inputs as in the caller
(the problem is rebuilt from its settings and body), and IPOPT is deterministic for given
inputs, so the results are identical to a run on one core (``tests/test_tracking.py``).

The worker keeps the last problem it built, so a continuation reuses the problem and solver of
the start it solved. It is forked from the caller (``fork`` start method: no interpreter to start,
nothing to import, and no ``if __name__ == "__main__"`` guard needed in the caller's script, which
``spawn`` would re-run in the worker); where ``fork`` is not available (:data:`FORK`), the guesses
stay in the caller. The worker runs only CasADi and IPOPT, nothing of the threads the caller may
have started (torch, numba). :meth:`GuessWorker.close` kills it with whatever it is still solving.

While the worker lives, CasADi's own OpenBLAS (``libcasadi-tp-openblas``, which MUMPS calls) runs
one thread in each process: with its default of one thread per core, the two processes' four
threads on two cores made the tracking's IPOPT runs 25 % slower (P03 walking: 10.6–12.0 s per
stride in ``python -m predictive track-imu`` against 8.4–9.0 s with one thread).
"""

from __future__ import annotations

import ctypes
import multiprocessing
import pickle
from multiprocessing.pool import AsyncResult, Pool
from pathlib import Path
from typing import Any

from predictive.ocp.collocation import (
    DEFAULT_STARTS,
    MONOTONE_BARRIER,
    OCPSettings,
    PredictiveGaitProblem,
    solve_predictive,
)
from predictive.ocp.solution import GaitSolution
from sspinn.estimator.cpu_share import usable_cpus
from sspinn.model.body import BodyParameters


def continued_gait(problem: PredictiveGaitProblem, prev: GaitSolution, speed: float, verbose: bool = False) -> GaitSolution:
    """The gait of ``problem`` at ``speed`` (m/s, fixed by its bounds) continued from ``prev``: one
    IPOPT run with the monotone barrier of :data:`~predictive.ocp.collocation.MONOTONE_BARRIER`;
    if it fails, the predictive multi-start at that speed (:func:`~predictive.ocp.collocation.solve_predictive`)."""
    sol = problem.solve(prev, fixed_speed=speed, ipopt_options=MONOTONE_BARRIER, verbose=verbose, raise_on_failure=False)
    if not sol.success:
        s = problem.settings
        sol = solve_predictive(speed, problem.body, n_nodes=s.n_nodes, duration=s.stride_duration, verbose=verbose)
    return sol


#: Whether a worker can be forked on this platform (not on Windows; macOS forks but its default is spawn).
FORK: bool = "fork" in multiprocessing.get_all_start_methods()


def casadi_blas_threads(n: int | None) -> int | None:
    """Set the threads of CasADi's bundled OpenBLAS to ``n`` (None: leave them) and return the
    number before, or None where CasADi bundles no OpenBLAS. Written by hand: threadpoolctl
    recognises BLAS libraries by their usual names, and CasADi's carries its own."""
    import casadi

    path = next(iter(sorted(Path(casadi.__file__).parent.glob("libcasadi-tp-openblas.so*"))), None)
    if path is None:
        return None
    try:
        lib = ctypes.CDLL(str(path))  # the library CasADi loaded already (dlopen counts references)
        before = int(lib.openblas_get_num_threads())
        if n is not None:
            lib.openblas_set_num_threads(int(n))
    except (OSError, AttributeError):
        return None
    return before


def default_workers() -> int:
    """2 where a worker can be forked and this process may use two or more cores, else 1."""
    return 2 if FORK and usable_cpus() >= 2 else 1


class GuessWorker:
    """One worker process solving predictive starts and continuations of one problem
    (``settings``, ``body``); each call returns an ``AsyncResult`` of a :class:`GaitSolution`."""

    def __init__(self, settings: OCPSettings, body: BodyParameters) -> None:
        self.settings, self.body = settings, body
        if not FORK:
            raise RuntimeError("a guess worker needs the 'fork' start method, which this platform lacks")
        self._blas_threads = casadi_blas_threads(1)  # before the fork: the worker inherits it
        self._pool: Pool | None = multiprocessing.get_context("fork").Pool(1)

    def solve_start(self, index: int) -> AsyncResult[GaitSolution]:
        """Start ``index`` of :data:`~predictive.ocp.collocation.DEFAULT_STARTS` (:meth:`PredictiveGaitProblem.solve_start`)."""
        return self._submit(_solve_start, index)

    def continued_gait(self, prev: GaitSolution, speed: float) -> AsyncResult[GaitSolution]:
        """:func:`continued_gait` from ``prev`` to ``speed`` (m/s)."""
        return self._submit(_continued_gait, prev, speed)

    def continued_from_start(self, index: int, speed: float) -> AsyncResult[GaitSolution]:
        """:func:`continued_gait` to ``speed`` (m/s) from the solution of start ``index`` that the
        worker solved (:meth:`solve_start`, submitted before): a continuation on speculation,
        before the caller knows which start its multi-start chooses."""
        return self._submit(_continued_from_start, index, speed)

    def _submit(self, fun: Any, *args: Any) -> AsyncResult[GaitSolution]:
        if self._pool is None:
            raise RuntimeError("the guess worker is closed")
        return self._pool.apply_async(fun, (self.settings, self.body, *args))

    def close(self) -> None:
        """Stop the worker now (a solve still running is abandoned)."""
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None
            casadi_blas_threads(self._blas_threads)


# ------------------------------------------------------------------------------ in the worker
_PROBLEM: tuple[bytes, PredictiveGaitProblem] | None = None
#: The starts this worker solved for its problem, by index.
_STARTS: dict[int, GaitSolution] = {}


def _problem(settings: OCPSettings, body: BodyParameters) -> PredictiveGaitProblem:
    """The worker's problem of ``settings`` and ``body`` (built once, kept for the next task)."""
    global _PROBLEM
    key = pickle.dumps((settings, body))
    if _PROBLEM is None or _PROBLEM[0] != key:
        _PROBLEM = (key, PredictiveGaitProblem(settings, body))
        _STARTS.clear()
    return _PROBLEM[1]


def _solve_start(settings: OCPSettings, body: BodyParameters, index: int) -> GaitSolution:
    _STARTS[index] = _problem(settings, body).solve_start(DEFAULT_STARTS[index])
    return _STARTS[index]


def _continued_from_start(settings: OCPSettings, body: BodyParameters, index: int, speed: float) -> GaitSolution:
    problem = _problem(settings, body)
    return continued_gait(problem, _STARTS[index], speed)


def _continued_gait(settings: OCPSettings, body: BodyParameters, prev: GaitSolution, speed: float) -> GaitSolution:
    return continued_gait(_problem(settings, body), prev, speed)
