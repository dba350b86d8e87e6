"""Trajectory optimisation (CasADi + IPOPT) on the sspinn model: problems, solutions, checks.

* :mod:`~predictive.ocp.settings` — settings, bounds, scales and effort terms shared by the NLPs;
* :mod:`~predictive.ocp.generic_gait` — typical stride duration and the data-free textbook gait;
* :mod:`~predictive.ocp.collocation` — the periodic predictive gait OCP (:func:`solve_predictive`);
* :mod:`~predictive.ocp.tracking` — the same OCP with tracking terms; :mod:`~predictive.ocp.tracking_data`
  turns recordings into tracked signals; :mod:`~predictive.ocp.imu_tracking` is the label-free
  IMU-tracking baseline;
* :mod:`~predictive.ocp.stride_nlp` — the single-stride NLP of the synthetic-data stride chain;
* :mod:`~predictive.ocp.solution` — :class:`GaitSolution`, its persistence and physical checks;
* :mod:`~predictive.ocp.limits` — what the model can be asked and what a solution must satisfy;
* :mod:`~predictive.ocp.perturbation` — floating-point-path perturbations for robustness checks;
* :mod:`~predictive.ocp.gait_analysis` — Winter comparison, normalised cycles, plots;
* :mod:`~predictive.ocp.cli` — ``python -m predictive solve``.
"""
