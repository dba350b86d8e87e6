"""Ctrl-C at a step boundary: a long loop finishes the step it is in, saves, then stops.

``SIGINT`` normally raises :class:`KeyboardInterrupt` wherever the program is, e.g. after the
optimizer has changed the weights but before the step counter moved, or after the next batch's
random numbers were drawn; a checkpoint taken there does not resume to the same result as an
uninterrupted run. :class:`DeferredInterrupt` turns the first Ctrl-C into a request that the loop
checks once per step (:attr:`DeferredInterrupt.requested`); a second Ctrl-C interrupts at once.
Outside the main thread (where signal handlers cannot be installed) it does nothing and
Ctrl-C behaves as usual.
"""

from __future__ import annotations

import signal
import sys
import threading
from types import FrameType
from typing import Any


class DeferredInterrupt:
    """Defer the first SIGINT between :meth:`install` and :meth:`restore` (or as a ``with``)."""

    def __init__(self, message: str = "finishing the current step, then saving (Ctrl-C again to stop at once)") -> None:
        self.message = message
        self.requested = False
        self._previous: Any = None
        self._installed = False

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.requested:  # the second Ctrl-C: stop now
            self.restore()
            raise KeyboardInterrupt
        self.requested = True
        print(f"\ninterrupt: {self.message}", file=sys.stderr, flush=True)

    def install(self) -> DeferredInterrupt:
        if threading.current_thread() is threading.main_thread() and not self._installed:
            self._previous = signal.signal(signal.SIGINT, self._handle)
            self._installed = True
        return self

    def restore(self) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._previous)
            self._installed = False

    def __enter__(self) -> DeferredInterrupt:
        return self.install()

    def __exit__(self, *exc: object) -> None:
        self.restore()
