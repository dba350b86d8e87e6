"""OpenMP's wait policy, chosen before anything loads OpenMP (see :mod:`envs.kernels`).

A module of its own so that ``python -m agents`` and the benchmarks can ask for passive waiting
before they import the compiled kernels or torch.
"""

from __future__ import annotations

import os


def openmp_loaded() -> bool:
    """Whether GNU OpenMP is already loaded in this process (Linux: ``/proc/self/maps``; torch
    loads it on import), after which its wait policy can no longer be chosen."""
    try:
        with open("/proc/self/maps") as maps:
            return any("libgomp" in line for line in maps)
    except OSError:
        return False


def prefer_passive_openmp() -> bool:
    """Ask for OpenMP threads that wait passively (``OMP_WAIT_POLICY=passive``) if OpenMP is not
    loaded yet and the variable is unset, so that :func:`step_parallel` runs on OpenMP (see
    :func:`_choose_threading_layer`). Call it before anything imports torch (``python -m agents``
    and ``benchmarks/speed/bench_env.py`` do): the policy then also applies to torch's OpenMP threads, whose
    multi-threaded operations then wait passively too (the batched torch environment at N = 4,096
    on 2 threads: 12 k instead of 24 k steps/s; on one thread, the agents' default, unchanged).
    Returns whether the policy is passive."""
    if "OMP_WAIT_POLICY" not in os.environ and not openmp_loaded():
        os.environ["OMP_WAIT_POLICY"] = "passive"
    return os.environ.get("OMP_WAIT_POLICY", "").lower() == "passive"
