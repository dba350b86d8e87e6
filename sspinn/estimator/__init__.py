"""SSPINNpose, the estimator: network (:mod:`~sspinn.estimator.network`), self-supervised losses
(:mod:`~sspinn.estimator.losses`), the foot ZUPT filter (:mod:`~sspinn.estimator.zupt`), training
(:mod:`~sspinn.estimator.training`), model files (:mod:`~sspinn.estimator.model_store`), inference
and streaming (:mod:`~sspinn.estimator.inference`), evaluation against labels
(:mod:`~sspinn.estimator.evaluation`) beside trivial predictors
(:mod:`~sspinn.estimator.trivial_predictors`)."""

from __future__ import annotations

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

__getattr__, __dir__ = attach(__name__, _EXPORTS)
