"""How many CPU threads training should use when it shares the machine.

torch's intra-op threads wait for each other at every parallel region; when another program keeps
one of the cores busy, a thread that the kernel has descheduled holds the others up: on a 2-core
machine beside one busy-looping process, the demo configuration's steps ran at 0.26× their rate
alone with two threads and at 0.80× with one. :func:`free_cpus` counts the cores that are not
busy with other work, from the machine's CPU use over a moment (:func:`psutil.cpu_percent`; the
load average lags by a minute); :class:`ThreadShare` applies it at the start of training and again every few hundred
steps, so training takes both cores of an idle machine and steps aside when a neighbour starts.

Why not torch or threadpoolctl alone: neither measures other processes' load, and OpenMP's
``OMP_DYNAMIC`` is not honoured by torch's thread pool; psutil measures the load.
"""

from __future__ import annotations

import psutil


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the platform has one, else all)."""
    try:
        return len(psutil.Process().cpu_affinity())
    except (AttributeError, psutil.Error, OSError):  # no affinity on macOS
        return psutil.cpu_count() or 1


def free_cpus(interval_s: float = 0.2) -> int:
    """Usable CPUs minus those kept busy by other work over the next ``interval_s`` seconds
    (the caller sleeps meanwhile; busy: all CPU time but idle and I/O wait), at least 1."""
    n = usable_cpus()
    busy = psutil.cpu_percent(interval=interval_s) / 100.0 * (psutil.cpu_count() or n)
    return max(1, min(n, round(n - busy)))


class ThreadShare:
    """torch's intra-op thread count for a training loop.

    Args:
        threads: a fixed count (> 0), or 0 for the CPUs not busy with other work, re-measured
            every ``every`` steps (:func:`free_cpus`).
        every: steps between measurements (with ``threads`` 0; each pauses training 50 ms).
    """

    def __init__(self, threads: int, every: int = 1000) -> None:
        self.fixed = threads
        self.every = every
        self.current = threads if threads > 0 else free_cpus()
        import torch  # here, so that usable_cpus and free_cpus serve code without torch (predictive.ocp)

        torch.set_num_threads(self.current)

    def update(self, step: int) -> None:
        """Re-measure at every ``every``-th step (training pauses for the measurement, so only
        other processes' work is counted)."""
        if self.fixed > 0 or step % self.every:
            return
        wanted = free_cpus(interval_s=0.05)
        if wanted != self.current:
            import torch

            self.current = wanted
            torch.set_num_threads(wanted)
