"""Gait generation without trajectory optimisation, and closed-loop deployment of gait cycles.

* :mod:`~predictive.generator.gait_generator` — the self-supervised gait generator (one network,
  (speed, height, mass) → a periodic gait cycle);
* :mod:`~predictive.generator.closed_loop` — feedforward + periodic LQR tracking of any gait
  cycle (generator or OCP) in the Gymnasium environment, with the gait phase estimated from the
  state and a gain schedule over speed;
* :mod:`~predictive.generator.controllers` — ``controller_for(speed, body)`` of the generator and
  of the OCP (:class:`predictive.controller.ControllerSource`);
* :mod:`~predictive.generator.cli` — ``python -m predictive train-generator`` and ``generate``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("GaitGenerator", "GeneratorConfig", "GeneratorWeights",), "predictive.generator.gait_generator"),
    **dict.fromkeys(("GaitTracker", "LQRWeights", "TrackerSettings",), "predictive.generator.closed_loop"),
    **dict.fromkeys(("GeneratorControllers", "OCPControllers",), "predictive.generator.controllers"),
}
__all__ = [
    "GaitGenerator",
    "GaitTracker",
    "GeneratorConfig",
    "GeneratorControllers",
    "GeneratorWeights",
    "LQRWeights",
    "OCPControllers",
    "TrackerSettings",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from predictive.generator.closed_loop import GaitTracker, LQRWeights, TrackerSettings
    from predictive.generator.controllers import GeneratorControllers, OCPControllers
    from predictive.generator.gait_generator import GaitGenerator, GeneratorConfig, GeneratorWeights

__getattr__, __dir__ = attach(__name__, _EXPORTS)
