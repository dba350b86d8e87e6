"""Physically exact synthetic gait data with ground truth (the sspinn dataset format v1).

Entry point: :func:`predictive.synth.pipeline.generate_dataset` (``python -m predictive synth``,
:mod:`~predictive.synth.cli`). The method is described in :mod:`~predictive.synth.pipeline`;
each step lives in its own module:

* :mod:`~predictive.synth.config` — :class:`~predictive.synth.config.SynthConfig` and its parts (YAML);
* :mod:`~predictive.synth.subjects` — virtual subjects and their true (perturbed) bodies;
* :mod:`~predictive.synth.cache` — the file caches, their keys and ``CODE_VERSION``;
* :mod:`~predictive.synth.gait_library` — periodic gaits (templates, per subject) and their fallbacks;
* :mod:`~predictive.synth.periodic_reference` — periodic gaits resampled to strides (guesses, targets);
* :mod:`~predictive.synth.planning` — stride plans (variability, speed changes);
* :mod:`~predictive.synth.chain` — the chain of stride OCPs and its fallback ladder;
* :mod:`~predictive.synth.recording` — one recording: its chain, labels, IMUs and provenance;
* :mod:`~predictive.synth.pipeline` — subjects and datasets, parallel workers, output.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("SynthConfig",), "predictive.synth.config"),
    **dict.fromkeys(("SynthWarning", "generate_dataset",), "predictive.synth.pipeline"),
    **dict.fromkeys(("standing_recording",), "predictive.synth.standing"),
    **dict.fromkeys(("start_stop_recording",), "predictive.synth.start_stop"),
}
__all__ = [
    "SynthConfig",
    "SynthWarning",
    "generate_dataset",
    "standing_recording",
    "start_stop_recording",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from predictive.synth.config import SynthConfig
    from predictive.synth.pipeline import SynthWarning, generate_dataset
    from predictive.synth.standing import standing_recording
    from predictive.synth.start_stop import start_stop_recording

__getattr__, __dir__ = attach(__name__, _EXPORTS)
