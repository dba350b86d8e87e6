"""Running the synthetic subjects on a joblib backend: its name checked, its progress relayed.

:func:`~predictive.synth.pipeline.generate_dataset` with ``workers > 1`` hands one task per
subject to ``joblib.Parallel`` under :func:`backend_context`. joblib does the scheduling, the
worker processes and the hand-over to other backends, so this module only adds what the
generator needs around it:

* :func:`backend_context` — the backend named in the configuration (``"loky"`` by default),
  checked before any work: an unknown name, a backend that cannot start (``dask`` without a
  client or scheduler) or bad options are one-line :class:`BackendError` s naming the valid ones.
* :class:`ProgressRelay` — the stages that the workers of a backend on this machine
  (:data:`LOCAL_BACKENDS`) report reach the progress bar through a ``multiprocessing`` manager
  queue; workers on other machines cannot reach it, so there the bar moves when a subject is done.

On a cluster: every worker needs this project installed (the same versions) and should see the
same ``cache_dir`` (a shared file system; otherwise each worker solves the template gaits
again), and the call that starts the generation must know the cluster, e.g. with Dask::

    from dask.distributed import Client
    from predictive.synth.config import SynthConfig
    from predictive.synth.pipeline import generate_dataset

    if __name__ == "__main__":
        Client("tcp://scheduler:8786")   # the default client: joblib's "dask" backend uses it
        config = SynthConfig.from_yaml("configs/synth/full.yaml", workers=64, backend="dask")
        generate_dataset(config, "data/synth_full")

or, from the command line, ``backend: dask`` and ``backend_options: {scheduler_host:
"tcp://scheduler:8786"}`` in the YAML file. dask and ray are not dependencies of this project.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable, Iterator, Mapping
from types import TracebackType
from typing import Any, Final

from sspinn.errors import UserError, one_line

#: joblib's backends whose workers run on this machine: progress per stage through a queue.
LOCAL_BACKENDS: Final = frozenset({"loky", "multiprocessing", "threading", "sequential"})


class BackendError(UserError):
    """The configured joblib backend is unknown or cannot start; the message names the valid ones."""


def joblib_backends() -> list[str]:
    """The backend names that joblib knows now: its own, ``dask`` (registered on first use) and
    any that the calling code registered (``joblib.register_parallel_backend``)."""
    from joblib.parallel import BACKENDS, EXTERNAL_BACKENDS

    return sorted({*BACKENDS, *EXTERNAL_BACKENDS})


def check_backend(name: str) -> None:
    """A :class:`BackendError` (one line, naming the valid ones) unless joblib knows ``name``."""
    known = joblib_backends()
    if name not in known:
        raise BackendError(
            f"backend {name!r} is not a joblib backend; valid: {', '.join(known)} "
            "(or one that your own code registers before generating, e.g. ray.util.joblib.register_ray())"
        )


@contextlib.contextmanager
def backend_context(name: str, options: Mapping[str, Any]) -> Iterator[None]:
    """``joblib.parallel_config(backend=name, **options)``, entered; a :class:`BackendError`
    (one line) for an unknown name or a backend that does not start with these options."""
    import joblib

    check_backend(name)
    try:
        config = joblib.parallel_config(backend=name, **dict(options))
    except (ImportError, TypeError, ValueError) as exc:
        raise BackendError(f"backend {name!r} with options {dict(options)} does not start: {one_line(exc)}") from None
    with config:
        yield


class ProgressRelay:
    """Progress messages ``(stage, seconds)`` put by workers on this machine, passed to
    ``on_progress`` in this process by a thread.

    ``with ProgressRelay(on_progress) as queue:`` gives a picklable queue (a
    ``multiprocessing`` manager's) for the workers; leaving the block passes what is left.
    joblib has no progress channel of its own from inside a task, hence this class.
    """

    def __init__(self, on_progress: Callable[[str, float], None]) -> None:
        self.on_progress = on_progress
        self._manager: Any = None
        self._queue: Any = None
        self._thread: threading.Thread | None = None

    def __enter__(self) -> Any:
        import multiprocessing as mp

        self._manager = mp.get_context("spawn").Manager()
        self._queue = self._manager.Queue()
        self._thread = threading.Thread(target=self._drain, name="synth-progress", daemon=True)
        self._thread.start()
        return self._queue

    def _drain(self) -> None:
        while (item := self._queue.get()) is not None:
            self.on_progress(*item)

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        try:
            self._queue.put(None)
            if self._thread is not None:
                self._thread.join()
        finally:
            self._manager.shutdown()
