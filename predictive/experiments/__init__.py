"""Experiments that compare the predictive methods with each other and with data.

* :mod:`~predictive.experiments.controller_comparison` — the comparison harness: generator vs
  stable-baselines3 agents vs trajectory optimisation, deployed on the same environment and
  scored by the same code (the only module of ``predictive`` that imports :mod:`agents`);
* :mod:`~predictive.experiments.solution_vs_labels` — a gait solution (e.g. IMU tracking)
  against the labels of an averaged stride and the paper's OCP figures;
* :mod:`~predictive.experiments.cli` — ``python -m predictive track-imu`` and ``compare``.
"""
