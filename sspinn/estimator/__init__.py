"""SSPINNpose, the estimator: network (:mod:`~sspinn.estimator.network`), self-supervised losses
(:mod:`~sspinn.estimator.losses`), the foot ZUPT filter (:mod:`~sspinn.estimator.zupt`), training
(:mod:`~sspinn.estimator.training`), model files (:mod:`~sspinn.estimator.model_store`), inference
and streaming (:mod:`~sspinn.estimator.inference`), evaluation against labels
(:mod:`~sspinn.estimator.evaluation`) beside trivial predictors
(:mod:`~sspinn.estimator.trivial_predictors`)."""
