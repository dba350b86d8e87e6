"""SSPINNpose, the estimator: network (:mod:`~sspinn.estimator.network`), self-supervised losses
(:mod:`~sspinn.estimator.losses`), the foot ZUPT filter (:mod:`~sspinn.estimator.zupt`), training
(:mod:`~sspinn.estimator.training`), model files (:mod:`~sspinn.estimator.model_store`), inference
and streaming (:mod:`~sspinn.estimator.inference`), evaluation against labels
(:mod:`~sspinn.estimator.evaluation`) beside trivial predictors
(:mod:`~sspinn.estimator.trivial_predictors`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("SSPINNpose", "NotFittedError",), "sspinn.estimator.sspinnpose"),
    **dict.fromkeys(("GaitEstimate", "StreamingEstimator", "estimate_recording",), "sspinn.estimator.inference"),
    **dict.fromkeys(("EvaluationError", "Metrics", "compute_metrics", "evaluate",), "sspinn.estimator.evaluation"),
    **dict.fromkeys(("StoredModel", "load_model", "save_model",), "sspinn.estimator.model_store"),
    **dict.fromkeys(("TrainConfig", "adaptation_config",), "sspinn.estimator.training"),
    **dict.fromkeys(("TrivialPredictor",), "sspinn.estimator.trivial_predictors"),
    **dict.fromkeys(("UncertaintyCalibration",), "sspinn.estimator.uncertainty"),
    **dict.fromkeys(("QualityCalibration",), "sspinn.estimator.quality"),
    **dict.fromkeys(("SagittalZuptKalman",), "sspinn.estimator.zupt"),
}
__all__ = [
    "EvaluationError",
    "GaitEstimate",
    "Metrics",
    "NotFittedError",
    "QualityCalibration",
    "SSPINNpose",
    "SagittalZuptKalman",
    "StoredModel",
    "StreamingEstimator",
    "TrainConfig",
    "TrivialPredictor",
    "UncertaintyCalibration",
    "adaptation_config",
    "compute_metrics",
    "estimate_recording",
    "evaluate",
    "load_model",
    "save_model",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from sspinn.estimator.evaluation import EvaluationError, Metrics, compute_metrics, evaluate
    from sspinn.estimator.inference import GaitEstimate, StreamingEstimator, estimate_recording
    from sspinn.estimator.model_store import StoredModel, load_model, save_model
    from sspinn.estimator.quality import QualityCalibration
    from sspinn.estimator.sspinnpose import NotFittedError, SSPINNpose
    from sspinn.estimator.training import TrainConfig, adaptation_config
    from sspinn.estimator.trivial_predictors import TrivialPredictor
    from sspinn.estimator.uncertainty import UncertaintyCalibration
    from sspinn.estimator.zupt import SagittalZuptKalman

__getattr__, __dir__ = attach(__name__, _EXPORTS)
