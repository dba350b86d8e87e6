"""sspinn: self-supervised physics-informed estimation of sagittal gait from IMUs, and
predictive gait simulation, on one Kane-derived 9-DOF model.

The main job in Python::

    import sspinn
    est = sspinn.SSPINNpose.load("models/pretrained/model.pt")
    estimate = est.predict(sspinn.open_recordings("my_data/walk.csv")[0])

Rooms: :mod:`sspinn.model` (the body model and its backends), :mod:`sspinn.data` (recordings),
:mod:`sspinn.imu` (real 3D IMU import), :mod:`sspinn.estimator` (SSPINNpose); plumbing at the
top (:mod:`sspinn.errors`, :mod:`sspinn.yaml_config`, :mod:`sspinn.run_folder`,
:mod:`sspinn.interrupt`, :mod:`sspinn.torch_files`) and the command line (:mod:`sspinn.cli`).
The names below are imported on first use, so ``import sspinn.model`` stays light (no torch).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

__version__ = "0.1.0"

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    "SSPINNpose": "sspinn.estimator.sspinnpose",
    "GaitEstimate": "sspinn.estimator.inference",
    "load_model": "sspinn.estimator.model_store",
    "evaluate": "sspinn.estimator.evaluation",
    "open_recordings": "sspinn.data.loading",
    "Recording": "sspinn.data.dataset",
    "Dataset": "sspinn.data.dataset",
    "Trajectory": "sspinn.model.trajectory",
    "BodyParameters": "sspinn.model.body",
}
__all__ = [
    "__version__", "SSPINNpose", "GaitEstimate", "load_model", "evaluate", "open_recordings", "Recording", "Dataset",
    "Trajectory", "BodyParameters",
]

if TYPE_CHECKING:
    from sspinn.data.dataset import Dataset, Recording
    from sspinn.data.loading import open_recordings
    from sspinn.estimator.evaluation import evaluate
    from sspinn.estimator.inference import GaitEstimate
    from sspinn.estimator.model_store import load_model
    from sspinn.estimator.sspinnpose import SSPINNpose
    from sspinn.model.body import BodyParameters
    from sspinn.model.trajectory import Trajectory

__getattr__, __dir__ = attach(__name__, _EXPORTS)
